// doors_global_localization: global-localization success rates of standard and door-aware MCL in
// the office corridor (paper 001 §V.C, Fig. 8-9), the series behind docs/benchmarks.md.
//
//   doors_global_localization [--irregular] [--into-corridor] [runs] [distance] [counts...]
//
// The corridor is mapped as in lesson 07 (known poses; doors open 90 deg, closed, open 45 deg;
// doors detected and removed from the grid), in its plain form (with closed doors symmetric under
// a half turn) and with a copier alcove that breaks the symmetry. Then, for doors closed and 30
// deg open, the likelihood field's sigma_hit 0.2 m (the tracking default) and 0.8 m, and each
// initial particle count (default 1k 5k 10k 50k), `runs` seeded runs (default 10): the robot
// starts at a random x in [1, 6] m and drives `distance` metres east (default 12); both filters
// start uniform over the free cells and KLD-sampling adapts the count down to 500. A run succeeds
// when the final estimate is within 0.3 m and 0.1 rad and at most 1000 particles are left.
// --irregular moves the doors off their even 5 m spacing; --into-corridor swings them into the
// corridor (as the paper's were). Prints one line per run and setting, then one JSON line.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <rangenav/localization/door_mcl.hpp>
#include <rangenav/localization/mcl.hpp>
#include <rangenav/mapping/doors.hpp>
#include <rangenav/mapping/occupancy_grid.hpp>
#include <rangenav/sim/robot.hpp>
#include <rangenav/sim/sensors.hpp>
#include <rangenav/sim/worlds.hpp>

using namespace rangenav;

namespace {

constexpr double deg = std::numbers::pi / 180;

/// Which way the doors swing (+1 into the offices, -1 into the corridor) and where they are
/// (empty: office_corridor()'s even spacing).
struct Layout {
  int swing{1};
  std::vector<double> centers;
};

sim::Scene corridor(double opening, bool alcove, const Layout& layout) {
  return sim::office_corridor(std::vector<double>(8, layout.swing * opening), alcove,
                              layout.centers);
}

struct CorridorMap {
  OccupancyGrid grid = OccupancyGrid::covering({0, -4}, {20, 6}, 0.5);
  std::vector<DoorModel> doors;
};

/// Lesson 07's three mapping passes (doors open 90 deg, closed, open 45 deg), the doors
/// detected and removed from the grid.
CorridorMap map_corridor(bool alcove, const Layout& layout) {
  CorridorMap m;
  DoorDetector detector;
  const sim::LaserScanner2D laser;
  std::mt19937_64 rng(1);
  ScanClassification c;
  int pass = 0;
  for (const double opening : {90 * deg, 0.0, 45 * deg}) {
    const sim::World world = corridor(opening, alcove, layout).world;
    const bool east = pass++ % 2 == 0;
    for (int k = 0; k <= 94; ++k) {
      const Pose2d pose{east ? 0.6 + 0.2 * k : 19.4 - 0.2 * k, 1.0, east ? 0.0 : std::numbers::pi};
      m.grid.integrate(pose, laser.scan(world, pose, rng), c);
      detector.add(c, m.grid);
    }
  }
  m.doors = detector.doors();
  detector.remove_doors(m.grid);
  return m;
}

/// One run: true when the filter ended within 0.3 m / 0.1 rad with at most 1000 particles.
std::pair<bool, bool> global_run(const sim::World& world, const CorridorMap& map,
                                 std::size_t particles, double distance, double sigma_hit,
                                 std::uint64_t seed) {
  sim::LaserScannerParams lp;
  lp.geometry = ScanGeometry<double>::from_fov(std::numbers::pi, deg_to_rad(1.0), 0.05, 30.0);
  const sim::LaserScanner2D laser(lp);
  sim::DifferentialDriveParams rp;
  rp.odometry.v_scale = 0.03;
  rp.odometry.omega_bias = 0.02;
  rp.odometry.v_sigma = rp.odometry.omega_sigma = 0.05;
  std::mt19937_64 sim_rng(seed), rng_a(seed + 1), rng_b(seed + 1);
  const double start_x = std::uniform_real_distribution<double>(1.0, 6.0)(sim_rng);
  sim::DifferentialDriveRobot robot(rp, {start_x, 1.0, 0.0});
  MclParams mp;
  mp.min_particles = std::min<std::size_t>(500, particles);
  mp.max_particles = particles;
  DoorAwareMclParams dp;
  dp.motion = {0.1, 0.05, 0.1, 0.05};
  dp.field.sigma_hit = sigma_hit;
  dp.sampling = mp;
  MonteCarloLocalization<> mcl(OdometryMotionModel(dp.motion),
                               LikelihoodFieldModel(map.grid, dp.field), mp);
  DoorAwareMcl door_mcl(map.grid, map.doors, dp);
  mcl.initialize_uniform(map.grid, particles, rng_a);
  door_mcl.initialize_uniform(map.grid, particles, rng_b);
  LikelihoodFieldModel::Observation z;
  DoorAwareObservation dz;
  Pose2d last = robot.odometry();
  while (robot.pose().x < start_x + distance) {
    for (int k = 0; k < 10; ++k) {
      const Pose2d& p = robot.pose();
      robot.step(world, 0.5, -1.5 * (p.y - 1.0) - 2.0 * p.theta, sim_rng);
    }
    const auto scan = laser.scan(world, robot.pose(), sim_rng);
    mcl.sensor_model().prepare(scan, Pose2d{}, z);
    door_mcl.prepare(scan, Pose2d{}, dz);
    mcl.update(OdometryReading{last, robot.odometry()}, z, rng_a);
    door_mcl.update(OdometryReading{last, robot.odometry()}, dz, rng_b);
    last = robot.odometry();
  }
  const auto success = [&](const Pose2d& e, std::size_t n) {
    return (e.position() - robot.pose().position()).norm() < 0.3 &&
           std::abs(angle_difference(e.theta, robot.pose().theta)) < 0.1 && n <= 1000;
  };
  return {success(mcl.estimate(), mcl.particle_count()),
          success(door_mcl.estimate(), door_mcl.particle_count())};
}

}  // namespace

int main(int argc, char** argv) {
  Layout layout;
  int i = 1;
  for (; i < argc && std::string(argv[i]).rfind("--", 0) == 0; ++i) {
    const std::string flag = argv[i];
    if (flag == "--irregular")
      layout.centers = {1.4, 6.1, 13.6, 17.9, 3.3, 6.9, 11.2, 16.4};
    else if (flag == "--into-corridor")
      layout.swing = -1;
    else {
      std::cerr << "usage: doors_global_localization [--irregular] [--into-corridor] [runs] "
                   "[distance] [counts...]\n";
      return 2;
    }
  }
  const std::uint64_t runs = i < argc ? std::strtoull(argv[i++], nullptr, 10) : 10;
  const double distance = i < argc ? std::strtod(argv[i++], nullptr) : 12.0;
  std::vector<std::size_t> counts;
  for (; i < argc; ++i)
    counts.push_back(std::strtoull(argv[i], nullptr, 10));
  if (counts.empty()) counts = {1000, 5000, 10000, 50000};

  std::string json;
  for (const bool alcove : {false, true}) {
    const CorridorMap map = map_corridor(alcove, layout);
    std::cout << (alcove ? "corridor with the copier alcove" : "plain corridor") << ": "
              << map.doors.size() << " doors detected\n";
    for (const double sigma_hit : {0.2, 0.8})
      for (const double opening : {0.0, 30 * deg}) {
        const sim::World world = corridor(opening, alcove, layout).world;
        for (const std::size_t n : counts) {
          std::size_t mcl_ok = 0, door_ok = 0;
          for (std::uint64_t r = 0; r < runs; ++r) {
            const auto [a, b] = global_run(world, map, n, distance, sigma_hit, 100 + r);
            mcl_ok += a ? 1 : 0;
            door_ok += b ? 1 : 0;
          }
          const std::string key = std::string(alcove ? "alcove" : "plain") + "_sigma" +
                                  (sigma_hit < 0.5 ? "0.2" : "0.8") +
                                  (opening == 0 ? "_closed_" : "_open30_") + std::to_string(n);
          std::cout << "global localization, " << key << ": MCL " << mcl_ok << "/" << runs
                    << ", door-aware " << door_ok << "/" << runs << "\n"
                    << std::flush;
          json += std::string(json.empty() ? "" : ", ") + "\"" + key + "\": [" +
                  std::to_string(mcl_ok) + ", " + std::to_string(door_ok) + "]";
        }
      }
  }
  std::cout << "{\"doors_swing_into\": \"" << (layout.swing > 0 ? "offices" : "corridor")
            << "\", \"doors_irregular\": " << (layout.centers.empty() ? "false" : "true")
            << ", \"runs\": " << runs << ", \"successes_mcl_door_mcl\": {" << json << "}}\n";
  return 0;
}
