#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <vector>

#include "rangenav/io/slam_relations.hpp"

using namespace rangenav;

namespace {
std::filesystem::path write_temp(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / name;
  std::ofstream(path) << text;
  return path;
}
}  // namespace

TEST_CASE("SLAM-benchmark relations: reading and evaluating a trajectory", "[io]") {
  // Relations in the benchmark's format (two spaces between fields 5 and 6, as in the CSAIL file).
  const auto path = write_temp("rangenav_test.relations",
                               "10.0 11.0 1.000000 0.000000 0.000000  0.000000 0.000000 0.000000\n"
                               "11.0 12.0 0.000000 1.000000 0.000000  0.000000 0.000000 1.570796\n"
                               "\n");
  const auto relations = io::read_slam_relations(path);
  REQUIRE(relations.size() == 2);
  CHECK(relations[1].delta.theta == Approx(1.570796));

  // A trajectory that fulfils both relations exactly, expressed in an arbitrary frame.
  const Pose2d origin{3.0, -2.0, 0.7};
  std::vector<io::StampedPose2d> traj = {
      {10.0, origin},
      {11.0, compose(origin, Pose2d{1, 0, 0})},
      {12.0, compose(compose(origin, Pose2d{1, 0, 0}), Pose2d{0, 1, 1.570796})}};
  auto eval = io::evaluate_slam_relations(traj, relations);
  CHECK(eval.translation.count == 2);
  CHECK(eval.translation.mean == Approx(0.0).margin(1e-9));
  CHECK(eval.rotation.mean == Approx(0.0).margin(1e-6));

  // The last pose 0.1 m off along its own x and turned 1 degree: only relation 2 is affected.
  traj[2].pose = compose(traj[2].pose, Pose2d{0.1, 0.0, std::numbers::pi / 180});
  eval = io::evaluate_slam_relations(traj, relations);
  CHECK(eval.translation.mean == Approx(0.05));
  CHECK(eval.translation.stddev == Approx(0.05));
  CHECK(eval.rotation.mean == Approx(0.5));
  const auto first_only = io::evaluate_slam_relations(
      traj, relations, [](const auto& r) { return r.timestamp1 < 10.5; });
  CHECK(first_only.translation.count == 1);
  CHECK(first_only.translation.mean == Approx(0.0).margin(1e-9));

  // A pose farther than 0.1 s from a relation's timestamp is missing.
  traj[2].timestamp = 12.2;
  eval = io::evaluate_slam_relations(traj, relations);
  CHECK(eval.missing == 1);
  CHECK(eval.translation.count == 1);
}

TEST_CASE("SLAM-benchmark relations: malformed files", "[io]") {
  const auto path =
      write_temp("rangenav_bad.relations", "10.0 11.0 1.0 0.0 0.0 0.0 0.0 0.0\n10 11 x\n");
  CHECK_THROWS_WITH(io::read_slam_relations(path),
                    "rangenav: read_slam_relations: " + path.string() +
                        ":2: expected 8 numbers 'timestamp1 timestamp2 x y z roll pitch yaw'");
  CHECK_THROWS_AS(io::read_slam_relations("/nonexistent/file.relations"), io_error);
}
