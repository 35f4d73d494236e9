// 00_demo: the main showcase. A simulated robot drives a scripted tour through the apartment of
// paper 002 (Fig. 2: a couch table whose top is above the 2D scanner's plane, chairs, an open
// drawer, small objects on the floor, a descending stair, doors) with three range sensors:
//   - a SICK S300-like 2D laser at 0.30 m (10 Hz),
//   - a continuously pitching 2D laser (one scan every 13.32 ms, paper 002 §3.3),
//   - a SwissRanger SR4000-like time-of-flight camera tilted down (0.5 Hz).
// It records the true path, the odometry and the scans, counts what each sensor perceives of
// the obstacles a 2D laser cannot see, maps the apartment online from the 2D laser scans and the
// odometry (incremental SLAM with a sparse point map, paper 000 §3), steering the tour by that
// SLAM estimate, and draws everything into demo_out/world.svg.
// Then it closes the loop on that map (run_navigation): back at its start in the hallway, the
// robot plans to the dresser in the kitchen, a named object of the topological map, on the
// pruned Voronoi graph of the SLAM sparse point map; it localizes on that map while driving
// (odometry prediction, each 2D scan registered against the map with the SLAM setup's ICP) and
// follows the path with Indiveri's path tracker and pose controller steering by that estimate,
// with the reactive behaviours on the pitching scanner's obstacle map. After planning a box blocks
// the corridor and a can too low for the 2D laser stands in the kitchen; the latest 2D scan shows
// the box on the path, the obstacle map the can, each time the edge is blocked and the path
// re-planned (demo_out/navigation.svg: SLAM map, pruned graph, plans, driven trajectory, paper 000
// Fig. 6a). The simulator's truth only scores the run: the JSON reports goal_reached (true pose
// within 10 cm and 5 deg), replans, min_clearance_m, contacts and the localization error
// nav_pose_rmse_m.
//
// Usage:  00_demo                 run the tour (what `cmake --workflow --preset demo` does)
//         00_demo --docs <dir>    also draw the three built-in worlds into <dir>/*.svg
//
// The last line printed is one JSON object with the demo's figures.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <numbers>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "rangenav/control/indiveri_path_tracker.hpp"
#include "rangenav/control/indiveri_pose_controller.hpp"
#include "rangenav/control/reactive.hpp"
#include "rangenav/core/angles.hpp"
#include "rangenav/egocentric/pitching_stream.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/io/svg.hpp"
#include "rangenav/mapping/incremental_mapper.hpp"
#include "rangenav/planning/a_star.hpp"
#include "rangenav/planning/topological_map.hpp"
#include "rangenav/scan/pitching.hpp"
#include "rangenav/sim/robot.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

using namespace rangenav;
using namespace rangenav::sim;

namespace {

std::vector<Point2d> box_outline(const Box& b) {
  const Eigen::Rotation2Dd r(b.yaw);
  const Point2d h = b.size / 2;
  return {b.center + r * Point2d(-h.x(), -h.y()), b.center + r * Point2d(h.x(), -h.y()),
          b.center + r * Point2d(h.x(), h.y()), b.center + r * Point2d(-h.x(), h.y())};
}

/// Draws a world: walls, doors, the stair, and the solids coloured by whether a 2D laser at
/// `scan_height` can see them (their z-range contains that height) or not (Fig. 2 of paper 002).
void draw_world(io::SvgDrawing& svg, const World& w, double scan_height, double opacity = 1.0) {
  const io::Style seen{.stroke = "#555", .fill = "#c8c8c8", .opacity = opacity};
  const io::Style unseen{.stroke = "#d35400", .fill = "#f5b041", .opacity = 0.8 * opacity};
  svg.layer("stair (floor below z = 0)");
  for (const FloorHole& h : w.holes())
    svg.polygon(box_outline({h.center, h.size, h.yaw, 0, 1}),
                {.stroke = "#2e86c1", .fill = "#aed6f1", .opacity = opacity});
  svg.layer("solids in the 2D scan plane");
  for (const Box& b : w.boxes())
    if (b.z_min <= scan_height && b.z_max >= scan_height) svg.polygon(box_outline(b), seen);
  for (const Cylinder& c : w.cylinders())
    if (c.z_min <= scan_height && c.z_max >= scan_height) svg.circle(c.center, c.radius, seen);
  svg.layer("solids above or below the 2D scan plane");
  for (const Box& b : w.boxes())
    if (!(b.z_min <= scan_height && b.z_max >= scan_height)) svg.polygon(box_outline(b), unseen);
  for (const Cylinder& c : w.cylinders())
    if (!(c.z_min <= scan_height && c.z_max >= scan_height)) svg.circle(c.center, c.radius, unseen);
  svg.layer("doors");
  for (const Door& d : w.doors())
    svg.polygon(box_outline(d.leaf()),
                {.stroke = "#6e2c00", .fill = "#a04000", .opacity = opacity});
  svg.layer("walls");
  for (const Wall& wall : w.walls())
    svg.segment(wall.a, wall.b, {.stroke = "black", .stroke_width_px = 2.5, .opacity = opacity});
}

/// Turn-then-drive waypoint follower (the real path trackers come with the control issue).
struct WaypointFollower {
  std::vector<Point2d> waypoints;
  std::size_t next = 0;
  double reached_within = 0.08;

  [[nodiscard]] bool done() const { return next >= waypoints.size(); }

  /// (v, omega) towards the next waypoint from the pose the robot believes it has.
  std::pair<double, double> command(const Pose2d& pose) {
    while (!done() && (waypoints[next] - pose.position()).norm() < reached_within)
      ++next;
    if (done()) return {0.0, 0.0};
    const Point2d to = waypoints[next] - pose.position();
    const double heading_error = angle_difference(std::atan2(to.y(), to.x()), pose.theta);
    const double omega = std::clamp(2.5 * heading_error, -1.5, 1.5);
    if (std::abs(heading_error) > 0.25) return {0.0, omega};  // turn on the spot first
    return {std::min(0.5, 1.2 * to.norm()), omega};
  }
};

void write_docs(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  const auto draw = [&](const Scene& s, const std::string& name) {
    io::SvgDrawing svg({.size_px = 700});
    draw_world(svg, s.world, apartment_scan_height);
    if (!s.tour.empty()) {
      std::vector<Point2d> tour{s.start.position()};
      tour.insert(tour.end(), s.tour.begin(), s.tour.end());
      svg.layer("demo tour").polyline(tour, {.stroke = "#27ae60", .stroke_width_px = 1.5});
    }
    svg.layer("start").pose(s.start, 0.5, {.stroke = "#27ae60", .fill = "#27ae60"});
    svg.save(dir / (name + ".svg"));
    std::cout << "wrote " << (dir / (name + ".svg")).string() << '\n';
  };
  draw(apartment(), "apartment");
  std::vector<double> doors(office_corridor_door_count, 0.0);
  doors[1] = std::numbers::pi / 2;
  doors[4] = 0.6;
  doors[6] = std::numbers::pi / 3;
  draw(office_corridor(doors), "office_corridor");
  draw(kitchen(), "kitchen");
}

// ---- mapping and localization (paper 000 §3) ---------------------------------------------------

// Online SLAM: every 2D laser scan goes to the incremental mapper with the odometry pose as it
// arrives (LaserSlamMapper, the documented 2D laser setup). Its map frame is the robot's frame at
// the first scan; odometry knows that pose in the frame where the robot started (the world frame
// of the start pose), so `origin` places the map in the world without the simulator's truth. The
// absolute trajectory error is the RMS of the position errors over all scans.
struct OnlineSlam {
  LaserSlamMapper<double> mapper{laser_slam_params<double>()};
  Pose2d origin;                        ///< the map frame in the world (odometry at the first scan)
  std::vector<Pose2d> estimate, truth;  // world frame
  double cpu_seconds = 0;

  void add(const LaserScan<double>& scan, const Pose2d& odometry, const Pose2d& true_pose) {
    if (truth.empty()) origin = odometry;
    const auto start = std::chrono::steady_clock::now();
    const auto update = mapper.process(scan, odometry.to_isometry());
    cpu_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    truth.push_back(true_pose);
    estimate.push_back(compose(origin, Pose2d::from_isometry(update.pose)));
  }
  /// Evaluated as usual with the estimated trajectory aligned to the truth at the first scan
  /// (the map's placement through odometry adds its own small error, seen in the navigation).
  [[nodiscard]] double ate_rmse() const {
    double sum_sq = 0;
    for (std::size_t i = 0; i < truth.size(); ++i) {
      const Pose2d aligned = compose(truth.front(), relative(origin, estimate[i]));
      sum_sq += (aligned.position() - truth[i].position()).squaredNorm();
    }
    return truth.empty() ? 0.0 : std::sqrt(sum_sq / static_cast<double>(truth.size()));
  }
  /// The sparse point map in the world frame (the map the navigation plans on).
  [[nodiscard]] std::vector<Point2d> world_map() const {
    std::vector<Point2d> map;
    for (const Point2d& p : mapper.map().points())
      map.push_back(origin.transform_point(p));
    return map;
  }
  void draw(io::SvgDrawing& svg) const {
    if (truth.empty()) return;
    svg.layer("SLAM sparse map").points(world_map(), {.stroke = "#d35400", .point_radius_px = 1.3});
    svg.layer("SLAM estimated path").path(estimate, {.stroke = "#c0392b", .stroke_width_px = 1.5});
  }
};

/// Localization on the finished SLAM map while driving: odometry increments predict the pose at
/// every control step, and each 2D scan is registered against the sparse point map with the map
/// ICP of the SLAM setup (point-to-line on the map's normals, 0.5 -> 0.2 m decaying threshold),
/// starting from that prediction (paper 000 §3.2, the tracking half of the incremental mapper).
/// A registration is accepted under the mapper's rules: converged (or degenerate with its
/// constrained directions), fitness >= 0.3, and a correction of the prediction below 0.5 m / 3 deg.
struct MapLocalizer {
  const SparsePointMap<2, double>& map;
  Pose2d origin;  ///< the map frame in the world
  LaserIcp<double> icp{};
  Pose2d estimate;  ///< world frame
  Pose2d last_odometry;
  std::size_t accepted = 0, rejected = 0;

  MapLocalizer(const OnlineSlam& slam, const Pose2d& initial, const Pose2d& odometry)
      : map(slam.mapper.map()), origin(slam.origin), estimate(initial), last_odometry(odometry) {
    auto& decaying = icp.rejector<DecayingDistanceRejector<double>>();
    decaying.initial_distance = 0.5;
    decaying.final_distance = 0.2;
    icp.solver.model_normals = map.normals();
  }
  void predict(const Pose2d& odometry) {
    estimate = compose(estimate, relative(last_odometry, odometry));
    last_odometry = odometry;
  }
  void correct(const LaserScan<double>& scan) {
    const Pose2d guess = relative(origin, estimate);  // in the map frame
    const auto r = icp.align(map.search(), scan, guess.to_isometry());
    const Pose2d found = Pose2d::from_isometry(r.transform);
    const Pose2d correction = relative(guess, found);
    const bool usable = r.reason == IcpTermination::converged ||
                        r.reason == IcpTermination::max_iterations ||
                        (r.reason == IcpTermination::degenerate && r.smallest_eigenvalue);
    if (usable && r.fitness >= 0.3 && correction.position().norm() <= 0.5 &&
        std::abs(correction.theta) <= deg_to_rad(3.0)) {
      estimate = compose(origin, found);
      ++accepted;
    } else {
      ++rejected;
    }
  }
};

// ---- the mapping tour (paper 002 Fig. 2, paper 000 §3) -----------------------------------------

/// The robot's three range sensors with the defaults of the papers' hardware. Each draws from
/// its own engine, so changing one sensor's rate does not change another's noise.
struct Sensors {
  LaserScanner2D laser;      ///< S300: 270 deg at 0.5 deg, level at 0.30 m; read at 10 Hz
  PitchingScanner pitching;  ///< a 2D scan every 13.32 ms, nodding -10..40 deg
  TofCamera tof;             ///< SR4000 tilted 25 deg down at the floor ahead; read at 0.5 Hz
  std::mt19937 laser_rng, pitching_rng, tof_rng;
  std::size_t next_pitched = 0;  ///< the pitching scanner's next scan
};

Sensors make_sensors(unsigned seed) {
  TofCameraParams tof_params;
  tof_params.tilt = deg_to_rad(25.0);
  return {LaserScanner2D(),       PitchingScanner(),      TofCamera(tof_params),
          std::mt19937(seed + 1), std::mt19937(seed + 2), std::mt19937(seed + 3)};
}

/// What each sensor perceived of the obstacles a 2D laser cannot see, counted with the truth.
struct Perception {
  std::size_t laser_scans = 0, laser_on_table_legs = 0, laser_on_table_top = 0;
  std::size_t pitched_scans = 0, pitching_on_table_top = 0, pitching_on_drawer = 0;
  std::size_t below_floor = 0, tof_frames = 0, tof_mixed_pixels = 0;
  std::vector<Point2d> laser_points;          ///< every 4th scan's end points (world frame)
  std::vector<Point3d> pitched_world_points;  ///< every 3rd pitched scan's points off the floor
};

/// The 2D laser: its scan goes to the SLAM; the truth tells which beams hit the couch table (the
/// table's top lies above the scan plane, so only its legs can be hit).
LaserScan<double> sense_laser(const Scene& scene, const DifferentialDriveRobot& robot, Sensors& s,
                              Perception& seen) {
  const LaserScan<double> scan = s.laser.scan(scene.world, robot.pose(), s.laser_rng, robot.time());
  ++seen.laser_scans;
  if (seen.laser_scans % 4 == 0)
    for (const Point2d& p : scan.valid_points())
      seen.laser_points.push_back(robot.pose().transform_point(p));
  const SceneObject& couch_table = scene.object("couch_table");
  for (const RayHit& h : s.laser.cast(scene.world, robot.pose())) {
    if (!h.hit() || !couch_table.contains({h.kind, h.index})) continue;
    (h.kind == SurfaceKind::box ? seen.laser_on_table_top : seen.laser_on_table_legs) += 1;
  }
  return scan;
}

/// The pitching scanner: every 2D scan whose time fell into this control step, turned into 3D
/// with Eq. (3) of paper 002 and into the world frame with the true pose.
void sense_pitching(const Scene& scene, const DifferentialDriveRobot& robot, Sensors& s,
                    Perception& seen) {
  const SceneObject& couch_table = scene.object("couch_table");
  const SceneObject& drawer = scene.object("drawer");
  const auto over = [](const SceneObject& o, const Point3d& g) {
    return g.x() > o.min.x() && g.x() < o.max.x() && g.y() > o.min.y() && g.y() < o.max.y() &&
           g.z() > o.min.z() + 0.2 * (o.max.z() - o.min.z());
  };
  const Transform3d to_world = robot_transform(robot.pose());
  while (s.pitching.scan_time(s.next_pitched) <= robot.time()) {
    const PitchedScan<double> ps = s.pitching.scan(
        scene.world, robot.pose(), s.pitching.scan_time(s.next_pitched), s.pitching_rng);
    ++s.next_pitched;
    ++seen.pitched_scans;
    for (const Point3d& p : pitched_points(ps.scan, ps.pitch, s.pitching.params().sensor_offset)) {
      const Point3d g = to_world * p;
      seen.pitching_on_table_top += over(couch_table, g) && g.z() > couch_table.max.z() - 0.06;
      seen.pitching_on_drawer += over(drawer, g);
      if (g.z() < -0.05) ++seen.below_floor;  // the descending stair (paper 002 §4.2)
      if (seen.pitched_scans % 3 == 0 && (g.z() > 0.03 || g.z() < -0.03))
        seen.pitched_world_points.push_back(g);
    }
  }
}

/// The ToF camera: counts mixed pixels (depth strictly between neighbours that jump).
void sense_tof(const Scene& scene, const DifferentialDriveRobot& robot, Sensors& s,
               Perception& seen) {
  const DepthImage<double> img = s.tof.capture(scene.world, robot.pose(), s.tof_rng, robot.time());
  ++seen.tof_frames;
  for (std::size_t row = 0; row < img.height(); ++row)
    for (std::size_t c = 1; c + 1 < img.width(); ++c) {
      const double a = img.at(row, c - 1), b = img.at(row, c), d = img.at(row, c + 1);
      if (std::isfinite(a) && std::isfinite(b) && std::isfinite(d) && std::abs(a - d) > 0.3 &&
          std::min(a, d) + 0.1 < b && b < std::max(a, d) - 0.1)
        ++seen.tof_mixed_pixels;
    }
}

/// How the tour went.
struct Tour {
  std::size_t waypoints_reached = 0, contacts = 0;
  double time = 0, distance = 0, odometry_error = 0;
  std::vector<Pose2d> true_path, odometry_path;
  Pose2d final_pose;
};

/// Drives the scene's tour at 50 Hz, mapping online with the 2D laser (OnlineSlam) and steering
/// by that estimate: odometry alone drifts too much to pass 0.9 m doors on a 60 s tour, so the
/// robot steers by the SLAM pose of the last scan moved on by the odometry since.
Tour drive_tour(const Scene& scene, const DifferentialDriveParams& robot_params, unsigned seed,
                OnlineSlam& slam, Perception& seen) {
  DifferentialDriveRobot robot(robot_params, scene.start);
  Sensors sensors = make_sensors(seed);
  std::mt19937 robot_rng(seed);
  WaypointFollower follower{scene.tour};
  Tour tour;
  tour.true_path = {robot.pose()};
  tour.odometry_path = {robot.odometry()};
  Pose2d slam_fix = robot.odometry(), odometry_at_fix = robot.odometry();  // the start, at first
  for (std::size_t step = 1; !follower.done() && robot.time() < 180.0; ++step) {
    const Pose2d believed = compose(slam_fix, relative(odometry_at_fix, robot.odometry()));
    const auto [v, omega] = follower.command(believed);
    const Pose2d before = robot.pose();
    if (!robot.step(scene.world, v, omega, robot_rng).moved) ++tour.contacts;
    tour.distance += (robot.pose().position() - before.position()).norm();
    if (step % 10 == 0) {
      tour.true_path.push_back(robot.pose());
      tour.odometry_path.push_back(robot.odometry());
    }
    if (step % 5 == 0) {  // 10 Hz
      slam.add(sense_laser(scene, robot, sensors, seen), robot.odometry(), robot.pose());
      slam_fix = slam.estimate.back();
      odometry_at_fix = robot.odometry();
    }
    sense_pitching(scene, robot, sensors, seen);
    if (step % 100 == 0) sense_tof(scene, robot, sensors, seen);  // 0.5 Hz
  }
  tour.true_path.push_back(robot.pose());
  tour.odometry_path.push_back(robot.odometry());
  tour.waypoints_reached = follower.next;
  tour.time = robot.time();
  tour.final_pose = robot.pose();
  tour.odometry_error = (robot.odometry().position() - robot.pose().position()).norm();
  return tour;
}

/// demo_out/world.svg: world, true path, odometry path, laser end points, 3D points off the floor,
/// the SLAM map and path.
void draw_tour(const Scene& scene, const Tour& tour, const Perception& seen,
               const OnlineSlam& slam) {
  std::filesystem::create_directories("demo_out");
  io::SvgDrawing svg({.size_px = 900});
  draw_world(svg, scene.world, LaserScannerParams{}.mount.translation().z());
  std::vector<Point3d> above, below;
  for (const Point3d& p : seen.pitched_world_points)
    (p.z() > 0 ? above : below).push_back(p);
  svg.layer("pitching scanner points off the floor")
      .points(above, {.stroke = "#8e44ad", .opacity = 0.35, .point_radius_px = 0.8});
  svg.layer("pitching scanner points below the floor")
      .points(below, {.stroke = "#1f618d", .point_radius_px = 1.2});
  svg.layer("2D laser end points")
      .points(seen.laser_points, {.stroke = "#e74c3c", .opacity = 0.5, .point_radius_px = 0.8});
  svg.layer("true path").path(tour.true_path, {.stroke = "#27ae60", .stroke_width_px = 2.5});
  svg.layer("odometry").path(tour.odometry_path, {.stroke = "#2c3e50", .stroke_width_px = 1.5});
  slam.draw(svg);
  svg.layer("robot").circle(tour.final_pose.position(), 0.3, {.stroke = "#27ae60"});
  svg.pose(tour.final_pose, 0.4, {.stroke = "#27ae60", .fill = "#27ae60"});
  svg.save("demo_out/world.svg");
}

// ---- closed-loop navigation (papers 000 §4-5, 002 §5, 003 §2.2) --------------------------------

struct NavigationResult {
  bool goal_reached = false;   ///< true pose within 10 cm and 5 degrees of the goal pose
  std::size_t replans = 0;     ///< edges blocked and paths re-planned
  double min_clearance = 1.0;  ///< smallest true footprint-to-obstacle distance on the drive (m)
  std::size_t contacts = 0;    ///< refused steps that started a contact
  double time = 0, distance = 0;
  double position_error = 0, heading_error = 0;  ///< true pose vs goal at the end
  double pose_rmse = 0;         ///< RMS of localization position errors at the scans (m)
  double pose_max_error = 0;    ///< largest of those (m)
  double heading_rmse_deg = 0;  ///< RMS of localization heading errors (deg)
  std::size_t registrations_rejected = 0, registrations = 0;
  std::size_t graph_nodes = 0, graph_edges = 0;
  std::string goal_name;
};

/// The named places of the topological map (paper 000 §1: "go to the refrigerator"): the
/// dresser (its front facing west), the counter and the couch table, with their outlines.
TopologicalMap named_places(const Scene& scene) {
  TopologicalMap places;
  for (const char* name : {"dresser", "counter", "couch_table"}) {
    const SceneObject& o = scene.object(name);
    const Point2d h = (o.max - o.min).head<2>() / 2, c = o.center().head<2>();
    const double facing = std::string_view(name) == "counter"   ? std::numbers::pi / 2
                          : std::string_view(name) == "dresser" ? std::numbers::pi
                                                                : 0.0;
    places.add({name,
                {c.x(), c.y(), facing},
                {{-h.x(), -h.y()}, {h.x(), -h.y()}, {h.x(), h.y()}, {-h.x(), h.y()}}});
  }
  return places;
}

/// The world after planning: a stack of boxes blocks the corridor between the living room's door
/// and the kitchen's, and a can (10 cm, below the 2D laser's plane: only the pitching scanner's
/// obstacle map shows it) stands on the kitchen floor west of the dining table. The map knows
/// neither.
World world_after_planning(const Scene& scene) {
  World world = scene.world;
  world.add_box({{4.4, 5.6}, {0.4, 1.2}, 0.0, 0.0, 0.9});
  world.add_cylinder({{6.59, 3.15}, 0.05, 0.0, 0.10});
  world.build_index();
  return world;
}

/// The reactive behaviours (paper 002 §5) for a robot of `radius`: the roadway slightly wider
/// than the robot, a stop 10 cm before an obstacle, and a gentle pull towards free space. The
/// tracker and the pose controller know which way they want to turn (StopTurn::commanded).
ReactiveBehaviours demo_reactive(double radius) {
  ReactiveParams p;
  p.roadway = {.half_width = radius + 0.03,
               .front_offset = radius,
               .dto_min = 0.1,
               .dto_max = 1.0,
               .v_max = 0.3,
               .turn_rate = 0.6};
  p.free_space = {.dto_min = 0.3, .dto_max = 1.5, .influence = 0.05};
  p.stop_turn = StopTurn::commanded;
  return ReactiveBehaviours(p);
}

/// demo_out/navigation.svg (paper 000 Fig. 6a): the SLAM map, the pruned graph, the blocked
/// edges, the first and last plans and the driven trajectory over the true world (pale).
void draw_navigation(const World& world, const std::vector<Point2d>& map,
                     const VoronoiPathGraph& graph, const std::vector<std::uint32_t>& blocked,
                     const PlannedPath& first_plan, const PlannedPath& last_plan,
                     const std::vector<Pose2d>& driven, const std::vector<Pose2d>& believed,
                     const Pose2d& goal) {
  io::SvgDrawing svg({.size_px = 900});
  draw_world(svg, world, apartment_scan_height, 0.35);
  svg.layer("SLAM sparse map").points(map, {.stroke = "#d35400", .point_radius_px = 1.6});
  const auto edge = [&](std::uint32_t e, const io::Style& style) {
    svg.segment(graph.nodes()[graph.edges()[e].from].position,
                graph.nodes()[graph.edges()[e].to].position, style);
  };
  svg.layer("pruned Voronoi graph");
  for (std::uint32_t e = 0; e < graph.edge_count(); ++e)
    edge(e, {.stroke = "#85c1e9", .stroke_width_px = 0.8});
  svg.layer("blocked edges");
  for (std::uint32_t e : blocked)
    edge(e, {.stroke = "red", .stroke_width_px = 4});
  svg.layer("first plan")
      .polyline(first_plan.waypoints, {.stroke = "#2874a6", .stroke_width_px = 2});
  svg.layer("last plan").polyline(last_plan.waypoints, {.stroke = "#e67e22", .stroke_width_px = 2});
  svg.layer("driven (true)").path(driven, {.stroke = "#27ae60", .stroke_width_px = 2.5});
  svg.layer("driven (estimated)").path(believed, {.stroke = "#1e8449", .stroke_width_px = 1});
  svg.layer("goal").pose(goal, 0.4, {.stroke = "#c0392b", .fill = "#c0392b"});
  svg.save("demo_out/navigation.svg");
}

/// Plans from the hallway to the dresser on the pruned Voronoi graph of the SLAM map, follows
/// the path with Indiveri's tracker and finishes with the pose controller, both steering by the
/// pose estimated on that map (MapLocalizer). The reactive behaviours keep the roadway clear on
/// the pitching scanner's obstacle map, and the path is re-planned when the latest 2D scan or the
/// obstacle map shows an obstacle on it. The simulator's truth only scores the run.
NavigationResult run_navigation(const Scene& scene, const OnlineSlam& slam,
                                const DifferentialDriveParams& robot_params, unsigned seed) {
  NavigationResult out;
  out.goal_name = "dresser";
  const Pose2d goal = named_places(scene).at(out.goal_name).approach_pose(1.1);

  // The robot is back on its start pose in the hallway, where the mapping tour began: it knows
  // that pose (the start of its odometry frame), and the first scan registration refines it.
  DifferentialDriveRobot robot(robot_params, scene.start);
  MapLocalizer localizer(slam, scene.start, robot.odometry());

  // Plan on the SLAM map, with the robot's width and the paper's 5 cm margin. The straight
  // connections of start and goal to the graph are checked against the map's points only, and a
  // wall ends up to eps_D beyond its last point: they keep that much more clearance.
  const double radius = robot_params.footprint.radius;
  const std::vector<Point2d> map = slam.world_map();
  VoronoiPathGraph graph(map, {.robot_width = 2 * radius, .safety_margin = 0.05});
  out.graph_nodes = graph.node_count();
  out.graph_edges = graph.edge_count();
  const double eps_d = slam.mapper.map().params().epsilon_d;
  AStar planner(graph, {.connection_clearance = graph.params().required_clearance() + eps_d});
  PlanResult plan = planner.plan(localizer.estimate.position(), goal.position());
  if (!plan.found()) return out;
  const PlannedPath first_plan = plan.path;

  const World world = world_after_planning(scene);
  std::mt19937 rng(seed), laser_rng(seed + 1);
  const LaserScanner2D laser;
  PitchingScannerParams pitching_params;
  pitching_params.noise.sigma = 0.005;  // SICK LMS 2xx: about 5 mm (1 sigma)
  const PitchingScanner pitching(pitching_params);
  const Point3d offset = pitching.params().sensor_offset;
  PitchingObstacleExtractor<double> extractor(offset);
  VirtualMapParams<double> mp;
  mp.max_age = 225;  // 3 s at 75 Hz
  mp.blind_range = pitching_blind_range(offset, pitching.params().pitch_max);
  ObstacleMap<double> obstacles(mp, ObstacleMapPolicy{0.0, 1.2});  // the robot's height band

  IndiveriPathTracker tracker(
      {.speed = 0.3, .corridor_half_width = radius + 0.02, .min_blocking_points = 4});
  tracker.set_path(LocalFramePath(plan.path));
  IndiveriPoseController approach({.max_speed = 0.3});
  ReactiveBehaviours reactive = demo_reactive(radius);

  const Transform3d mount = laser.params().mount;
  std::vector<Point2d> scan_points;  // the latest 2D scan in the robot frame
  std::vector<Pose2d> driven{robot.pose()}, believed{localizer.estimate};
  std::vector<std::uint32_t> blocked;
  Pose2d previous = localizer.estimate;
  std::size_t next_pitched = 0, step = 0, scored = 0;
  bool approaching = false, in_contact = false;
  double error_sq = 0, heading_sq = 0;
  while (robot.time() < 150.0) {
    localizer.predict(robot.odometry());
    // Perception: the 2D laser at 10 Hz (registered on the map, then checked against the path),
    // the pitching scanner's stream into the obstacle map.
    const bool fresh_scan = step++ % 5 == 0;
    if (fresh_scan) {
      const LaserScan<double> scan = laser.scan(world, robot.pose(), laser_rng, robot.time());
      localizer.correct(scan);
      scan_points.clear();
      for (const Point2d& p : scan.valid_points())
        scan_points.push_back((mount * Point3d(p.x(), p.y(), 0.0)).head<2>());
      // Evaluation only: the estimate against the simulator's truth.
      const Pose2d& e = localizer.estimate;
      const double d = (e.position() - robot.pose().position()).norm();
      error_sq += d * d;
      heading_sq += std::pow(angle_difference(e.theta, robot.pose().theta), 2);
      out.pose_max_error = std::max(out.pose_max_error, d);
      ++scored;
    }
    const Pose2d pose = localizer.estimate;
    while (pitching.scan_time(next_pitched) <= robot.time()) {
      const auto ps = pitching.scan(world, robot.pose(), pitching.scan_time(next_pitched++), rng);
      obstacles.update(relative(previous, pose), extractor.push(ps, pose));
      previous = pose;
    }
    double v = 0, omega = 0;
    if (!approaching) {
      // The path ahead is checked against each new 2D scan and the obstacle map (10 Hz).
      TrackerCommand cmd = fresh_scan ? tracker.step(pose, scan_points) : tracker.step(pose);
      if (fresh_scan && !cmd.replan) cmd = tracker.step(pose, obstacles);
      if (cmd.replan && cmd.blocked_edge != LocalFramePath::no_edge) {
        // Paper 000 §4: mark the edge not traversable and re-plan on the same diagram.
        graph.set_blocked(cmd.blocked_edge);
        blocked.push_back(cmd.blocked_edge);
        ++out.replans;
        plan = planner.plan(pose.position(), goal.position());
        if (!plan.found()) break;
        tracker.set_path(LocalFramePath(plan.path));
        cmd = tracker.step(pose);
      }
      if (cmd.replan) cmd = tracker.step(pose);  // on a connection to the graph: nothing to block
      approaching = cmd.finished;
      v = cmd.v;
      omega = cmd.omega;
    }
    if (approaching) {
      const PoseControlCommand cmd = approach.step(pose, goal);
      if (cmd.reached) break;
      v = cmd.v;
      omega = cmd.omega;
    }
    const ReactiveCommand safe = reactive.apply(v, omega, obstacles);
    const Pose2d before = robot.pose();
    const StepResult r = robot.step(world, safe.v, safe.omega, rng);
    if (!r.moved && !in_contact) ++out.contacts;
    in_contact = !r.moved;
    out.distance += (robot.pose().position() - before.position()).norm();
    out.min_clearance = std::min(out.min_clearance,
                                 footprint_clearance(world, robot_params.footprint, robot.pose()));
    if (step % 10 == 0) {
      driven.push_back(robot.pose());
      believed.push_back(localizer.estimate);
    }
  }
  driven.push_back(robot.pose());
  believed.push_back(localizer.estimate);
  out.time = robot.time();
  out.position_error = (robot.pose().position() - goal.position()).norm();
  out.heading_error = std::abs(angle_difference(robot.pose().theta, goal.theta));
  out.goal_reached = out.position_error < 0.10 && out.heading_error < deg_to_rad(5.0);
  out.pose_rmse = scored == 0 ? 0.0 : std::sqrt(error_sq / static_cast<double>(scored));
  out.heading_rmse_deg =
      scored == 0 ? 0.0 : rad_to_deg(std::sqrt(heading_sq / static_cast<double>(scored)));
  out.registrations = localizer.accepted + localizer.rejected;
  out.registrations_rejected = localizer.rejected;
  draw_navigation(world, map, graph, blocked, first_plan, plan.path, driven, believed, goal);
  return out;
}

// ---- the report --------------------------------------------------------------------------------

void print_summary(const Scene& scene, const Tour& tour, const Perception& seen,
                   const OnlineSlam& slam, const NavigationResult& nav) {
  std::cout << "rangenav demo: tour of the apartment (paper 002 Fig. 2 scene)\n"
            << "  waypoints reached       " << tour.waypoints_reached << " of " << scene.tour.size()
            << " in " << tour.time << " s simulated, " << tour.distance << " m driven, "
            << tour.contacts << " blocked steps\n"
            << "  odometry error at end   " << tour.odometry_error << " m\n"
            << "  2D laser                " << seen.laser_scans << " scans, "
            << seen.laser_on_table_legs << " readings on the couch table's legs, "
            << seen.laser_on_table_top << " on its top (above the scan plane)\n"
            << "  pitching scanner        " << seen.pitched_scans << " scans, "
            << seen.pitching_on_table_top << " readings on the couch table top, "
            << seen.pitching_on_drawer << " on the open drawer, " << seen.below_floor
            << " below the floor (stair)\n"
            << "  SLAM (2D laser)         " << slam.mapper.map().size() << " map points of "
            << slam.mapper.map().points_offered() << " offered, absolute trajectory error "
            << slam.ate_rmse() << " m RMS (odometry alone: " << tour.odometry_error
            << " m at the end), " << slam.cpu_seconds << " s\n"
            << "  ToF camera              " << seen.tof_frames << " frames, "
            << seen.tof_mixed_pixels << " mixed pixels at jump edges\n"
            << "  navigation to the " << nav.goal_name << "    "
            << (nav.goal_reached ? "goal reached" : "goal NOT reached") << " in " << nav.time
            << " s, " << nav.distance << " m, " << nav.replans << " re-plans, " << nav.contacts
            << " contacts, min clearance " << nav.min_clearance << " m, final error "
            << nav.position_error << " m / " << rad_to_deg(nav.heading_error) << " deg ("
            << nav.graph_nodes << " graph nodes, " << nav.graph_edges << " edges on the SLAM map)\n"
            << "  localization on the map " << nav.pose_rmse << " m / " << nav.heading_rmse_deg
            << " deg RMS error (max " << nav.pose_max_error << " m), " << nav.registrations_rejected
            << " of " << nav.registrations << " scan registrations rejected\n"
            << "  wrote demo_out/world.svg and demo_out/navigation.svg (in "
            << std::filesystem::current_path().string() << ")\n";
}

void print_json(const Scene& scene, const Tour& tour, const Perception& seen,
                const OnlineSlam& slam, const NavigationResult& nav, double runtime) {
  std::printf(
      "{\"demo\": \"00_demo\", \"world\": \"apartment\", \"waypoints_reached\": %zu, "
      "\"waypoints\": %zu, \"sim_time_s\": %.2f, \"distance_m\": %.3f, \"blocked_steps\": %zu, "
      "\"odometry_error_m\": %.4f, \"laser_scans\": %zu, \"laser_readings_on_table_legs\": %zu, "
      "\"laser_readings_on_table_top\": %zu, "
      "\"pitched_scans\": %zu, \"pitched_readings_on_table_top\": %zu, "
      "\"pitched_readings_on_drawer\": %zu, \"pitched_readings_below_floor\": %zu, "
      "\"tof_frames\": %zu, \"tof_mixed_pixels\": %zu, \"slam_ate_rmse_m\": %.4f, "
      "\"slam_map_points\": %zu, \"goal_reached\": %s, \"replans\": %zu, "
      "\"min_clearance_m\": %.3f, \"contacts\": %zu, \"nav_time_s\": %.2f, "
      "\"nav_position_error_m\": %.4f, \"nav_heading_error_deg\": %.2f, \"nav_pose_rmse_m\": %.4f, "
      "\"nav_pose_max_error_m\": %.4f, \"nav_heading_rmse_deg\": %.2f, \"runtime_s\": %.3f}\n",
      tour.waypoints_reached, scene.tour.size(), tour.time, tour.distance, tour.contacts,
      tour.odometry_error, seen.laser_scans, seen.laser_on_table_legs, seen.laser_on_table_top,
      seen.pitched_scans, seen.pitching_on_table_top, seen.pitching_on_drawer, seen.below_floor,
      seen.tof_frames, seen.tof_mixed_pixels, slam.ate_rmse(), slam.mapper.map().size(),
      nav.goal_reached ? "true" : "false", nav.replans, nav.min_clearance, nav.contacts, nav.time,
      nav.position_error, rad_to_deg(nav.heading_error), nav.pose_rmse, nav.pose_max_error,
      nav.heading_rmse_deg, runtime);
}

}  // namespace

int main(int argc, char** argv) {
  const auto wall_start = std::chrono::steady_clock::now();
  if (argc == 3 && std::string_view(argv[1]) == "--docs") write_docs(argv[2]);

  // The robot: a 0.3 m disc up to 1.2 m high, with odometry that overestimates distances by 2 %,
  // drifts by 0.005 rad/s and is noisy. Everything below is deterministic for the seed.
  const Scene scene = apartment();
  DifferentialDriveParams robot_params;
  robot_params.footprint = Footprint::circle(0.3, 0.02, 1.2);
  robot_params.odometry = {.v_scale = 0.02,
                           .omega_scale = 0.0,
                           .omega_bias = 0.005,
                           .v_sigma = 0.02,
                           .omega_sigma = 0.05};
  const unsigned seed = 20240101;

  // 1. The mapping tour: sense, map online, steer by the map (demo_out/world.svg).
  OnlineSlam slam;
  Perception seen;
  const Tour tour = drive_tour(scene, robot_params, seed, slam, seen);
  draw_tour(scene, tour, seen, slam);

  // 2. Closed loop: hallway -> the dresser in the kitchen, a corridor blocked after planning
  //    (demo_out/navigation.svg).
  const NavigationResult nav = run_navigation(scene, slam, robot_params, seed + 4);

  const double runtime =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  print_summary(scene, tour, seen, slam, nav);
  print_json(scene, tour, seen, slam, nav, runtime);
  const bool ok = tour.waypoints_reached == scene.tour.size() && tour.contacts == 0 &&
                  nav.goal_reached && nav.contacts == 0;
  return ok ? 0 : 1;
}
