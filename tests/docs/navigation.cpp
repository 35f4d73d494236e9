// The snippets of docs/mapping.md (occupancy grid, doors), docs/localization.md,
// docs/planning.md and docs/control.md, compiled and run in the simulator; each test checks what
// the page says against the simulator's truth.

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

#include "docs_support.hpp"
#include "rangenav/rangenav.hpp"

using namespace rangenav;

namespace {

/// The office corridor mapped with known poses: three passes with the doors open 90 deg, closed,
/// and open 45 deg (the runs of paper 001 §V), as docs/mapping.md describes.
struct MappedCorridor {
  OccupancyGrid grid = OccupancyGrid::covering({0, -4}, {20, 6}, 0.5);
  std::vector<DoorModel> doors;
};

MappedCorridor map_corridor() {
  MappedCorridor out;
  std::vector<std::pair<Pose2d, LaserScan<double>>> mapping_run;
  const sim::LaserScanner2D laser;
  std::mt19937_64 rng(1);
  const double deg = std::numbers::pi / 180;
  for (const double opening : {90 * deg, 0.0, 45 * deg}) {
    const sim::Scene scene = sim::office_corridor(std::vector<double>(8, opening));
    for (int k = 0; k <= 94; ++k) {
      const Pose2d pose{0.6 + 0.2 * k, 1.0, 0.0};
      mapping_run.emplace_back(pose, laser.scan(scene.world, pose, rng));
    }
  }
  // [snippet:grid-doors]
  OccupancyGrid grid = OccupancyGrid::covering({0, -4}, {20, 6}, 0.5);  // 5 cm cells, log odds
  DoorDetector doors;
  ScanClassification c;
  for (const auto& [pose, scan] : mapping_run) {  // known poses (a corrected log, a simulator)
    grid.integrate(pose, scan, c);  // c.static_beams / dynamic_points / vanished_points (§III)
    doors.add(c, grid);             // lines in the dynamic points, doors where they turn (§III.B)
  }
  doors.remove_doors(grid);  // the static map: what the doors swept is free
  // doors.doors(): hinge, leaf_length, reference_angle, opening range of every door found
  // [snippet-end]
  out.grid = std::move(grid);
  out.doors = doors.doors();
  return out;
}

}  // namespace

TEST_CASE("mapping: an occupancy grid with known poses finds the corridor's doors", "[docs]") {
  const MappedCorridor m = map_corridor();
  const sim::Scene truth = sim::office_corridor(std::vector<double>(8, 0.0));
  CHECK(m.doors.size() == truth.world.doors().size());
  for (const DoorModel& d : m.doors) {
    double nearest = 1e9;
    for (const auto& t : truth.world.doors())
      nearest = std::min(nearest, (t.hinge - d.hinge).norm());
    CHECK(nearest < 0.05);
    CHECK(d.leaf_length == Approx(0.9).margin(0.05));
  }
}

TEST_CASE("localization: MCL and door-aware MCL track the robot in the corridor", "[docs]") {
  const MappedCorridor m = map_corridor();
  const OccupancyGrid& grid = m.grid;
  const sim::Scene scene = sim::office_corridor(std::vector<double>(8, 0.5));  // doors ajar
  sim::LaserScannerParams lp;
  lp.geometry = ScanGeometry<double>::from_fov(std::numbers::pi, deg_to_rad(1.0), 0.05, 30.0);
  const sim::LaserScanner2D laser(lp);
  sim::DifferentialDriveRobot robot({}, {1.0, 1.0, 0.0});
  std::mt19937_64 sim_rng(3);
  const Pose2d start = robot.pose();
  // [snippet:mcl]
  std::mt19937_64 rng(42);
  MonteCarloLocalization<> mcl{OdometryMotionModel(), LikelihoodFieldModel(grid)};
  mcl.initialize_gaussian(start, {0.05, 0.05, 0.02}, 500, rng);  // or initialize_uniform(grid, ...)
  DoorAwareMcl door_mcl(grid, m.doors);  // §IV: a Kalman-filtered angle per door in each particle
  door_mcl.initialize_gaussian(start, {0.05, 0.05, 0.02}, 500, rng);
  LikelihoodFieldModel::Observation z;
  DoorAwareObservation dz;
  Pose2d previous_odometry = robot.odometry();
  // [snippet-end]
  double mcl_error = 0, door_error = 0;
  int n = 0;
  while (robot.pose().x < 18.0) {
    for (int k = 0; k < 10; ++k) {
      const Pose2d& p = robot.pose();
      robot.step(scene.world, 0.5, -1.5 * (p.y - 1.0) - 2.0 * p.theta, sim_rng);
    }
    const LaserScan<double> scan = laser.scan(scene.world, robot.pose(), sim_rng);
    const Pose2d odometry = robot.odometry();
    // [snippet:mcl-step]
    // every scan: the odometry since the last one, and the scan (sensor at the robot's origin)
    mcl.sensor_model().prepare(scan, Pose2d{}, z);
    mcl.update(OdometryReading{previous_odometry, odometry}, z, rng);
    door_mcl.prepare(scan, Pose2d{}, dz);  // end points + the scan's Douglas-Peucker segments
    door_mcl.update(OdometryReading{previous_odometry, odometry}, dz, rng);
    previous_odometry = odometry;
    const Pose2d x = mcl.estimate();              // the weighted mean; mcl.covariance()
    const double door0 = door_mcl.door_angle(0);  // door 0's opening from its reference
    // [snippet-end]
    mcl_error += (x.position() - robot.pose().position()).norm();
    door_error += (door_mcl.estimate().position() - robot.pose().position()).norm();
    CHECK(std::isfinite(door0));
    ++n;
  }
  CHECK(mcl_error / n < 0.15);
  CHECK(door_error / n < 0.05);
}

TEST_CASE("planning: Voronoi graph, A*, re-planning and named places", "[docs]") {
  const sim::Scene scene = sim::apartment();
  std::vector<Point2d> map_points;  // a map of the apartment: every wall sampled at 5 cm
  for (const auto& wall : scene.world.walls())
    for (double t = 0; t <= 1.0; t += 0.05 / std::max(0.05, (wall.b - wall.a).norm()))
      map_points.push_back(wall.a + t * (wall.b - wall.a));
  const Point2d start = scene.start.position(), goal = scene.tour.back();
  // [snippet:plan]
  VoronoiPathGraph graph(map_points, {.robot_width = 0.45, .safety_margin = 0.05});
  AStar planner(graph);  // keeps its buffers between queries
  PlanResult plan = planner.plan(start, goal);
  if (plan.found()) {
    // plan.path.waypoints: start, Voronoi vertices ..., goal
    // plan.path.edges: the graph edge of each segment (VoronoiPathGraph::npos at the two ends)
    graph.set_blocked(plan.path.edges[plan.path.edges.size() / 2]);  // a scan shows it blocked
    plan = planner.plan(start, goal);  // re-planned around it, no rebuild
  }
  // [snippet-end]
  REQUIRE(plan.found());
  for (std::size_t i = 0; i + 1 < plan.path.waypoints.size(); ++i) {
    const Point2d a = plan.path.waypoints[i], b = plan.path.waypoints[i + 1];
    for (double t = 0; t <= 1; t += 0.1)  // every waypoint segment keeps clear of the walls
      for (const Point2d& p : map_points)
        REQUIRE((a + t * (b - a) - p).norm() > 0.2);
  }

  // [snippet:places]
  TopologicalMap places;  // named objects beside the metric map (paper 000 §1)
  places.add({"refrigerator",
              {4.0, 2.0, std::numbers::pi / 2},                        // x axis: where it faces
              {{-0.3, -0.3}, {0.3, -0.3}, {0.3, 0.3}, {-0.3, 0.3}}});  // outline, object frame
  const Pose2d target = places.at("refrigerator").approach_pose(0.6);  // 0.6 m ahead, facing it
  // [snippet-end]
  CHECK(target.position().isApprox(Point2d(4.0, 2.6), 1e-9));
  CHECK(target.theta == Approx(-std::numbers::pi / 2));
}

TEST_CASE("control: follow a planned path, then stop on the goal pose", "[docs]") {
  const sim::Scene scene = sim::apartment();
  std::vector<Point2d> map_points;
  for (const auto& wall : scene.world.walls())
    for (double t = 0; t <= 1.0; t += 0.05 / std::max(0.05, (wall.b - wall.a).norm()))
      map_points.push_back(wall.a + t * (wall.b - wall.a));
  VoronoiPathGraph graph(map_points, {.robot_width = 0.6, .safety_margin = 0.05});
  AStar planner(graph);
  const Pose2d target{scene.tour[1].x(), scene.tour[1].y(), 0.0};
  const PlanResult plan = planner.plan(scene.start.position(), target.position());
  REQUIRE(plan.found());
  sim::DifferentialDriveRobot robot({}, scene.start);
  const sim::LaserScanner2D laser;
  std::mt19937 rng(9);
  std::size_t contacts = 0;
  // [snippet:follow]
  IndiveriPathTracker tracker({.speed = 0.3});          // Eq. (7) of paper 000, segment by segment
  tracker.set_path(LocalFramePath(plan.path));          // a chain of local frames (Fig. 6b)
  IndiveriPoseController approach({.max_speed = 0.3});  // the final approach (paper 003 §2.2.3)
  ReactiveBehaviours reactive(                          // the safety layer (paper 002 §5)
      {.roadway = {.half_width = 0.3, .dto_min = 0.3, .dto_max = 1.5, .v_max = 0.3}});
  bool arrived = false;
  while (!arrived && robot.time() < 120) {  // 50 Hz
    const Pose2d pose = robot.pose();       // a localizer's estimate on a real robot
    const LaserScan<double> scan = laser.scan(scene.world, pose, rng);  // robot frame
    TrackerCommand cmd = tracker.step(pose, scan);  // cmd.replan: the path ahead is blocked
    double v = cmd.v, omega = cmd.omega;
    if (cmd.finished) {
      const PoseControlCommand final_cmd = approach.step(pose, target);
      arrived = final_cmd.reached;
      v = final_cmd.v, omega = final_cmd.omega;
    }
    const ReactiveCommand safe = reactive.apply(v, omega, scan);
    contacts += robot.step(scene.world, safe.v, safe.omega, rng).moved ? 0 : 1;
  }
  // [snippet-end]
  CHECK(arrived);
  CHECK(contacts == 0);
  CHECK((robot.pose().position() - target.position()).norm() < 0.05);
  CHECK(std::abs(angle_difference(robot.pose().theta, target.theta)) < deg_to_rad(5.0));
}
