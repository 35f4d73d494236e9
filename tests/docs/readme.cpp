// The snippets of README.md, compiled and run: each TEST_CASE builds the snippet's input (in the
// simulator, so no outside data is needed), runs the snippet as the README shows it, and checks
// what the README says it does against the simulator's truth.
// The regions between "// [snippet:NAME]" and "// [snippet-end]" are copied into the Markdown;
// tests/docs/check_docs.cmake fails when the two differ.

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <variant>
#include <vector>

#include <catch2/catch.hpp>

#include "docs_support.hpp"
#include "rangenav/rangenav.hpp"

namespace docs = rangenav::docs_test;

// [snippet:own-rejector]
// Keeps only the pairs whose data point was measured within `max_range` of the sensor: a 2D
// laser's far readings are sparse and meet surfaces at grazing angles. A rejector has only the
// members it needs (docs/concepts.md lists them); `reject` sees every iteration's pairs.
struct SensorRangeRejector {
  double max_range = 8.0;  // m

  template <int D>
  void reject(const rangenav::IcpContext<D, double>&,
              std::vector<rangenav::Correspondence<D, double>>& pairs) const {
    const double max_range_sq = max_range * max_range;  // squared distances throughout
    std::erase_if(pairs, [&](const auto& pair) { return pair.data.squaredNorm() > max_range_sq; });
  }
};
static_assert(rangenav::CorrespondenceRejector<SensorRangeRejector, 2, double>);
// [snippet-end]

TEST_CASE("README: register two 3D clouds read from PLY files", "[docs]") {
  // Input: a simulated room and the same room seen after a known motion, written as PLY files.
  const docs::ScratchDir dir("readme_register");
  const rangenav::Transform3d motion = docs::room_motion();
  docs::write_room_pair(dir.path() / "target.ply", dir.path() / "source.ply", motion);
  const std::filesystem::path target_path = dir.path() / "target.ply",
                              source_path = dir.path() / "source.ply";

  // [snippet:register-clouds]
  const auto target = rangenav::io::read_ply<double>(target_path);  // any 3D PointCloud
  const auto source = rangenav::io::read_ply<double>(source_path);
  const auto result = rangenav::align(target, source);  // GICP, pairs closer than 1 m
  // result.transform maps source into target; result.reason says why it stopped
  // [snippet-end]

  REQUIRE(result.converged);
  CHECK((result.transform.translation() - motion.translation()).norm() < 1e-3);
  CHECK(Eigen::AngleAxisd(result.transform.linear().transpose() * motion.linear()).angle() < 1e-3);
}

TEST_CASE("README: SLAM on a CARMEN log, then a path planned on its map", "[docs]") {
  // Input: a CARMEN log of a simulated tour of the apartment (odometry with drift).
  const docs::ScratchDir dir("readme_slam");
  const std::filesystem::path log_path = dir.path() / "apartment.clf";
  const docs::SimulatedLog truth = docs::write_apartment_log(log_path);

  // [snippet:slam-log]
  rangenav::LaserSlamMapper<double> slam;  // the 2D laser setup, laser_slam_params()
  // One laser's scans of the log (.clf / .log, plain or gzip), with its frame's odometry.
  const auto log = rangenav::io::read_carmen_scan_log(log_path);
  std::vector<rangenav::Pose2d> trajectory;  // one pose per scan, in the first scan's frame
  for (std::size_t i = 0; i < log.records.size(); ++i) {
    std::optional<rangenav::Transform2d> odom;  // none where the log has no pose
    if (log.odometry[i]) odom = log.odometry[i]->to_isometry();
    const auto update = slam.process(log.records[i].scan, odom);
    trajectory.push_back(rangenav::Pose2d::from_isometry(update.pose));
  }
  // slam.map().points(): the sparse point map (paper 000 §3.3)
  // [snippet-end]

  REQUIRE(trajectory.size() == truth.poses.size());
  CHECK(docs::ate_rmse(trajectory, truth.poses) < 0.05);

  // Plan across the mapped apartment, from the first pose of the tour to its far end.
  const rangenav::Point2d start = trajectory.front().position();
  const rangenav::Point2d goal = trajectory[trajectory.size() / 2].position();
  // [snippet:plan-path]
  rangenav::VoronoiPathGraph graph(slam.map().points(),  // any 2D PointCloud of obstacles
                                   {.robot_width = 0.45, .safety_margin = 0.05});
  rangenav::AStar planner(graph);
  const rangenav::PlanResult plan = planner.plan(start, goal);
  // plan.path.waypoints: start, Voronoi vertices ..., goal (paper 000 §4)
  // [snippet-end]

  REQUIRE(plan.found());
  CHECK(plan.path.waypoints.front() == start);
  CHECK(plan.path.waypoints.back() == goal);
}

TEST_CASE("README: ICP with your own rejector", "[docs]") {
  // Input: two scans of the apartment 0.3 m / 6 deg apart; the data scan also sees a box the
  // model scan does not.
  const docs::ScanPair scans = docs::apartment_scan_pair(/*with_new_box=*/true);
  const rangenav::Transform2d odometry_guess = scans.guess;
  const auto& model_scan = scans.model;
  const auto& scan = scans.data;

  // [snippet:use-own-rejector]
  rangenav::Icp<2, double, rangenav::DecayingDistanceRejector<double>, SensorRangeRejector> icp;
  icp.rejector<SensorRangeRejector>().max_range = 6.0;
  const auto result = icp.align(rangenav::KdTree<2, double>(model_scan), scan, odometry_guess);
  // [snippet-end]

  REQUIRE(result.converged);
  const rangenav::Pose2d error =
      rangenav::relative(scans.truth, rangenav::Pose2d::from_isometry(result.transform));
  CHECK(error.position().norm() < 0.02);
  CHECK(std::abs(error.theta) < rangenav::deg_to_rad(0.5));

  // The rejector on its own: of two pairs, the one whose data point lies 7 m out goes.
  std::vector<rangenav::Correspondence<2, double>> pairs(2);
  pairs[0].data = {5.0, 0.0};
  pairs[1].data = {0.0, 7.0};
  icp.rejector<SensorRangeRejector>().reject(rangenav::IcpContext<2, double>{}, pairs);
  REQUIRE(pairs.size() == 1);
  CHECK(pairs[0].data.x() == 5.0);
}

TEST_CASE("mapping.md: loop-closing SLAM on a CARMEN log", "[docs]") {
  // Input: the same simulated apartment tour as a CARMEN log (odometry 3 % long, drifting).
  const docs::ScratchDir dir("mapping_slam");
  const std::filesystem::path log_path = dir.path() / "apartment.clf";
  const docs::SimulatedLog truth = docs::write_apartment_log(log_path);

  // [snippet:laser-slam]
  rangenav::LaserSlam<double> slam;                               // the default configuration
  const auto log = rangenav::io::read_carmen_scan_log(log_path);  // one laser (io.md)
  for (std::size_t i = 0; i < log.records.size(); ++i) {
    std::optional<rangenav::Transform2d> odom;  // the laser frame's odometry, when known
    if (log.odometry[i]) odom = log.odometry[i]->to_isometry();
    slam.process(log.records[i].scan, odom);
  }
  slam.finish();                              // a last optimisation if a loop is pending
  const auto trajectory = slam.trajectory();  // every scan, at the optimised key frames
  const auto map = slam.map_points();         // the submaps, re-anchored
  // [snippet-end]

  REQUIRE(trajectory.size() == truth.poses.size());
  std::vector<rangenav::Pose2d> poses;
  for (const auto& t : trajectory)
    poses.push_back(rangenav::Pose2d::from_isometry(t));
  CHECK(docs::ate_rmse(poses, truth.poses) < 0.05);
  CHECK(!map.empty());
}
