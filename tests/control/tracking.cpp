// Path following (Indiveri's law on local frames, paper 000 §5) and the pose controller (paper
// 003 §2.2.3) closed around exact unicycle kinematics integrated in the test.

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "rangenav/control/indiveri_path_tracker.hpp"
#include "rangenav/control/indiveri_pose_controller.hpp"
#include "rangenav/control/local_frame_path.hpp"
#include "rangenav/sim/robot.hpp"

using Catch::Matchers::Equals;
using rangenav::IndiveriPathTracker;
using rangenav::IndiveriPoseController;
using rangenav::LocalFramePath;
using rangenav::Point2d;
using rangenav::Pose2d;

namespace {

constexpr double pi = std::numbers::pi;

// Exact unicycle motion over dt at constant (v, omega): the simulator's.
constexpr auto integrate = &rangenav::sim::DifferentialDriveRobot::integrate;

}  // namespace

TEST_CASE("local frame path: frames along the segments") {
  const std::vector<Point2d> wp{{0, 0}, {2, 0}, {2, 0}, {2, 3}};
  const LocalFramePath path(wp);
  REQUIRE(path.size() == 2);  // the duplicate waypoint is dropped
  CHECK(path.length() == Approx(5.0));
  CHECK(path.segment(1).heading == Approx(pi / 2));
  const Pose2d local = path.segment(1).to_local(Pose2d{1.5, 1.0, pi / 2});
  CHECK(local.x == Approx(1.0));
  CHECK(local.y == Approx(0.5));  // left of the segment that points up
  CHECK(local.theta == Approx(0.0).margin(1e-12));
  CHECK(path.segment(0).edge == LocalFramePath::no_edge);

  const std::vector<Point2d> one{{1, 1}, {1, 1}};
  CHECK_THROWS_WITH(LocalFramePath(one),
                    Equals("rangenav: LocalFramePath: argument 'waypoints.size()' = 2 must hold at "
                           "least two distinct points"));
  const std::vector<Point2d> bad{{0, 0}, {NAN, 1}};
  CHECK_THROWS_WITH(LocalFramePath(bad), Equals("rangenav: LocalFramePath: argument "
                                                "'waypoints[1]' = nan 1 must be finite"));
  const std::vector<std::uint32_t> edges{1, 2};
  CHECK_THROWS_WITH(LocalFramePath(wp, edges),
                    Equals("rangenav: LocalFramePath: argument 'edges.size()' = 2 must be 0 or "
                           "waypoints.size() - 1 = 3"));
}

TEST_CASE("path tracker: Eq. (7) is the Lyapunov-stable law") {
  const rangenav::IndiveriGains g{3.0, 1.5};
  // omega = -h v y sin(theta)/theta - gamma theta
  CHECK(IndiveriPathTracker::indiveri_omega(0.5, 0.2, 0.4, g) ==
        Approx(-3.0 * 0.5 * 0.2 * std::sin(0.4) / 0.4 - 1.5 * 0.4));
  CHECK(IndiveriPathTracker::indiveri_omega(0.5, 0.2, 0.0, g) == Approx(-0.3));
  // V = h y^2/2 + theta^2/2 has V' = h y v sin(theta) + theta omega = -gamma theta^2.
  for (double y : {-1.0, 0.3, 2.0})
    for (double th : {-2.5, -0.3, 0.7, 3.0}) {
      const double v = 0.4, w = IndiveriPathTracker::indiveri_omega(v, y, th, g);
      CHECK(g.h * y * v * std::sin(th) + th * w == Approx(-g.gamma * th * th));
    }
}

TEST_CASE("path tracker: converges to a straight line from offsets and headings") {
  // The x axis from (0, 0) to (60, 0); start anywhere within 2 m of it, facing any direction.
  const std::vector<Point2d> wp{{0, 0}, {60, 0}};
  rangenav::IndiveriPathTrackerParams params;
  const double dt = 0.02;
  int runs = 0;
  for (double y0 : {-2.0, -1.0, -0.3, 0.0, 0.3, 1.0, 2.0})
    for (double th0 = -pi + 0.25; th0 <= pi; th0 += pi / 6) {
      IndiveriPathTracker tracker(params);
      tracker.set_path(LocalFramePath(wp));
      Pose2d pose{2.0, y0, th0};
      double max_offset = std::abs(y0);
      for (int k = 0; k < static_cast<int>(50.0 / dt); ++k) {
        const auto cmd = tracker.step(pose);
        REQUIRE(!cmd.finished);
        REQUIRE(cmd.v > 0.0);  // always forward
        pose = integrate(pose, cmd.v, cmd.omega, dt);
        max_offset = std::max(max_offset, std::abs(pose.y));
      }
      INFO("start y = " << y0 << ", theta = " << th0);
      CHECK(std::abs(pose.y) < 0.01);
      CHECK(std::abs(pose.theta) < 0.01);
      // Turning around costs at most a turning circle: the offset stays bounded.
      CHECK(max_offset < std::abs(y0) + 1.0);
      ++runs;
    }
  CHECK(runs == 7 * 12);
}

TEST_CASE("path tracker: follows a polyline, switches segments, finishes at the end") {
  const std::vector<Point2d> wp{{0, 0}, {4, 0}, {4, 3}, {8, 3}};
  IndiveriPathTracker tracker;
  tracker.set_path(LocalFramePath(wp));
  Pose2d pose{0.0, 0.2, 0.1};
  const double dt = 0.02;
  std::size_t last_segment = 0;
  double worst = 0.0;
  bool finished = false;
  for (int k = 0; k < 10000 && !finished; ++k) {
    const auto cmd = tracker.step(pose);
    REQUIRE(cmd.segment >= last_segment);  // segments only advance
    last_segment = cmd.segment;
    if (cmd.finished) {
      finished = true;
      break;
    }
    pose = integrate(pose, cmd.v, cmd.omega, dt);
    // Distance to the polyline.
    double d = 1e9;
    for (std::size_t i = 0; i + 1 < wp.size(); ++i) {
      const Point2d a = wp[i], b = wp[i + 1], p = pose.position();
      const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      d = std::min(d, (a + t * (b - a) - p).norm());
    }
    if (k > 200) worst = std::max(worst, d);  // after the initial offset is regained
  }
  CHECK(finished);
  CHECK(last_segment == 2);
  CHECK((pose.position() - Point2d(8, 3)).norm() < 0.31);
  CHECK(worst < 0.35);  // corner cutting at 90-degree turns stays within the robot's width
}

TEST_CASE("path tracker: a blocked segment asks for re-planning") {
  const std::vector<Point2d> wp{{0, 0}, {5, 0}, {5, 5}};
  const std::vector<std::uint32_t> edges{17, 23};
  IndiveriPathTracker tracker;
  tracker.set_path(LocalFramePath(wp, edges));
  const Pose2d pose{1.0, 0.0, 0.0};
  // Obstacle points in the robot frame: 1 m ahead, on the segment.
  const std::vector<Point2d> blocking{{1.0, 0.05}, {1.0, -0.05}, {1.0, 0.1}};
  const auto cmd = tracker.step(pose, blocking);
  CHECK(cmd.replan);
  CHECK(cmd.blocked_edge == 17);
  CHECK(cmd.v == 0.0);
  // Beside the segment (beyond the corridor), behind the robot, or beyond the lookahead: free.
  const std::vector<Point2d> beside{{1.0, 0.5}, {1.0, -0.5}};
  const std::vector<Point2d> behind{{-0.5, 0.0}, {-0.6, 0.0}};
  const std::vector<Point2d> far{{3.0, 0.0}, {3.1, 0.0}};
  CHECK(!tracker.step(pose, beside).replan);
  CHECK(!tracker.step(pose, behind).replan);
  CHECK(!tracker.step(pose, far).replan);
  // A single point is noise (min_blocking_points = 2).
  CHECK(!tracker.step(pose, std::vector<Point2d>{{1.0, 0.0}}).replan);
  // The robot turned left by 90 degrees: a point 1 m to its right lies on the segment.
  CHECK(
      tracker.segment_blocked({1.0, 0.0, pi / 2}, std::vector<Point2d>{{0.0, -1.0}, {0.0, -1.05}}));

  // Around the corner: 4.5 m along the first segment is its end; 0.5 m more along the path lies
  // 0.5 m up the second segment, within the 1.5 m lookahead from x = 4.0.
  const Pose2d near_corner{4.0, 0.0, 0.0};
  const std::vector<Point2d> round_corner{{1.0, 0.5}, {1.05, 0.5}};  // world (5, 0.5)
  const auto corner = tracker.step(near_corner, round_corner);
  CHECK(corner.replan);
  CHECK(corner.blocked_edge == 23);
  CHECK(!tracker.step(near_corner, std::vector<Point2d>{{1.0, 1.0}, {1.05, 1.0}}).replan);

  // A Voronoi chain: 2 cm segments along x (edges 100, 101, ...). The check looks 1.5 m ahead
  // along the path, not 2 cm, and names the edge the obstacle stands on.
  std::vector<Point2d> chain;
  std::vector<std::uint32_t> chain_edges;
  for (int i = 0; i <= 250; ++i) {
    chain.emplace_back(0.02 * i, 0.0);
    if (i > 0) chain_edges.push_back(static_cast<std::uint32_t>(99 + i));
  }
  IndiveriPathTracker dense;
  dense.set_path(LocalFramePath(chain, chain_edges));
  const Pose2d start{0.0, 0.0, 0.0};
  const auto ahead = dense.blocked_segment(start, std::vector<Point2d>{{1.01, 0.1}, {1.01, -0.1}});
  REQUIRE(ahead);
  CHECK(*ahead == 50);  // x = 1.01 lies on the segment [1.00, 1.02]
  CHECK(dense.step(start, std::vector<Point2d>{{1.01, 0.1}, {1.01, -0.1}}).blocked_edge == 150);
  CHECK(!dense.blocked_segment(start, std::vector<Point2d>{{1.6, 0.0}, {1.61, 0.0}}));

  IndiveriPathTracker empty;
  CHECK_THROWS_WITH(empty.step(pose), Equals("rangenav: IndiveriPathTracker::step: no path set"));
  CHECK_THROWS_WITH(tracker.step({NAN, 0, 0}), Equals("rangenav: IndiveriPathTracker::step: "
                                                      "argument 'pose.x' = nan must be finite"));
  rangenav::IndiveriPathTrackerParams bad;
  bad.regain.h = 0.0;
  CHECK_THROWS_WITH(IndiveriPathTracker(bad),
                    Equals("rangenav: IndiveriPathTracker: argument 'params.regain.h' = 0 must be "
                           "finite and > 0"));
}

TEST_CASE("pose controller: reaches the pose from every direction without cusps") {
  IndiveriPoseController controller;
  const Pose2d target{1.0, -2.0, 0.7};
  const double dt = 0.01;
  int runs = 0;
  for (int b = 0; b < 12; ++b)
    for (int h = 0; h < 8; ++h) {
      const double bearing = b * pi / 6, heading = -pi + h * pi / 4 + 0.1;
      Pose2d pose{target.x + 2.0 * std::cos(bearing), target.y + 2.0 * std::sin(bearing), heading};
      bool reached = false;
      double min_v = 0.0;
      for (int k = 0; k < 12000 && !reached; ++k) {
        const auto cmd = controller.step(pose, target);
        reached = cmd.reached;
        min_v = std::min(min_v, cmd.v);
        REQUIRE(std::abs(cmd.omega) <= 1.5 + 1e-12);
        REQUIRE(cmd.v <= 0.3 + 1e-12);
        pose = integrate(pose, cmd.v, cmd.omega, dt);
      }
      INFO("bearing " << bearing << ", heading " << heading);
      CHECK(reached);
      CHECK(min_v >= 0.0);  // never reverses: no cusps
      CHECK((pose.position() - target.position()).norm() < 0.021);
      CHECK(std::abs(rangenav::angle_difference(pose.theta, target.theta)) < 0.036);
      ++runs;
    }
  CHECK(runs == 96);
}

TEST_CASE("pose controller: on the target's position but turned, it turns on the spot") {
  // e = 0 leaves theta = atan2(-y_G, -x_G) undefined; the controller takes theta = 0 there and
  // turns on the spot (v = gamma e = 0) toward the target heading.
  IndiveriPoseController controller;
  for (double phi : {-3.0, -1.2, -0.2, 0.1, 0.9, 2.5, pi}) {
    Pose2d pose{0.0, 0.0, phi};
    const auto cmd = controller.step(pose, {0.0, 0.0, 0.0});  // exactly e = 0
    INFO("heading " << phi);
    CHECK(cmd.e == 0.0);
    CHECK(cmd.v == 0.0);
    if (phi != pi) CHECK(cmd.omega * phi < 0.0);  // toward phi = 0 (either way from pi)
    CHECK(std::abs(cmd.omega) <= 1.5);
  }
  // From a target's position (a rounding error away from it) or from up to the position tolerance
  // away, with any heading error, the robot reaches the pose and stays near it.
  const Pose2d target{1.0, -2.0, 0.7};
  for (double distance : {0.0, 1e-12, 1e-6, 1e-3, 0.015})
    for (double offset : {-3.0, -1.2, -0.2, 0.1, 0.9, 2.5, pi}) {
      const double side = 1.3 * offset;  // some direction of the displacement
      Pose2d pose{target.x + distance * std::cos(side), target.y + distance * std::sin(side),
                  rangenav::normalize_angle(target.theta + offset)};
      bool reached = false;
      double drift = 0.0;
      int k = 0;
      for (; k < 3000 && !reached; ++k) {
        const auto cmd = controller.step(pose, target);
        reached = cmd.reached;
        REQUIRE(cmd.v >= 0.0);
        pose = integrate(pose, cmd.v, cmd.omega, 0.01);
        drift = std::max(drift, (pose.position() - target.position()).norm());
      }
      INFO("distance " << distance << ", heading offset " << offset << ": " << k << " steps, drift "
                       << drift);
      CHECK(reached);
      CHECK(drift <= 1.25 * distance + 1e-9);  // the law is scale-invariant: stays near
      CHECK(std::abs(rangenav::angle_difference(pose.theta, target.theta)) < 0.035);
    }
}

TEST_CASE("pose controller: the closed-form law and its contracts") {
  rangenav::IndiveriPoseControllerParams p;
  p.max_speed = 100.0;
  p.max_angular_speed = 100.0;
  IndiveriPoseController c(p);
  // Robot at (-1, -1) in the target frame, heading 0: e = sqrt 2, theta = atan2(1, 1) = pi/4,
  // alpha = pi/4.
  const auto cmd = c.step({-1.0, -1.0, 0.0}, {0, 0, 0});
  const double e = std::sqrt(2.0), th = pi / 4, a = pi / 4;
  CHECK(cmd.e == Approx(e));
  CHECK(cmd.theta == Approx(th));
  CHECK(cmd.alpha == Approx(a));
  CHECK(cmd.v == Approx(0.5 * e));
  const double curvature = std::sin(a) / e + 2.0 * th / e * std::sin(a) / a + 2.5 * a / e;
  CHECK(cmd.omega == Approx(cmd.v * curvature));
  // Limits scale v and omega together: the curvature stays.
  const auto limited = IndiveriPoseController().step({-1.0, -1.0, 0.0}, {0, 0, 0});
  CHECK(limited.omega / limited.v == Approx(curvature));

  rangenav::IndiveriPoseControllerParams bad;
  bad.h = 1.0;
  CHECK_THROWS_WITH(
      IndiveriPoseController(bad),
      Equals("rangenav: IndiveriPoseController: argument 'params.h' = 1 must be > 1"));
  bad.h = 2.0;
  bad.beta = 3.5;
  CHECK_THROWS_WITH(IndiveriPoseController(bad),
                    Equals("rangenav: IndiveriPoseController: argument 'params.beta' = 3.5 must "
                           "satisfy 2 < beta < h + 1 = 3"));
}
