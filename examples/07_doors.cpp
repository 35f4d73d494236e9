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
//   4. draw the paper's Fig. 4 to doors_out/doors.svg: the grid with the detected doors' angle
//      ranges, and below it the likelihood field of the static map with the door states
//      door-aware MCL estimated (doors 30 deg open); end with one JSON line.
// Run it as `07_doors [seed]`. Global localization (the paper's Fig. 8-9) is measured by
// tools/doors_global_localization.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <rangenav/io/svg.hpp>
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

std::string fixed(double v, int digits = 3) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

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
  std::cout << "mapping: " << dynamic << " dynamic readings, " << vanished << " vanished cells, "
            << detector.potential_leaves().size() << " potential door leaves\n";
  const auto true_doors = corridor(0.0).world.doors();
  for (const DoorModel& d : m.doors) {
    double nearest = 1e9;
    for (const auto& t : true_doors)
      nearest = std::min(nearest, (t.hinge - d.hinge).norm());
    std::cout << "door: hinge (" << fixed(d.hinge.x(), 2) << ", " << fixed(d.hinge.y(), 2)
              << "), leaf " << fixed(d.leaf_length, 2) << " m, opening range "
              << fixed(d.opening_max / deg, 0) << " deg, " << fixed(nearest, 3)
              << " m from the true hinge\n";
  }
  detector.remove_doors(m.grid);  // the static map both filters localize on
  return m;
}

// ---- 3. Localization with both filters -------------------------------------------------------

struct Errors {
  double mean{0}, max{0};
};

struct TrackingResult {
  Errors mcl, door_mcl;
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

// ---- 4. Fig. 4 -------------------------------------------------------------------------------

/// The grid with the doors' angle ranges; `dy` metres below it the sensor model of door-aware MCL
/// over the map, p(z | x, m, doors) of a beam end point every 0.1 m with the doors at `states`
/// (grey levels, darker = more likely, below 2 % of the peak blank) and the estimated leaves.
void draw_fig4(const CorridorMap& m, const std::vector<Pose2d>& path,
               const DoorAwareState& states) {
  io::SvgDrawing svg;
  std::vector<Point2d> occupied;
  for (int y = 0; y < m.grid.height(); ++y)
    for (int x = 0; x < m.grid.width(); ++x)
      if (m.grid.is_occupied({x, y})) occupied.push_back(m.grid.cell_center({x, y}));
  svg.layer("static grid").points(occupied, {.stroke = "black", .point_radius_px = 1.0});
  svg.layer("doors (min / max angle)");
  for (const DoorModel& d : m.doors) {
    svg.segment(d.hinge, d.leaf_end(d.opening_min), {.stroke = "blue", .stroke_width_px = 2});
    svg.segment(d.hinge, d.leaf_end(d.opening_max), {.stroke = "red", .stroke_width_px = 2});
    svg.circle(d.hinge, 0.05, {.stroke = "black", .fill = "black"});
  }
  svg.layer("robot path").path(path, {.stroke = "green"});

  const double dy = m.grid.height() * m.grid.resolution() + 1.0;
  const DoorAwareMcl model(m.grid, m.doors);
  const Point2d lo = m.grid.origin();
  const Point2d hi = lo + Point2d(m.grid.width(), m.grid.height()) * m.grid.resolution();
  std::vector<std::pair<Point2d, double>> samples;
  double peak = 0;
  for (double y = lo.y() + 0.05; y < hi.y(); y += 0.1)
    for (double x = lo.x() + 0.05; x < hi.x(); x += 0.1) {
      const double p = std::exp(model.end_point_log_likelihood({x, y}, states));
      samples.emplace_back(Point2d(x, y - dy), p);
      peak = std::max(peak, p);
    }
  constexpr int levels = 6;
  std::vector<std::vector<Point2d>> by_level(levels);
  for (const auto& [q, p] : samples) {
    const double v = p / peak;
    if (v >= 0.02)
      by_level[static_cast<std::size_t>(std::min(levels - 1.0, std::floor(v * levels)))].push_back(
          q);
  }
  svg.layer("likelihood field, estimated door states");
  for (int l = 0; l < levels; ++l) {  // 0.1 m is about 4.4 px in a 1000 px picture of 22 m
    const int grey = 230 - 230 * (l + 1) / levels;
    const std::string colour = "rgb(" + std::to_string(grey) + "," + std::to_string(grey) + "," +
                               std::to_string(grey) + ")";
    svg.points(by_level[static_cast<std::size_t>(l)], {.stroke = colour, .point_radius_px = 2.3});
  }
  svg.layer("estimated doors (30 deg open)");
  for (std::size_t k = 0; k < m.doors.size(); ++k)
    svg.segment(m.doors[k].hinge - Point2d(0, dy),
                m.doors[k].leaf_end(states.doors[k].mean) - Point2d(0, dy),
                {.stroke = "orange", .stroke_width_px = 1.5});
  svg.text(lo + Point2d(0, m.grid.height() * m.grid.resolution() + 0.3),
           "grid map with the detected doors' minimum (blue) and maximum (red) angles", 14);
  svg.text(lo + Point2d(0, -0.7),
           "likelihood field of the static map with the estimated door states (doors 30 deg open)",
           14);
  std::filesystem::create_directories("doors_out");
  svg.save("doors_out/doors.svg");
  std::cout << "wrote doors_out/doors.svg\n";
}

}  // namespace

int main(int argc, char** argv) {
  const std::uint64_t seed = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 1;
  const CorridorMap map = map_corridor(seed);  // steps 1-2

  struct State {
    const char* name;
    double opening;
  };
  std::string mcl_json, door_json;
  std::vector<Pose2d> drawn_path;
  DoorAwareState drawn_states;  // door estimates of the partially open run, for Fig. 4
  for (const State s : {State{"closed", 0.0}, State{"open", 90 * deg},
                        State{"partially_open", 30 * deg}}) {  // step 3
    const TrackingResult r = track(corridor(s.opening).world, map, seed);
    std::cout << "doors " << s.name << ": standard MCL error mean " << fixed(r.mcl.mean)
              << " m, max " << fixed(r.mcl.max) << " m; door-aware MCL mean "
              << fixed(r.door_mcl.mean) << " m, max " << fixed(r.door_mcl.max) << " m\n";
    const std::string sep = mcl_json.empty() ? "" : ", ";
    mcl_json += sep + "\"" + s.name + "\": " + fixed(r.mcl.mean, 4);
    door_json += sep + "\"" + s.name + "\": " + fixed(r.door_mcl.mean, 4);
    if (drawn_path.empty()) drawn_path = r.truth;
    if (s.opening == 30 * deg) drawn_states = r.door_states;
  }
  draw_fig4(map, drawn_path, drawn_states);  // step 4

  std::cout << "{\"doors_true\": " << corridor(0.0).world.doors().size()
            << ", \"doors_detected\": " << map.doors.size() << ", \"mcl_mean_err_m\": {" << mcl_json
            << "}, \"door_mcl_mean_err_m\": {" << door_json << "}}\n";
  return 0;
}
