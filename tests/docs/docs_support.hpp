#pragma once
// Inputs for the documentation's snippets, made in the simulator so that every snippet runs
// without outside data: a CARMEN log of a tour of the apartment, a pair of 2D scans, a pair of
// 3D clouds; and the scores the tests check the snippets' results with.

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "io/scratch_dir.hpp"
#include "rangenav/core/angles.hpp"
#include "rangenav/core/cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/io/ply.hpp"
#include "rangenav/scan/laser_scan.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

namespace rangenav::docs_test {

using rangenav::test::ScratchDir;

/// What the simulated log recorded: the true pose of every scan.
struct SimulatedLog {
  std::vector<Pose2d> poses;
};

/// Writes a CARMEN log (FLASER records: 361 beams over 180 deg, 81.91 = no return) of the
/// apartment's tour: a scan every 10 cm or 0.2 rad, odometry 3 % long and drifting in heading.
inline SimulatedLog write_apartment_log(const std::filesystem::path& path) {
  const sim::Scene scene = sim::apartment();
  sim::LaserScannerParams params;
  params.geometry = ScanGeometry<double>::from_fov(deg_to_rad(180.0), deg_to_rad(0.5), 0.05, 30.0);
  const sim::LaserScanner2D scanner(params);
  std::mt19937 rng(7);
  std::ofstream out(path);
  out.precision(4);
  out << std::fixed;
  SimulatedLog log;
  Pose2d pose = scene.start, odometry = pose;
  double t = 0, since_scan = 1e9;
  const auto record = [&] {
    const LaserScan<double> scan = scanner.scan(scene.world, pose, rng, t);
    out << "FLASER " << scan.size();
    for (std::size_t i = 0; i < scan.size(); ++i)
      out << ' ' << (scan.range(i) >= scan.range_max() ? 81.91 : scan.range(i));
    for (int twice = 0; twice < 2; ++twice)
      out << ' ' << odometry.x << ' ' << odometry.y << ' ' << odometry.theta;
    out << ' ' << t << " sim " << t << '\n';
    log.poses.push_back(pose);
    since_scan = 0;
  };
  for (const Point2d& goal : scene.tour)
    for (int guard = 0; guard < 10000 && (goal - pose.position()).norm() > 0.05; ++guard) {
      if (since_scan >= 0.1) record();
      const double bearing =
          normalize_angle(std::atan2(goal.y() - pose.y, goal.x() - pose.x) - pose.theta);
      const Pose2d step{std::abs(bearing) < 0.3 ? 0.05 : 0.0, 0.0, std::clamp(bearing, -0.1, 0.1)};
      pose = compose(pose, step);
      odometry = compose(odometry, {step.x * 1.03, 0.0, step.theta * 1.01 + 0.0005});
      t += 0.05;
      since_scan += step.x + 0.5 * std::abs(step.theta);
    }
  record();
  return log;
}

/// Absolute trajectory error: RMS of the position errors of `estimate` (in the frame of the
/// first pose) against `truth` (world frame).
inline double ate_rmse(const std::vector<Pose2d>& estimate, const std::vector<Pose2d>& truth) {
  double sum_sq = 0;
  for (std::size_t i = 0; i < truth.size(); ++i)
    sum_sq += (estimate[i].position() - relative(truth.front(), truth[i]).position()).squaredNorm();
  return std::sqrt(sum_sq / static_cast<double>(truth.size()));
}

/// Two 2D scans of the apartment and the true pose of the data scan in the model scan's frame.
struct ScanPair {
  LaserScan<double> model, data;
  Pose2d truth;       ///< data scan pose in the model scan's frame
  Transform2d guess;  ///< the truth, 8 cm and 2 deg off (an odometry guess)
};

/// The model scan from the apartment's start, the data scan 0.3 m / 6 deg further on; with
/// `with_new_box` a box the model scan did not see stands in view of the data scan.
inline ScanPair apartment_scan_pair(bool with_new_box) {
  const sim::Scene scene = sim::apartment();
  sim::World world = scene.world;
  if (with_new_box) {
    world.add_box({compose(scene.start, {1.2, -0.4, 0}).position(), {0.3, 0.3}, 0.3, 0.0, 0.8});
    world.build_index();
  }
  const sim::LaserScanner2D scanner;
  std::mt19937 rng(3);
  const Pose2d truth{0.3, 0.05, deg_to_rad(6.0)};
  ScanPair pair{scanner.scan(scene.world, scene.start, rng),
                scanner.scan(world, compose(scene.start, truth), rng), truth,
                compose(truth, {0.06, -0.05, deg_to_rad(2.0)}).to_isometry()};
  return pair;
}

/// The motion between the two clouds of write_room_pair (8.6 deg about a tilted axis, 0.23 m).
inline Transform3d room_motion() {
  Transform3d motion = Transform3d::Identity();
  motion.linear() = Eigen::AngleAxisd(0.15, Eigen::Vector3d(0.1, 0.2, 1).normalized()).matrix();
  motion.translation() = Eigen::Vector3d(0.2, -0.1, 0.05);
  return motion;
}

/// Writes a 6 x 4 x 3 m room (a table top in one corner breaks its symmetry) sampled with
/// 20,000 points as `target`, and half of those points moved by motion^-1 as `source`, so that
/// `motion` maps source onto target.
inline void write_room_pair(const std::filesystem::path& target,
                            const std::filesystem::path& source, const Transform3d& motion) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Cloud3d room, moved;
  for (int i = 0; i < 20000; ++i) {
    Point3d p(6 * u(rng) - 3, 4 * u(rng) - 2, 3 * u(rng));
    const int face = i % 6;
    if (face < 2) p.x() = face == 0 ? -3 : 3;
    if (face == 2 || face == 3) p.y() = face == 2 ? -2 : 2;
    if (face == 4) p.z() = 0;
    if (face == 5) p.z() = (p.x() > 0 && p.y() > 0) ? 0.8 : 3;
    room.points.push_back(p);
    if (i % 2 == 0) moved.points.push_back(motion.inverse(Eigen::Isometry) * p);
  }
  room.width = room.points.size();
  moved.width = moved.points.size();
  io::write_ply(target, room);
  io::write_ply(source, moved);
}

}  // namespace rangenav::docs_test
