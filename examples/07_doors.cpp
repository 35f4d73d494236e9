// Lesson 07: doors as movable parts of the map (paper 001, Nieuwenhuisen, Stückler and Behnke).
//
// Standard Monte-Carlo localization assumes a static map, yet in an office corridor the doors move
// and change what the laser sees. In this lesson we rebuild the paper's simulated experiments in
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
// `07_doors --global [runs] [distance] [particle counts...]` instead measures global-localization
// success rates of both filters (the paper's Fig. 8-9) with doors closed and 30 deg open, in the
// plain corridor (symmetric under a half turn) and with a copier alcove that breaks the symmetry,
// with the likelihood field's sigma_hit 0.2 m and 0.8 m (defaults: 10 runs, 12 m, 1k 5k 10k 50k
// particles).
//
// `--irregular` (before the other arguments) moves the doors off their even 5 m spacing (south
// doors centred at x = 1.4, 6.1, 13.6, 17.9, north ones at 3.3, 6.9, 11.2, 16.4), as in a real
// corridor, where one office does not look like the next.
// `--into-corridor` (before the other arguments) swings the doors into the corridor instead of
// into the offices, as the doors of the paper's corridor did (its robot had to drive "two tight
// curves" around open doors). The mapping passes are the same (open 90 deg, closed, open 45 deg;
// the mapping poses are given, the robot does not drive past the doors) and the lesson localizes
// with the doors closed and 30 deg open (wider openings block the robot's way).
//
// Run it as `07_doors [--irregular] [--into-corridor] [seed]`.

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
#include <utility>
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

struct Errors {
  double mean{0}, max{0};
};

struct TrackingResult {
  Errors mcl, door_mcl;
  std::vector<Pose2d> truth;
  DoorAwareState door_states;  ///< door-aware MCL's door angle estimates at the end (pose unused)
};

TrackingResult track(const sim::World& world, const OccupancyGrid& grid,
                     const std::vector<DoorModel>& doors, std::uint64_t seed) {
  sim::LaserScannerParams lp;  // 181 beams over 180 deg
  lp.geometry = ScanGeometry<double>::from_fov(std::numbers::pi, deg_to_rad(1.0), 0.05, 30.0);
  const sim::LaserScanner2D laser(lp);
  sim::DifferentialDriveParams rp;  // odometry with scale, drift and noise
  rp.odometry.v_scale = 0.03;
  rp.odometry.omega_bias = 0.02;
  rp.odometry.v_sigma = 0.05;
  rp.odometry.omega_sigma = 0.05;
  sim::DifferentialDriveRobot robot(rp, {1.0, 1.0, 0.0});
  // Both filters share every parameter except those of the door states, as in §V.B.
  const OdometryMotionParams motion{0.1, 0.05, 0.1, 0.05};
  const std::size_t particles = 500;
  MclParams mp;
  mp.min_particles = mp.max_particles = particles;
  mp.adapt_particle_count = false;
  MonteCarloLocalization<> mcl(OdometryMotionModel(motion), LikelihoodFieldModel(grid), mp);
  DoorAwareMclParams dp;
  dp.motion = motion;
  dp.sampling = mp;
  DoorAwareMcl door_mcl(grid, doors, dp);
  std::mt19937_64 sim_rng(seed), rng_a(seed + 1), rng_b(seed + 1);
  mcl.initialize_gaussian(robot.pose(), {0.05, 0.05, 0.02}, particles, rng_a);
  door_mcl.initialize_gaussian(robot.pose(), {0.05, 0.05, 0.02}, particles, rng_b);
  LikelihoodFieldModel::Observation z;
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
    const Point2d truth = robot.pose().position();
    const double a = (mcl.estimate().position() - truth).norm();
    const double b = (door_mcl.estimate().position() - truth).norm();
    r.mcl.mean += a;
    r.door_mcl.mean += b;
    r.mcl.max = std::max(r.mcl.max, a);
    r.door_mcl.max = std::max(r.door_mcl.max, b);
    r.truth.push_back(robot.pose());
    ++n;
  }
  r.mcl.mean /= n;
  r.door_mcl.mean /= n;
  for (std::size_t k = 0; k < doors.size(); ++k)
    r.door_states.doors[k] = door_mcl.door_estimate(k);
  return r;
}

/// Fig. 4 of paper 001, bottom: the sensor model of door-aware MCL over the map, p(z_j | x, m,
/// doors) of a beam end point at every 0.1 m, with the doors at the given estimated states; drawn
/// `dy` metres below the grid as grey levels (darker = more likely; below 2 % of the peak: blank).
void draw_likelihood_panel(io::SvgDrawing& svg, const OccupancyGrid& grid,
                           const std::vector<DoorModel>& doors, const DoorAwareState& states,
                           double dy) {
  const DoorAwareMcl model(grid, doors);
  const double step = 0.1;
  std::vector<std::pair<Point2d, double>> samples;
  double peak = 0;
  const Point2d lo = grid.origin();
  const Point2d hi = lo + Point2d(grid.width(), grid.height()) * grid.resolution();
  for (double y = lo.y() + step / 2; y < hi.y(); y += step)
    for (double x = lo.x() + step / 2; x < hi.x(); x += step) {
      const double p = std::exp(model.end_point_log_likelihood({x, y}, states));
      samples.emplace_back(Point2d(x, y - dy), p);
      peak = std::max(peak, p);
    }
  constexpr int levels = 6;
  std::vector<std::vector<Point2d>> by_level(levels);
  for (const auto& [q, p] : samples) {
    const double v = p / peak;
    if (v < 0.02) continue;
    by_level[static_cast<std::size_t>(std::min(levels - 1.0, std::floor(v * levels)))].push_back(q);
  }
  svg.layer("likelihood field, estimated door states");
  // About 44 px per metre in a 1000 px picture of ~22 m: a 0.1 m sample is ~4.4 px wide.
  for (int l = 0; l < levels; ++l) {
    const int grey = 230 - 230 * (l + 1) / levels;
    std::ostringstream colour;
    colour << "rgb(" << grey << "," << grey << "," << grey << ")";
    svg.points(by_level[static_cast<std::size_t>(l)],
               {.stroke = colour.str(), .point_radius_px = 2.3});
  }
}

/// One global-localization run's outcome for one filter.
struct GlobalOutcome {
  bool success{false};
  double error_m{0}, error_rad{0};
  std::size_t particles{0};
};

/// Global localization (§V.C): both filters start uniform over the free cells with `particles`
/// particles; KLD-sampling then adapts the count to the pose uncertainty (down to 500) while the
/// robot drives `distance` metres east along the corridor from a random x in [1, 6]. A run
/// succeeds when, at the end, the estimate is within 0.3 m and 0.1 rad of the truth and the
/// particle count has fallen to at most 1000 (the paper: "the localization error and the number
/// of particles falls below a threshold").
std::pair<GlobalOutcome, GlobalOutcome> global_run(const sim::World& world,
                                                   const OccupancyGrid& grid,
                                                   const std::vector<DoorModel>& doors,
                                                   std::size_t particles, double distance,
                                                   double sigma_hit, std::uint64_t seed) {
  sim::LaserScannerParams lp;
  lp.geometry = ScanGeometry<double>::from_fov(std::numbers::pi, deg_to_rad(1.0), 0.05, 30.0);
  const sim::LaserScanner2D laser(lp);
  sim::DifferentialDriveParams rp;
  rp.odometry.v_scale = 0.03;
  rp.odometry.omega_bias = 0.02;
  rp.odometry.v_sigma = 0.05;
  rp.odometry.omega_sigma = 0.05;
  std::mt19937_64 sim_rng(seed), rng_a(seed + 1), rng_b(seed + 1);
  const double start_x = std::uniform_real_distribution<double>(1.0, 6.0)(sim_rng);
  sim::DifferentialDriveRobot robot(rp, {start_x, 1.0, 0.0});
  const OdometryMotionParams motion{0.1, 0.05, 0.1, 0.05};
  MclParams mp;
  mp.min_particles = std::min<std::size_t>(500, particles);
  mp.max_particles = particles;
  LikelihoodFieldParams field;
  field.sigma_hit = sigma_hit;
  MonteCarloLocalization<> mcl(OdometryMotionModel(motion), LikelihoodFieldModel(grid, field), mp);
  DoorAwareMclParams dp;
  dp.motion = motion;
  dp.field = field;
  dp.sampling = mp;
  DoorAwareMcl door_mcl(grid, doors, dp);
  mcl.initialize_uniform(grid, particles, rng_a);
  door_mcl.initialize_uniform(grid, particles, rng_b);
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
    const OdometryReading u{last, robot.odometry()};
    mcl.update(u, z, rng_a);
    door_mcl.update(u, dz, rng_b);
    last = robot.odometry();
  }
  const auto outcome = [&](const Pose2d& e, std::size_t n) {
    GlobalOutcome o;
    o.error_m = (e.position() - robot.pose().position()).norm();
    o.error_rad = std::abs(angle_difference(e.theta, robot.pose().theta));
    o.particles = n;
    o.success = o.error_m < 0.3 && o.error_rad < 0.1 && n <= 1000;
    return o;
  };
  return {outcome(mcl.estimate(), mcl.particle_count()),
          outcome(door_mcl.estimate(), door_mcl.particle_count())};
}

std::string fixed(double v, int digits = 3) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

/// Step 1-2: the corridor (`alcove`: with its copier alcove) mapped with known poses while the
/// doors change between passes (open 90 deg, closed, open 45 deg), the doors detected and removed
/// from the static grid. Prints what it found when `verbose`.
struct CorridorMap {
  OccupancyGrid grid;
  std::vector<DoorModel> doors;
  std::size_t true_doors{0};
};

/// Where the doors are and which way they swing: `swing` +1 into the offices, -1 into the
/// corridor; `centers` empty: evenly spaced (office_corridor()'s door_centers).
struct Layout {
  int swing{1};
  std::vector<double> centers;
};

/// The corridor with every door at `opening` (rad, into the side `layout.swing` says).
sim::Scene corridor(double opening, bool alcove, const Layout& layout) {
  return sim::office_corridor(std::vector<double>(8, layout.swing * opening), alcove,
                              layout.centers);
}

CorridorMap map_corridor(bool alcove, std::uint64_t seed, bool verbose, const Layout& layout) {
  const std::vector<double> passes = {90 * deg, 0.0, 45 * deg};
  CorridorMap m{OccupancyGrid::covering({0, -4}, {20, 6}, 0.5), {}, 0};
  DoorDetector detector;
  const sim::LaserScanner2D mapping_laser;  // SICK S300: 270 deg, 541 beams
  std::mt19937_64 rng(seed);
  ScanClassification c;
  std::size_t dynamic = 0, vanished = 0;
  std::vector<sim::Door> true_doors;
  for (std::size_t pass = 0; pass < passes.size(); ++pass) {
    const sim::Scene scene = corridor(passes[pass], alcove, layout);
    true_doors = scene.world.doors();
    for (int k = 0; k <= 94; ++k) {
      const bool east = pass % 2 == 0;
      const Pose2d pose{east ? 0.6 + 0.2 * k : 19.4 - 0.2 * k, 1.0, east ? 0.0 : std::numbers::pi};
      m.grid.integrate(pose, mapping_laser.scan(scene.world, pose, rng), c);
      dynamic += c.dynamic_points.size();
      vanished += c.vanished_points.size();
      detector.add(c, m.grid);
    }
  }
  m.doors = detector.doors();
  m.true_doors = true_doors.size();
  if (verbose) {
    std::cout << "mapping: " << dynamic << " dynamic readings, " << vanished << " vanished cells, "
              << detector.potential_leaves().size() << " potential door leaves\n";
    // Doors: where lines turned about a common hinge.
    for (const DoorModel& d : m.doors) {
      double nearest = 1e9;
      for (const auto& t : true_doors)
        nearest = std::min(nearest, (t.hinge - d.hinge).norm());
      std::cout << "door: hinge (" << fixed(d.hinge.x(), 2) << ", " << fixed(d.hinge.y(), 2)
                << "), leaf " << fixed(d.leaf_length, 2) << " m, opening range "
                << fixed(d.opening_max / deg, 0) << " deg, " << fixed(nearest, 3)
                << " m from the true hinge\n";
    }
  }
  detector.remove_doors(m.grid);
  return m;
}

/// `07_doors --global [runs] [distance] [counts...]`: global-localization success rates of both
/// filters (the paper's Fig. 8-9) in the plain (symmetric) corridor and in the corridor with its
/// copier alcove, with the likelihood field's sigma_hit at the tracking default (0.2 m) and
/// widened to 0.8 m, doors closed and 30 deg open. Slow: see benchmarks/README.md.
int run_global(int argc, char** argv, const Layout& layout) {
  const std::uint64_t runs = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 10;
  const double distance = argc > 3 ? std::strtod(argv[3], nullptr) : 12.0;
  std::vector<std::size_t> counts;
  for (int i = 4; i < argc; ++i)
    counts.push_back(std::strtoull(argv[i], nullptr, 10));
  if (counts.empty()) counts = {1000, 5000, 10000, 50000};
  std::string json;
  for (const bool alcove : {false, true}) {
    const CorridorMap map = map_corridor(alcove, 1, false, layout);
    std::cout << (alcove ? "corridor with the copier alcove" : "plain corridor") << ": "
              << map.doors.size() << " of " << map.true_doors << " doors detected\n";
    for (const double sigma_hit : {0.2, 0.8})
      for (const double opening : {0.0, 30 * deg}) {
        const sim::Scene scene = corridor(opening, alcove, layout);
        for (const std::size_t n : counts) {
          std::size_t mcl_ok = 0, door_ok = 0;
          for (std::uint64_t r = 0; r < runs; ++r) {
            const auto [a, b] =
                global_run(scene.world, map.grid, map.doors, n, distance, sigma_hit, 100 + r);
            mcl_ok += a.success ? 1 : 0;
            door_ok += b.success ? 1 : 0;
            std::cout << "  run " << r << ": MCL " << fixed(a.error_m, 2) << " m "
                      << fixed(a.error_rad, 2) << " rad " << a.particles
                      << " particles; door-aware " << fixed(b.error_m, 2) << " m "
                      << fixed(b.error_rad, 2) << " rad " << b.particles << " particles\n"
                      << std::flush;
          }
          const std::string key = std::string(alcove ? "alcove" : "plain") + "_sigma" +
                                  fixed(sigma_hit, 1) + (opening == 0 ? "_closed_" : "_open30_") +
                                  std::to_string(n);
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
            << ", \"runs\": " << runs << ", \"distance_m\": " << fixed(distance, 1)
            << ", \"successes_mcl_door_mcl\": {" << json << "}}\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // `--irregular`: doors off their even spacing; `--into-corridor`: doors swing into the
  // corridor.
  Layout layout;
  for (bool more = true; more && argc > 1;) {
    const std::string flag = argv[1];
    more = flag == "--irregular" || flag == "--into-corridor";
    if (flag == "--irregular") layout.centers = {1.4, 6.1, 13.6, 17.9, 3.3, 6.9, 11.2, 16.4};
    if (flag == "--into-corridor") layout.swing = -1;
    if (more) {
      --argc;
      ++argv;
    }
  }
  const int swing = layout.swing;
  // `07_doors --global runs distance n1 n2 ...`: the global-localization success rates instead of
  // the default lesson (slow: see benchmarks/README.md).
  const bool global = argc > 1 && std::string(argv[1]) == "--global";
  const std::uint64_t seed = argc > 1 && !global ? std::strtoull(argv[1], nullptr, 10) : 1;

  // 1-2. Mapping with known poses while the doors change between passes; the doors.
  if (global) return run_global(argc, argv, layout);
  const CorridorMap map = map_corridor(false, seed, true, layout);
  const OccupancyGrid& grid = map.grid;
  const std::vector<DoorModel>& doors = map.doors;

  // 3. Localization with both filters for three door states.
  struct State {
    const char* name;
    double opening;
  };
  std::vector<State> states = {{"closed", 0.0}, {"open", 90 * deg}, {"partially_open", 30 * deg}};
  if (swing < 0) states.erase(states.begin() + 1);  // open into the corridor: no way past
  std::string mcl_json, door_json;
  std::vector<Pose2d> drawn_path;
  DoorAwareState drawn_states;  // door estimates of the partially open run, for Fig. 4 bottom
  for (const State& s : states) {
    const sim::Scene scene = corridor(s.opening, false, layout);
    const TrackingResult r = track(scene.world, grid, doors, seed);
    std::cout << "doors " << s.name << ": standard MCL error mean " << fixed(r.mcl.mean)
              << " m, max " << fixed(r.mcl.max) << " m; door-aware MCL mean "
              << fixed(r.door_mcl.mean) << " m, max " << fixed(r.door_mcl.max) << " m\n";
    const std::string sep = mcl_json.empty() ? "" : ", ";
    mcl_json += sep + "\"" + s.name + "\": " + fixed(r.mcl.mean, 4);
    door_json += sep + "\"" + s.name + "\": " + fixed(r.door_mcl.mean, 4);
    if (drawn_path.empty()) drawn_path = r.truth;
    if (s.opening == 30 * deg) drawn_states = r.door_states;
  }

  // 4. Fig. 4: top, the grid with the doors' angle ranges; bottom, the likelihood field of the
  // static map with the door states door-aware MCL estimated in the partially open run.
  io::SvgDrawing svg;
  std::vector<Point2d> occupied;
  for (int y = 0; y < grid.height(); ++y)
    for (int x = 0; x < grid.width(); ++x)
      if (grid.is_occupied({x, y})) occupied.push_back(grid.cell_center({x, y}));
  svg.layer("static grid").points(occupied, {.stroke = "black", .point_radius_px = 1.0});
  svg.layer("doors (min / max angle)");
  for (const DoorModel& d : doors) {
    svg.segment(d.hinge, d.leaf_end(d.opening_min), {.stroke = "blue", .stroke_width_px = 2});
    svg.segment(d.hinge, d.leaf_end(d.opening_max), {.stroke = "red", .stroke_width_px = 2});
    svg.circle(d.hinge, 0.05, {.stroke = "black", .fill = "black"});
  }
  svg.layer("robot path").path(drawn_path, {.stroke = "green"});
  const double panel_dy = grid.height() * grid.resolution() + 1.0;
  draw_likelihood_panel(svg, grid, doors, drawn_states, panel_dy);
  svg.layer("estimated doors (30 deg open)");
  for (std::size_t k = 0; k < doors.size(); ++k) {
    const Point2d down(0, panel_dy);
    svg.segment(doors[k].hinge - down, doors[k].leaf_end(drawn_states.doors[k].mean) - down,
                {.stroke = "orange", .stroke_width_px = 1.5});
  }
  svg.text(grid.origin() + Point2d(0, grid.height() * grid.resolution() + 0.3),
           "grid map with the detected doors' minimum (blue) and maximum (red) angles", 14);
  svg.text(grid.origin() + Point2d(0, -0.7),
           "likelihood field of the static map with the "
           "estimated door states (doors 30 deg open)",
           14);
  std::filesystem::create_directories("doors_out");
  const std::string svg_path = std::string("doors_out/doors") +
                               (layout.centers.empty() ? "" : "_irregular") +
                               (swing > 0 ? "" : "_into_corridor") + ".svg";
  svg.save(svg_path);
  std::cout << "wrote " << svg_path << "\n";

  std::cout << "{\"doors_true\": " << map.true_doors << ", \"doors_detected\": " << doors.size()
            << ", \"mcl_mean_err_m\": {" << mcl_json << "}, \"door_mcl_mean_err_m\": {" << door_json
            << "}}\n";
  return 0;
}
