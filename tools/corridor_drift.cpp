// The SLAM front end in a corridor whose ends a short-range scanner cannot see: LaserSlam
// (example 03's defaults) drives down a 2 m wide, 83 m long simulated corridor
// (sim::long_corridor), scanning forwards (180° at 1°) to a limited range, with odometry that
// over-reads distance by 1 % (or by what --odometry-scale says) and turns 0.001 rad per step. Along
// the corridor's axis only a few boxes (or nothing) constrain the scans, so the odometry is what
// should carry the pose there (the walls fix the lateral position and the heading). Prints, per
// noise seed, the worst position error against the simulator's truth over 50 scans, and the
// odometry's own error along the axis (1 % of the distance by default).
//
//   corridor_drift [--range R] [--step S] [--bare] [--seeds N] [--odometry-scale F]
//
// Defaults: range 5.6 m (a Hokuyo URG-04LX's), 1.0 m steps, nine boxes along the walls, seeds
// 1-4, odometry scale 1.01 (0.99: it under-reads by 1 %). --bare leaves the walls bare. Last line:
// JSON with the worst error over the seeds. docs/mapping.md gives the figures.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <random>
#include <string>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/mapping/loop_closing_mapper.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

int main(int argc, char** argv) try {
  using rangenav::Point2d;
  using rangenav::Pose2d;
  const char* usage =
      "usage: corridor_drift [--range R] [--step S] [--bare] [--seeds N] [--odometry-scale F]\n";
  double range = 5.6, step = 1.0, odometry_scale = 1.01;
  bool boxes = true;
  unsigned seeds = 4;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--bare") {
      boxes = false;
      continue;
    }
    if (i + 1 >= argc ||
        (arg != "--range" && arg != "--step" && arg != "--seeds" && arg != "--odometry-scale")) {
      std::fprintf(stderr, "corridor_drift: bad option %s\n%s", argv[i], usage);
      return 2;
    }
    char* end = nullptr;
    const double value = std::strtod(argv[++i], &end);
    if (end == argv[i] || *end != '\0' || !(value > 0) || (arg == "--seeds" && value > 1000)) {
      std::fprintf(stderr, "corridor_drift: bad value %s %s (> 0)\n%s", arg.c_str(), argv[i],
                   usage);
      return 2;
    }
    if (arg == "--range") range = value;
    if (arg == "--step") step = value;
    if (arg == "--seeds") seeds = static_cast<unsigned>(value);
    if (arg == "--odometry-scale") odometry_scale = value;
  }

  const rangenav::sim::World world = rangenav::sim::long_corridor(boxes).world;
  rangenav::sim::LaserScannerParams params;
  params.geometry = rangenav::ScanGeometry<double>::from_fov(
      rangenav::deg_to_rad(180.0), rangenav::deg_to_rad(1.0), 0.05, range);
  const rangenav::sim::LaserScanner2D scanner(params);
  constexpr int scans = 50;
  if (step * (scans - 1) > 75) {
    std::fprintf(stderr, "corridor_drift: --step %g drives past the corridor's end\n", step);
    return 2;
  }

  // The route and its odometry are the same for every seed (the seed draws the range noise).
  std::vector<Pose2d> truth(scans), odometry(scans);
  double odometry_worst = 0;
  for (std::size_t i = 1; i < truth.size(); ++i) {
    truth[i] = rangenav::compose(truth[i - 1], {step, 0, 0});
    odometry[i] = rangenav::compose(odometry[i - 1], {step * odometry_scale, 0, 0.001});
    odometry_worst = std::max(odometry_worst, std::abs(odometry[i].x - truth[i].x));
  }

  double worst_of_all = 0;
  for (unsigned seed = 1; seed <= seeds; ++seed) {
    std::mt19937 rng(seed);
    rangenav::LaserSlam<double> slam;
    double worst = 0;
    for (std::size_t i = 0; i < truth.size(); ++i) {
      const auto update =
          slam.process(scanner.scan(world, truth[i], rng), odometry[i].to_isometry());
      worst = std::max(worst, (update.pose.translation() - truth[i].position()).norm());
    }
    std::printf("seed %u: worst error %.3f m over %.1f m (odometry along the axis %.3f m)\n", seed,
                worst, step * (scans - 1), odometry_worst);
    worst_of_all = std::max(worst_of_all, worst);
  }
  std::printf(
      "{\"range_m\":%g,\"step_m\":%g,\"boxes\":%s,\"seeds\":%u,\"worst_error_m\":%.3f,"
      "\"odometry_error_m\":%.3f}\n",
      range, step, boxes ? "true" : "false", seeds, worst_of_all, odometry_worst);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "corridor_drift: %s\n", e.what());
  return 1;
}
