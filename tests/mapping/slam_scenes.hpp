#pragma once
// Simulated SLAM runs for the loop-closure tests: a ring of corridors the robot drives around
// with drifting odometry, scanned by the simulator's SICK S300 model.

#include <cmath>
#include <random>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/scan/laser_scan.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/world.hpp"

namespace rangenav::test {

/// A 20 m x 14 m block of offices with a 2 m wide corridor around a 16 m x 10 m core, boxes and
/// pillars at irregular places along the walls (so that no stretch of corridor is a featureless
/// tube and no two corners look alike).
inline sim::World ring_corridor() {
  sim::World w;
  const std::vector<Point2d> outer{{0, 0}, {20, 0}, {20, 14}, {0, 14}};
  const std::vector<Point2d> inner{{2, 2}, {18, 2}, {18, 12}, {2, 12}};
  w.add_polygon(outer);
  w.add_polygon(inner);
  const double boxes[][4] = {{3.1, 0.2, 0.6, 0.4},    {7.4, 0.25, 1.0, 0.5},  {12.9, 1.8, 0.8, 0.4},
                             {16.2, 0.2, 0.5, 0.4},   {19.7, 4.1, 0.6, 1.2},  {18.3, 8.8, 0.6, 0.8},
                             {19.75, 11.2, 0.5, 0.5}, {14.6, 13.8, 1.4, 0.4}, {9.3, 12.3, 0.6, 0.6},
                             {4.2, 13.75, 0.8, 0.5},  {0.3, 9.7, 0.6, 1.5},   {1.75, 5.2, 0.5, 0.8},
                             {0.25, 2.9, 0.5, 0.5}};
  for (const auto& b : boxes)
    w.add_box({{b[0], b[1]}, {b[2], b[3]}, 0.0, 0.0, 1.0});
  w.add_cylinder({{10.2, 1.0}, 0.12, 0.0, 2.5});
  w.add_cylinder({{19.0, 6.5}, 0.15, 0.0, 2.5});
  w.add_cylinder({{6.1, 13.0}, 0.12, 0.0, 2.5});
  return w;
}

/// One simulated run: scans, the drifting odometry and the true poses, scan by scan.
struct SimulatedRun {
  std::vector<LaserScan<double>> scans;
  std::vector<Pose2d> odometry;
  std::vector<Pose2d> truth;
};

/// Drives through `waypoints` from `start` in 5 cm steps, scanning every 10 cm or 5°; the
/// odometry over-estimates distance by `scale_error` and drifts in heading by `heading_drift`
/// rad per metre plus Gaussian noise.
inline SimulatedRun drive(const sim::World& world, Pose2d start,
                          const std::vector<Point2d>& waypoints, double scale_error = 0.03,
                          double heading_drift = 0.01, unsigned seed = 7) {
  const sim::LaserScanner2D scanner;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  SimulatedRun run;
  Pose2d pose = start, odom = start;
  double travelled = 0;
  const auto record = [&] {
    run.scans.push_back(scanner.scan(world, pose, rng));
    run.odometry.push_back(odom);
    run.truth.push_back(pose);
  };
  record();
  for (const auto& goal : waypoints) {
    for (int guard = 0; guard < 100000 && (goal - pose.position()).norm() > 0.05; ++guard) {
      const double bearing =
          normalize_angle(std::atan2(goal.y() - pose.y, goal.x() - pose.x) - pose.theta);
      const double turn = std::clamp(bearing, -0.1, 0.1);
      const double forward = std::abs(bearing) < 0.3 ? 0.05 : 0.0;
      pose = compose(pose, {forward, 0.0, turn});
      const double d = forward * (1 + scale_error) + 0.002 * noise(rng) * forward;
      const double dtheta = turn + heading_drift * forward + 0.002 * noise(rng) * forward;
      odom = compose(odom, {d, 0.0, dtheta});
      travelled += forward + 0.6 * std::abs(turn);
      if (travelled >= 0.1) {
        travelled = 0;
        record();
      }
    }
  }
  return run;
}

/// A 3D range scan of `world` from a sensor 0.5 m above the robot at `pose`: 8 rings of 180
/// beams (every 2°) at elevations from -20° to +15°, ranges to 20 m with 1 cm noise, in the
/// robot frame (z up).
template <class Engine>
std::vector<Point3d> scan_3d(const sim::World& world, const Pose2d& pose, Engine& rng) {
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<Point3d> points;
  const Point3d origin(pose.x, pose.y, 0.5);
  for (int ring = 0; ring < 8; ++ring) {
    const double elevation = deg_to_rad(-20.0 + 5.0 * ring);
    for (int beam = 0; beam < 180; ++beam) {
      const double azimuth = deg_to_rad(2.0 * beam);
      const Point3d local(std::cos(elevation) * std::cos(azimuth),
                          std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
      const Point3d world_dir(std::cos(pose.theta) * local.x() - std::sin(pose.theta) * local.y(),
                              std::sin(pose.theta) * local.x() + std::cos(pose.theta) * local.y(),
                              local.z());
      const auto hit = world.cast_ray(origin, world_dir, 20.0);
      if (!(hit.range < 20.0)) continue;
      points.push_back(local * (hit.range + noise(rng)) + Point3d(0, 0, 0.5));
    }
  }
  return points;
}

/// Once and a third around ring_corridor() counter-clockwise from (1, 1), facing east.
inline SimulatedRun ring_run(double scale_error = 0.03, double heading_drift = 0.01) {
  return drive(ring_corridor(), {1.0, 1.0, 0.0},
               {{19, 1}, {19, 13}, {1, 13}, {1, 1}, {19, 1}, {19, 6}}, scale_error, heading_drift);
}

}  // namespace rangenav::test
