#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "rangenav/core/parallel.hpp"
#include "rangenav/geometry/voxel_grid.hpp"

using namespace rangenav;

TEST_CASE("voxel filter: one centroid per occupied voxel, ordered by voxel", "[geometry]") {
  // Two points per unit voxel at known offsets: the centroid is the voxel's centre.
  std::vector<Eigen::Vector3d> pts;
  for (int x = -2; x < 2; ++x)
    for (int y = 0; y < 3; ++y) {
      pts.emplace_back(x + 0.25, y + 0.25, 0.5);
      pts.emplace_back(x + 0.75, y + 0.75, 0.5);
    }
  pts.emplace_back(std::numeric_limits<double>::quiet_NaN(), 0, 0);
  const auto out = voxel_downsample(pts, 1.0);
  REQUIRE(out.size() == 12);
  for (std::size_t i = 0; i < out.size(); ++i) {
    CHECK(out[i].x() - std::floor(out[i].x()) == Approx(0.5));
    CHECK(out[i].y() - std::floor(out[i].y()) == Approx(0.5));
    if (i > 0) CHECK(out[i - 1].x() <= out[i].x());
  }
  CHECK_THROWS_AS(voxel_downsample(pts, 0.0), invalid_argument);
  CHECK_THROWS_AS(voxel_downsample(pts, 1.0, 0), invalid_argument);
}

TEST_CASE("voxel filter: any thread count gives the serial output bit for bit", "[geometry]") {
  INFO("OpenMP enabled: " << parallel_enabled);
  std::mt19937 rng(4);
  std::normal_distribution<double> n(0, 3);
  std::vector<Eigen::Vector3d> pts(50000);
  for (auto& p : pts)
    p = {n(rng), n(rng), 0.3 * n(rng)};
  pts[17] = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  pts[99] = Eigen::Vector3d(1e12, 0, 0);  // beyond the 21-bit key range: skipped
  const auto serial = voxel_downsample(pts, 0.1);
  for (const int threads : {2, 3, 8}) {
    const auto parallel = voxel_downsample(pts, 0.1, threads);
    CHECK(parallel == serial);
  }
  std::vector<Eigen::Vector2f> flat(20000);
  for (auto& p : flat)
    p = {static_cast<float>(n(rng)), static_cast<float>(n(rng))};
  CHECK(voxel_downsample(flat, 0.05f, 2) == voxel_downsample(flat, 0.05f));
}
