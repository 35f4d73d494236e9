// Lesson 07: doors as movable parts of the map (paper 001, Nieuwenhuisen, Stückler and Behnke).
//
// Standard Monte-Carlo localization assumes a static map, yet in an office corridor the doors move
// and change what the laser sees. In this lesson we rebuild the paper's simulated experiment in
// the office corridor of rangenav::sim:
//   1. map the corridor with known poses three times, with the doors open 90 deg, then closed,
//      then open 45 deg: readings in cells once seen free are dynamic, and so are seen-occupied
//      cells that turn free (OccupancyGrid, §III);
//   2. find lines in the dynamic points and doors where lines turn about a common hinge
//      (DoorDetector), then remove the doors' cells from the static grid;
//   3. drive the corridor with the doors closed, open and partially open, and localize with
//      standard MCL (doors removed from the map) and with door-aware MCL (a Kalman-filtered angle
//      per door in every particle, §IV), printing the mean and maximum position errors;
//   4. draw the paper's Fig. 4 to doors_out/doors.svg (support/door_figure.hpp): the grid with
//      the detected doors' angle ranges, and below it the likelihood field of the static map with
//      the door states door-aware MCL estimated (doors 30 deg open); end with one JSON line.
// Run it as `07_doors [seed]`. Global localization (the paper's Fig. 8-9) is measured by
// tools/doors_global_localization.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

#include <rangenav/localization/door_mcl.hpp>
#include <rangenav/localization/mcl.hpp>
#include <rangenav/mapping/doors.hpp>
#include <rangenav/mapping/occupancy_grid.hpp>
#include <rangenav/sim/robot.hpp>
#include <rangenav/sim/sensors.hpp>
#include <rangenav/sim/worlds.hpp>

#include "support/door_figure.hpp"

using namespace rangenav;

namespace {

constexpr double deg = std::numbers::pi / 180;

/// The office corridor with all 8 doors at `opening` (rad; positive: into the offices).
sim::Scene corridor(double opening) {
  return sim::office_corridor(std::vector<double>(8, opening));
}

// ---- 1-2. Mapping with known poses, and the doors --------------------------------------------

struct CorridorMap {
  OccupancyGrid grid = OccupancyGrid::covering({0, -4}, {20, 6}, 0.5);
  std::vector<DoorModel> doors;
};

CorridorMap map_corridor(std::uint64_t seed) {
  CorridorMap m;
  DoorDetector detector;
  const sim::LaserScanner2D laser;  // SICK S300: 270 deg, 541 beams
  std::mt19937_64 rng(seed);
  ScanClassification c;  // reused: what integrate() found in each scan
  std::size_t dynamic = 0, vanished = 0;
  const std::vector<double> passes = {90 * deg, 0.0, 45 * deg};
  for (std::size_t pass = 0; pass < passes.size(); ++pass) {
    const sim::Scene scene = corridor(passes[pass]);
    for (int k = 0; k <= 94; ++k) {  // along the centre line, east then west then east
      const bool east = pass % 2 == 0;
      const Pose2d pose{east ? 0.6 + 0.2 * k : 19.4 - 0.2 * k, 1.0, east ? 0.0 : std::numbers::pi};
      m.grid.integrate(pose, laser.scan(scene.world, pose, rng), c);  // classify, then map
      dynamic += c.dynamic_points.size();
      vanished += c.vanished_points.size();
      detector.add(c, m.grid);  // line objects of the dynamic points; doors turning about hinges
    }
  }
  m.doors = detector.doors();
  std::printf("mapping: %zu dynamic readings, %zu vanished cells, %zu potential door leaves\n",
              dynamic, vanished, detector.potential_leaves().size());
  const auto true_doors = corridor(0.0).world.doors();
  for (const DoorModel& d : m.doors) {
    double nearest = 1e9;
    for (const auto& t : true_doors)
      nearest = std::min(nearest, (t.hinge - d.hinge).norm());
    std::printf(
        "door: hinge (%.2f, %.2f), leaf %.2f m, opening range %.0f deg, %.3f m from the "
        "true hinge\n",
        d.hinge.x(), d.hinge.y(), d.leaf_length, d.opening_max / deg, nearest);
  }
  detector.remove_doors(m.grid);  // the static map both filters localize on
  return m;
}

// ---- 3. Localization with both filters -------------------------------------------------------

struct Errors {
  double mean{0}, max{0};  // position error (m)
};
struct TrackingResult {
  Errors mcl, door_mcl;  // standard and door-aware MCL
  std::vector<Pose2d> truth;
  DoorAwareState door_states;  ///< door-aware MCL's door angle estimates at the end
};

TrackingResult track(const sim::World& world, const CorridorMap& map, std::uint64_t seed) {
  sim::LaserScannerParams lp;  // 181 beams over 180 deg
  lp.geometry = ScanGeometry<double>::from_fov(std::numbers::pi, deg_to_rad(1.0), 0.05, 30.0);
  const sim::LaserScanner2D laser(lp);
  sim::DifferentialDriveParams rp;  // odometry 3 % long, drifting and noisy
  rp.odometry.v_scale = 0.03;
  rp.odometry.omega_bias = 0.02;
  rp.odometry.v_sigma = rp.odometry.omega_sigma = 0.05;
  sim::DifferentialDriveRobot robot(rp, {1.0, 1.0, 0.0});
  // Both filters share every parameter except those of the door states, as in §V.B.
  const OdometryMotionParams motion{0.1, 0.05, 0.1, 0.05};
  MclParams mp;
  mp.min_particles = mp.max_particles = 500;
  mp.adapt_particle_count = false;
  MonteCarloLocalization<> mcl(OdometryMotionModel(motion), LikelihoodFieldModel(map.grid), mp);
  DoorAwareMclParams dp;
  dp.motion = motion;
  dp.sampling = mp;
  DoorAwareMcl door_mcl(map.grid, map.doors, dp);
  std::mt19937_64 sim_rng(seed), rng_a(seed + 1), rng_b(seed + 1);
  mcl.initialize_gaussian(robot.pose(), {0.05, 0.05, 0.02}, 500, rng_a);
  door_mcl.initialize_gaussian(robot.pose(), {0.05, 0.05, 0.02}, 500, rng_b);
  LikelihoodFieldModel::Observation z;  // scans prepared once for all particles
  DoorAwareObservation dz;
  Pose2d last = robot.odometry();
  TrackingResult r;
  int n = 0;
  while (robot.pose().x < 18.5) {
    for (int k = 0; k < 10; ++k) {  // 0.2 s at 0.5 m/s, keeping to the centre line
      const Pose2d& p = robot.pose();
      robot.step(world, 0.5, -1.5 * (p.y - 1.0) - 2.0 * p.theta, sim_rng);
    }
    const auto scan = laser.scan(world, robot.pose(), sim_rng);
    mcl.sensor_model().prepare(scan, Pose2d{}, z);
    door_mcl.prepare(scan, Pose2d{}, dz);
    const OdometryReading u{last, robot.odometry()};
    mcl.update(u, z, rng_a);
    door_mcl.update(u, dz, rng_b);
    last = robot.odometry();
    const double a = (mcl.estimate().position() - robot.pose().position()).norm();
    const double b = (door_mcl.estimate().position() - robot.pose().position()).norm();
    r.mcl = {r.mcl.mean + a, std::max(r.mcl.max, a)};
    r.door_mcl = {r.door_mcl.mean + b, std::max(r.door_mcl.max, b)};
    r.truth.push_back(robot.pose());
    ++n;
  }
  r.mcl.mean /= n;
  r.door_mcl.mean /= n;
  for (std::size_t k = 0; k < map.doors.size(); ++k)
    r.door_states.doors[k] = door_mcl.door_estimate(k);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  const std::uint64_t seed = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 1;
  const CorridorMap map = map_corridor(seed);  // steps 1-2

  const std::vector<std::pair<const char*, double>> door_states = {
      {"closed", 0.0}, {"open", 90 * deg}, {"partially_open", 30 * deg}};
  std::vector<TrackingResult> runs;
  for (const auto& [name, opening] : door_states) {  // step 3
    const TrackingResult& r = runs.emplace_back(track(corridor(opening).world, map, seed));
    std::printf(
        "doors %s: standard MCL error mean %.3f m, max %.3f m; door-aware MCL mean %.3f m, max "
        "%.3f m\n",
        name, r.mcl.mean, r.mcl.max, r.door_mcl.mean, r.door_mcl.max);
  }
  // Step 4: Fig. 4 with the door states estimated in the run with the doors 30 deg open.
  examples::draw_door_figure(map.grid, map.doors, runs[0].truth, runs[2].door_states,
                             "doors_out/doors.svg");
  std::printf("wrote doors_out/doors.svg\n");

  std::printf(
      "{\"doors_true\": %zu, \"doors_detected\": %zu, \"mcl_mean_err_m\": {\"closed\": %.4f, "
      "\"open\": %.4f, \"partially_open\": %.4f}, \"door_mcl_mean_err_m\": {\"closed\": %.4f, "
      "\"open\": %.4f, \"partially_open\": %.4f}}\n",
      corridor(0.0).world.doors().size(), map.doors.size(), runs[0].mcl.mean, runs[1].mcl.mean,
      runs[2].mcl.mean, runs[0].door_mcl.mean, runs[1].door_mcl.mean, runs[2].door_mcl.mean);
  return 0;
}
