#include <algorithm>
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

TEST_CASE("voxel filter: a cloud far from the origin keeps every voxel", "[geometry]") {
  // A lidar map in UTM coordinates lies millions of metres from 0, millions of voxels at
  // 0.25 m: more than a voxel key's 2^20 cells from the origin. Shifted by a whole number of
  // voxels the cloud falls into the same voxels, so the output is the shifted output of the
  // cloud at the origin (the sums at 5e6 m round to a few nm).
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-40, 40);
  std::vector<Eigen::Vector3d> near(20000);
  for (auto& p : near)
    p = {u(rng), u(rng), 0.05 * u(rng)};
  const Eigen::Vector3d shift(4 * 125000.0, 4 * 1250000.0, 4 * 25.0);  // 0.25 m voxels, exactly
  std::vector<Eigen::Vector3d> far = near;
  for (auto& p : far)
    p += shift;
  const auto expected = voxel_downsample(near, 0.25);
  REQUIRE(expected.size() > 10000);
  for (const int threads : {1, 2}) {
    const auto out = voxel_downsample(far, 0.25, threads);
    REQUIRE(out.size() == expected.size());
    double worst = 0;
    for (std::size_t i = 0; i < out.size(); ++i)
      worst = std::max(worst, (out[i] - shift - expected[i]).norm());
    CHECK(worst < 1e-6);
  }
  // A cloud that reaches 2^20 voxels or more from its first point (at 0.25 m, 300 km are 1.2
  // million voxels) no longer fits the voxel keys; it is filtered without them, and keeps every
  // point.
  const std::vector<Eigen::Vector3d> wide{{0, 0, 0}, {3e5, 0, 0}, {-1e5, 0, 0}, {3e5, 1, 0}};
  const auto both_ends = voxel_downsample(wide, 0.25);
  REQUIRE(both_ends.size() == 4);
  CHECK(both_ends.front().x() == -1e5);
  CHECK(both_ends.back().y() == 1.0);
  CHECK(voxel_downsample(wide, 0.25, 2) == both_ends);
}

TEST_CASE("voxel filter: outliers and tiny leaves lose no point", "[geometry]") {
  // The filter without voxel keys must be the keyed one: same voxels, sums and order.
  std::mt19937 rng(9);
  std::normal_distribution<double> n(0, 5);
  std::vector<Eigen::Vector3d> cloud(30000);
  for (auto& p : cloud)
    p = {n(rng), n(rng), 0.2 * n(rng)};
  for (const double leaf : {0.05, 0.3})
    CHECK(detail::voxel_downsample_exact(cloud, leaf) == voxel_downsample(cloud, leaf));

  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 100; ++i)
    pts.emplace_back(0.01 * i, 0, 0);
  const auto ten = voxel_downsample(pts, 0.1);
  REQUIRE(ten.size() == 10);
  // An outlier 1e12 m away, last or first: it is a voxel of its own, the last by cell.
  auto outlier_last = pts;
  outlier_last.emplace_back(1e12, 0, 0);
  auto outlier_first = outlier_last;
  std::rotate(outlier_first.begin(), outlier_first.end() - 1, outlier_first.end());
  for (const int threads : {1, 2}) {
    const auto last = voxel_downsample(outlier_last, 0.1, threads);
    REQUIRE(last.size() == 11);
    CHECK(std::equal(ten.begin(), ten.end(), last.begin()));
    CHECK(last.back() == Eigen::Vector3d(1e12, 0, 0));
    CHECK(voxel_downsample(outlier_first, 0.1, threads) == last);
    // A leaf far too small for the cloud: every point is a voxel of its own.
    CHECK(voxel_downsample(pts, 1e-9, threads) == pts);
    // Non-finite points (no return) are skipped, and so is a point 2^62 voxels or more from 0.
    auto gaps = pts;
    gaps.emplace_back(std::numeric_limits<double>::infinity(), 0, 0);
    gaps.insert(gaps.begin(), Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0, 0));
    gaps.emplace_back(1e300, 0, 0);
    CHECK(voxel_downsample(gaps, 0.1, threads) == ten);
  }
}
