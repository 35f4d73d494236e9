// Lesson 04: egocentric obstacle and structure maps from a continuously pitching laser scanner
// (paper 002 §3-4, Fig. 2 and Fig. 6).
//
// A 2D laser sees only its own plane. Here a robot with a horizontal 2D laser 0.30 m above the
// floor and a pitching 2D scanner (SICK LMS 2xx, 181 beams, nodding between -10 and 40 deg)
// approaches four obstacles of the simulated apartment that the 2D laser cannot see: a book lying
// on the floor (3 cm), the couch table's top (0.40-0.44 m, the scan plane passes under it), an
// open drawer (0.55-0.70 m) and a descending stair. For each, it builds
//   - an obstacle map (VirtualMap<ObstacleMapPolicy>): per bearing the nearest reading inside the
//     virtual corridor, floor removed by the neighbourhood classification, stairs turned into
//     artificial obstacles; updated with every 2D scan (transform by odometry, age-out, replace);
//   - a structure map per pitch sweep (VirtualMap<StructureMapPolicy>): per bearing the farthest
//     reading, i.e. the walls;
// and asks each map and the 2D scan whether it holds the obstacle at its true distance.
//
// Run it as `04_virtual_maps [output.svg]` (default: virtual_maps.svg in the working directory).
// The drawing shows, for each obstacle, the obstacle map (left) beside the structure map (right)
// in the robot's frame, like Fig. 6 of the paper. The last line printed is JSON: for each
// obstacle class whether the 2D scan, the obstacle map and the structure map hold it, and the
// median update time (µs) of the obstacle map. How the nod narrows with speed (§3.3) is measured
// by tools/area_of_interest.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "rangenav/egocentric/pitching_stream.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/io/svg.hpp"
#include "rangenav/sim/robot.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"
#include "support/range_ahead.hpp"

using namespace rangenav;

namespace {

struct Target {
  const char* kind;  // the obstacle class of Fig. 2
  const char* name;  // the object in sim::apartment()
  Pose2d stop;       // where the robot stops, facing the object
};

// The true distance from `pose` to the object straight ahead: 2D rays through the robot's height
// band that hit the object's primitives; for the stair, its top edge.
double true_distance(const sim::Scene& scene, const std::string& name, const Pose2d& pose) {
  const auto& obj = scene.object(name);
  if (obj.type == "stair") return std::abs(obj.min.y() - pose.y);  // the robot faces +y there
  double best = std::numeric_limits<double>::infinity();
  for (double z = 0.002; z <= 1.0; z += 0.004) {
    const auto hit = scene.world.cast_ray_2d({pose.x, pose.y},
                                             {std::cos(pose.theta), std::sin(pose.theta)}, z, 10.0);
    if (hit.hit() && obj.contains(sim::PrimitiveRef{hit.kind, hit.index}))
      best = std::min(best, hit.range);
  }
  return best;
}

std::string json_bools(const std::vector<Target>& targets, const std::vector<bool>& found) {
  std::string s = "{";
  for (std::size_t i = 0; i < targets.size(); ++i)
    s += std::string(i ? ", " : "") + "\"" + targets[i].kind +
         "\": " + (found[i] ? "true" : "false");
  return s + "}";
}

/// The pitching scanner of paper 002 §3.3 (the simulator's default: 1 deg per 13.32 ms scan, AOI
/// -10..40 deg, pitch axis 0.55 m high), with the LMS 2xx's 5 mm range noise.
sim::PitchingScannerParams scanner_params() {
  sim::PitchingScannerParams pp;
  pp.noise.sigma = 0.005;
  return pp;
}

/// Whether the 2D scan, the obstacle map and the structure map hold an obstacle.
struct Found {
  bool scan2d, obstacle_map, structure_map;
};

/// The robot drives 0.4 m towards `target` at 0.2 m/s, then the scanner nods once more; every
/// pitched scan updates the obstacle map, every sweep gives a structure map. Each map and a 2D
/// scan are asked whether they hold the obstacle at its true distance (within 5 cm); both maps go
/// into row `row` of the drawing (Fig. 6: obstacle map left, structure map right).
Found approach(const sim::Scene& scene, const Target& target, std::size_t row, std::mt19937& rng,
               io::SvgDrawing& svg, std::vector<double>& update_seconds) {
  const sim::PitchingScannerParams pp = scanner_params();
  const sim::PitchingScanner pitching(pp);
  ObstacleMap<double> obstacle_map;     // 720 bins, corridor [0, 1] m, age-out after 500 moves
  FloorClassifierParams<double> floor;  // thresholds from the scanner's noise (floor.hpp)
  floor.range_noise = pp.noise.sigma;
  PitchingObstacleExtractor<double> extractor(pp.sensor_offset, floor);
  SweepAssembler<double> sweeps(SweepParams<double>{pp.sensor_offset});
  LaserScan<double> structure;
  const Pose2d start = compose(target.stop, Pose2d{-0.4, 0.0, 0.0});
  Pose2d structure_base, pose = start, previous = start;
  const std::size_t scans =
      150 + 2 * static_cast<std::size_t>(pitching.nod_period() / pp.scan_period);
  for (std::size_t k = 0; k < scans; ++k) {
    const auto scan = pitching.scan(scene.world, pose, pitching.scan_time(k), rng);
    const auto points = extractor.push(scan, pose);  // floor removed, stairs as obstacles
    const auto t0 = std::chrono::steady_clock::now();
    obstacle_map.update(relative(previous, pose), points);  // §4.4: transform, age, replace
    update_seconds.push_back(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    if (sweeps.push(scan, pose)) {  // a nod completed: its structure map (§4.3)
      structure = structure_scan(sweeps.sweep());
      structure_base = sweeps.sweep().base_pose;
    }
    previous = pose;
    if (k < 150)
      pose = sim::DifferentialDriveRobot::integrate(pose, 0.4 / (150 * pp.scan_period), 0.0,
                                                    pp.scan_period);
  }
  const LaserScan<double> scan2d = sim::LaserScanner2D().scan(scene.world, pose, rng);  // 0.30 m

  const double truth = true_distance(scene, target.name, pose);
  const double truth_structure = true_distance(scene, target.name, structure_base);
  const double d_obstacle = examples::range_ahead(obstacle_map),
               d_scan = examples::range_ahead(scan2d),
               d_structure = examples::range_ahead(structure);
  const Found found{std::abs(d_scan - truth) <= 0.05, std::abs(d_obstacle - truth) <= 0.05,
                    std::abs(d_structure - truth_structure) <= 0.05};
  std::printf(
      "%-12s %-12s true %.3f m | obstacle map %.3f m (%s) | 2D scan %.3f m (%s) | structure map "
      "%.3f m (%s)\n",
      target.kind, target.name, truth, d_obstacle, found.obstacle_map ? "found" : "missed", d_scan,
      found.scan2d ? "found" : "missed", d_structure, found.structure_map ? "found" : "rejected");

  const Point2d at(0.0, -9.5 * static_cast<double>(row)), right(9.5, 0.0);
  std::vector<Point2d> obs, str, las;  // clipped to 4.5 m around the robot
  const auto add = [](std::vector<Point2d>& out, const Point2d& offset, const auto& cloud) {
    for (const auto& p : cloud)
      if (p.norm() < 4.5) out.push_back(offset + p);
  };
  add(obs, at, obstacle_map.valid_points());
  add(str, at + right, structure.valid_points());
  add(las, at, scan2d.valid_points());
  svg.layer("2D scan at 0.30 m").points(las, {.stroke = "#9ecae1", .point_radius_px = 1.0});
  svg.layer("obstacle map").points(obs, {.stroke = "crimson"});
  svg.layer("structure map").points(str, {.stroke = "#2171b5"});
  svg.layer("robot").pose(Pose2d{at.x(), at.y(), 0.0}, 0.4, {.stroke = "black"});
  svg.layer("robot").pose(Pose2d{at.x() + right.x(), at.y(), 0.0}, 0.4, {.stroke = "black"});
  return found;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string svg_path = argc > 1 ? argv[1] : "virtual_maps.svg";
  const sim::Scene scene = sim::apartment();
  constexpr double half_pi = std::numbers::pi / 2;
  const std::vector<Target> targets = {
      // the obstacle classes of Fig. 2
      {"small_object", "book", {0.8, 2.6, -half_pi}},
      {"table_top", "couch_table", {3.0, 3.3, -half_pi}},
      {"drawer", "drawer", {8.35, 3.5, 0.0}},
      {"stair", "stair", {8.8, 6.0, half_pi}},
  };
  std::mt19937 rng(2024);

  std::vector<bool> in_scan2d, in_obstacle, in_structure;
  std::vector<double> update_seconds;  // per update; the median is robust to preemption
  io::SvgDrawing svg;
  for (std::size_t t = 0; t < targets.size(); ++t) {
    const Found f = approach(scene, targets[t], t, rng, svg, update_seconds);
    in_scan2d.push_back(f.scan2d);
    in_obstacle.push_back(f.obstacle_map);
    in_structure.push_back(f.structure_map);
  }
  svg.save(svg_path);
  std::printf("wrote %s (obstacle maps left, structure maps right, one row per obstacle)\n",
              svg_path.c_str());

  std::nth_element(update_seconds.begin(),
                   update_seconds.begin() + static_cast<std::ptrdiff_t>(update_seconds.size() / 2),
                   update_seconds.end());
  const double update_us = 1e6 * update_seconds[update_seconds.size() / 2];
  std::printf(
      "{\"scan2d\": %s, \"obstacle_map\": %s, \"structure_map\": %s, \"update_us\": %.2f}\n",
      json_bools(targets, in_scan2d).c_str(), json_bools(targets, in_obstacle).c_str(),
      json_bools(targets, in_structure).c_str(), update_us);
  return 0;
}
