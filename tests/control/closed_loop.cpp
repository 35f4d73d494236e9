// Planning and control closed around exact unicycle kinematics (paper 000 §4-5): plan on the
// Voronoi graph of a building of rooms, follow the path with Indiveri's tracker, finish with the
// pose controller; an obstacle that appears on a segment of the path makes the tracker ask for
// re-planning, the edge is blocked and the robot drives around it.

#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <vector>

#include "rangenav/control/indiveri_path_tracker.hpp"
#include "rangenav/control/indiveri_pose_controller.hpp"
#include "rangenav/planning/a_star.hpp"
#include "rangenav/sim/robot.hpp"

using rangenav::Point2d;
using rangenav::Pose2d;

namespace {

// 3 x 3 rooms of 4 m, walls sampled every 5 cm, a 1 m door in the middle of every inner wall.
std::vector<Point2d> building() {
  std::vector<Point2d> pts;
  for (int line = 0; line <= 3; ++line)
    for (int k = 0; k <= 240; ++k) {
      const double c = 4.0 * line, t = 0.05 * k;
      const bool outer = line == 0 || line == 3;
      if (!outer && std::abs(std::fmod(t, 4.0) - 2.0) < 0.5) continue;
      pts.emplace_back(c, t);
      pts.emplace_back(t, c);
    }
  return pts;
}

// Exact unicycle motion over dt at constant (v, omega): the simulator's.
constexpr auto integrate = &rangenav::sim::DifferentialDriveRobot::integrate;

}  // namespace

TEST_CASE("closed loop: plan, track, re-plan around an obstacle, reach the pose") {
  const auto walls = building();
  rangenav::VoronoiPathGraph graph(walls);
  rangenav::AStar planner(graph);
  const Pose2d start{1.0, 1.2, 0.0};
  const Pose2d goal{10.5, 10.0, std::numbers::pi / 2};

  auto first = planner.plan(start.position(), goal.position());
  REQUIRE(first.found());
  // The obstacle: a box in the middle of the first door the path goes through (the first graph
  // edge that crosses x = 4 or y = 4), seen by the robot's scan once within range.
  Point2d obstacle = Point2d::Zero();
  for (std::size_t i = 0; i + 1 < first.path.waypoints.size(); ++i) {
    const Point2d a = first.path.waypoints[i], b = first.path.waypoints[i + 1];
    if ((a.x() < 4.0) != (b.x() < 4.0) || (a.y() < 4.0) != (b.y() < 4.0)) {
      obstacle = (a + b) / 2;
      break;
    }
  }
  REQUIRE(obstacle.norm() > 0);
  const auto scan_of_obstacle = [&](const Pose2d& pose) {
    std::vector<Point2d> pts;  // the obstacle's outline (0.3 m square) in the robot frame
    if ((obstacle - pose.position()).norm() > 2.0) return pts;
    for (int k = 0; k < 12; ++k) {
      const double a = k * std::numbers::pi / 6;
      const Point2d w = obstacle + 0.15 * Point2d(std::cos(a), std::sin(a));
      pts.push_back(rangenav::relative(pose, Pose2d{w.x(), w.y(), 0.0}).position());
    }
    return pts;
  };

  rangenav::IndiveriPathTracker tracker;
  tracker.set_path(rangenav::LocalFramePath(first.path));
  rangenav::IndiveriPoseController approach;
  Pose2d pose = start;
  const double dt = 0.02;
  int replans = 0;
  bool reached = false, approaching = false;
  double min_clearance = 1e9, min_obstacle_distance = 1e9;
  for (int k = 0; k < 60000 && !reached; ++k) {
    double v = 0, w = 0;
    if (!approaching) {
      const auto cmd = tracker.step(pose, scan_of_obstacle(pose));
      if (cmd.replan) {
        REQUIRE(cmd.blocked_edge != rangenav::LocalFramePath::no_edge);
        graph.set_blocked(cmd.blocked_edge);
        const auto again = planner.plan(pose.position(), goal.position());
        REQUIRE(again.found());
        tracker.set_path(rangenav::LocalFramePath(again.path));
        ++replans;
        continue;
      }
      approaching = cmd.finished;
      v = cmd.v;
      w = cmd.omega;
    }
    if (approaching) {
      const auto cmd = approach.step(pose, goal);
      reached = cmd.reached;
      v = cmd.v;
      w = cmd.omega;
    }
    pose = integrate(pose, v, w, dt);
    min_clearance =
        std::min(min_clearance, planner.segment_clearance(pose.position(), pose.position()));
    min_obstacle_distance = std::min(min_obstacle_distance, (pose.position() - obstacle).norm());
  }
  CHECK(reached);
  CHECK((pose.position() - goal.position()).norm() < 0.10);
  CHECK(std::abs(rangenav::angle_difference(pose.theta, goal.theta)) < rangenav::deg_to_rad(5.0));
  CHECK(replans >= 1);
  CHECK(graph.blocked_count() == static_cast<std::size_t>(replans));
  CHECK(min_obstacle_distance > 0.5);  // never drove through the blocked door
  CHECK(min_clearance > 0.2);          // kept away from the walls (doors are 1 m wide)
}
