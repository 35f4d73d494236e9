// area_of_interest: the pitching scanner's area of interest adapted to velocity (paper 002 §3.3),
// measured in a drive; lesson 04 shows the maps this scanner feeds at the default nod.
//
//   area_of_interest [seed]
//
// At standstill the scanner nods over its full vertical aperture (walls and ceiling for 3D
// mapping); the faster the robot drives, the more area_of_interest() narrows the pitch range
// towards the virtual corridor (the robot's height band seen from d_min on), so each nod takes
// less time and the ground ahead is looked at again before the robot has driven far. The robot
// drives down a 3 m wide corridor towards a 3-cm box at 0.15, 0.3 and 0.6 m/s, and at 0.6 m/s
// with the standstill pitch range for contrast; for each it prints the pitch range, the nod
// period and the distance driven per nod, the floor look-ahead (the nearest floor the scanner
// sees, pitching_blind_range), where the box first entered the obstacle map and the longest
// drive between two looks at the box. The last line printed is JSON.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/egocentric/pitching_stream.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/sim/robot.hpp"
#include "rangenav/sim/sensors.hpp"
#include "support/range_ahead.hpp"

using namespace rangenav;

namespace {

struct AoiRun {
  double speed{0};            // m/s
  bool adapted{true};         // pitch range from area_of_interest(speed), else the standstill one
  PitchInterval<double> aoi;  // rad, positive looks down
  double nod_s{0};            // one full nod
  double look_ahead_m{0};     // the nearest floor seen: pitching_blind_range(pitch max)
  double first_seen_m{0};     // distance to the box when it entered the obstacle map (0: never)
  double longest_gap_m{0};    // the farthest the robot drove between two looks at the box
};

// The robot drives along a 3 m wide corridor towards a 3-cm box (front face at box_x) at `speed`
// until it is 0.8 m in front of it; the pitching scanner nods over the pitch range `aoi`.
AoiRun drive_towards_box(double speed, const PitchInterval<double>& aoi, bool adapted,
                         std::mt19937& rng) {
  constexpr double box_x = 4.0;
  sim::World world;
  world.add_wall({{-1.0, -1.5}, {8.0, -1.5}});
  world.add_wall({{-1.0, 1.5}, {8.0, 1.5}});
  world.add_box({{box_x + 0.1, 0.0}, {0.2, 0.3}, 0.0, 0.0, 0.03});
  world.build_index();
  sim::PitchingScannerParams pp;  // the simulator's scanner, 1 cm noise
  pp.pitch_min = aoi.min;
  pp.pitch_max = aoi.max;
  const sim::PitchingScanner scanner(pp);
  FloorClassifierParams<double> floor;
  floor.range_noise = pp.noise.sigma;
  floor.steepest_depression = aoi.max;
  PitchingObstacleExtractor<double> extractor(pp.sensor_offset, floor);
  ObstacleMap<double> map;
  AoiRun run{
      speed, adapted, aoi, scanner.nod_period(), pitching_blind_range(pp.sensor_offset, aoi.max),
      0.0};
  Pose2d pose{0, 0, 0}, previous = pose;
  double last_look = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t k = 0; pose.x < box_x - 0.8; ++k) {
    const auto points = extractor.push(scanner.scan(world, pose, scanner.scan_time(k), rng), pose);
    map.update(relative(previous, pose), points);
    const double d = examples::range_ahead(map);
    if (run.first_seen_m == 0 && std::abs(d - (box_x - pose.x)) <= 0.05) run.first_seen_m = d;
    // A look at the box: this scan's obstacle points include some on the box.
    const bool look = std::any_of(points.begin(), points.end(), [&](const Point3d& p) {
      return std::abs(pose.x + p.x() - (box_x + 0.1)) < 0.15 && std::abs(p.y()) < 0.2;
    });
    if (look) {
      if (!std::isnan(last_look))
        run.longest_gap_m = std::max(run.longest_gap_m, pose.x - last_look);
      last_look = pose.x;
    }
    previous = pose;
    pose = sim::DifferentialDriveRobot::integrate(pose, speed, 0.0, pp.scan_period);
  }
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  std::mt19937 rng(argc > 1 ? static_cast<unsigned>(std::strtoul(argv[1], nullptr, 10)) : 2024);
  // The pitch axis is 0.55 m high; at 0.5 m/s and above only the virtual corridor [0, 1] m from
  // d_min = 1 m on is scanned.
  const AreaOfInterestParams<double> aoi_params;
  const double sensor_height = sim::PitchingScannerParams{}.sensor_offset.z();
  std::vector<AoiRun> runs;
  for (const double v : {0.15, 0.3, 0.6})
    runs.push_back(drive_towards_box(v, area_of_interest(v, sensor_height, aoi_params), true, rng));
  runs.push_back(  // the top speed with the standstill pitch range, for contrast
      drive_towards_box(0.6, area_of_interest(0.0, sensor_height, aoi_params), false, rng));
  std::printf("area of interest adapted to velocity (§3.3), 3-cm box ahead in a corridor:\n");
  std::string json = "[";
  for (const AoiRun& r : runs) {
    std::printf(
        "  %.2f m/s %-9s pitch %+6.1f..%+5.1f deg, nod %.2f s = %.2f m driven, floor seen from "
        "%.2f m, box first seen %.2f m ahead, looked at again after at most %.2f m\n",
        r.speed, r.adapted ? "adapted" : "full AOI", rad_to_deg(r.aoi.min), rad_to_deg(r.aoi.max),
        r.nod_s, r.nod_s * r.speed, r.look_ahead_m, r.first_seen_m, r.longest_gap_m);
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "%s{\"speed\": %.2f, \"adapted\": %s, \"pitch_min_deg\": %.1f, "
                  "\"pitch_max_deg\": %.1f, \"nod_s\": %.2f, \"look_ahead_m\": %.2f, "
                  "\"first_seen_m\": %.2f, \"longest_gap_m\": %.2f}",
                  json.size() > 1 ? ", " : "", r.speed, r.adapted ? "true" : "false",
                  rad_to_deg(r.aoi.min), rad_to_deg(r.aoi.max), r.nod_s, r.look_ahead_m,
                  r.first_seen_m, r.longest_gap_m);
    json += buf;
  }
  std::printf("{\"aoi\": %s}\n", (json + "]").c_str());
  return 0;
}
