#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <numbers>

#include "rangenav/core/angles.hpp"
#include "rangenav/scan/laser_scan.hpp"

using namespace rangenav;

namespace {
const double qnan = std::numeric_limits<double>::quiet_NaN();
const double inf = std::numeric_limits<double>::infinity();
}  // namespace

TEST_CASE("LaserScan computes Cartesian points (Eq. 2) and flags invalid beams", "[scan]") {
  // Five beams at -90, -45, 0, 45, 90 degrees.
  const LaserScand scan(-std::numbers::pi / 2, std::numbers::pi / 4, 0.1, 30.0,
                        {1.0, qnan, 2.0, 30.0, 0.05}, {}, 12.5);
  REQUIRE(scan.size() == 5);
  CHECK(scan.angle_max() == Approx(std::numbers::pi / 2));
  CHECK(scan.timestamp() == 12.5);
  CHECK(scan.is_valid(0));
  CHECK_FALSE(scan.is_valid(1));  // NaN
  CHECK(scan.is_valid(2));
  CHECK_FALSE(scan.is_valid(3));  // at max range
  CHECK_FALSE(scan.is_valid(4));  // below min range
  CHECK(scan.point(0).isApprox(Point2d(0, -1), 1e-12));
  CHECK(scan.point(2).isApprox(Point2d(2, 0)));
  REQUIRE(scan.valid_count() == 2);
  CHECK(scan.valid_indices() == std::vector<std::uint32_t>{0, 2});
  // The PointCloud adaptor exposes exactly the valid points.
  static_assert(PointCloudOf<LaserScand, 2>);
  REQUIRE(traits::size(scan) == 2);
  CHECK(traits::point(scan, 1).isApprox(Point2d(2, 0)));
}

TEST_CASE("zero, inf and negative ranges are invalid data, not errors", "[scan]") {
  const LaserScand scan(0.0, 0.01, 0.0, 10.0, {0.0, inf, -inf, -1.0, 9.999});
  CHECK(scan.valid_count() == 1);
  CHECK(scan.is_valid(4));
  const LaserScand all_nan(0.0, 0.01, 0.0, 10.0, {qnan, qnan, qnan});
  CHECK(all_nan.valid_count() == 0);
  CHECK(traits::size(all_nan) == 0);
}

TEST_CASE("set_ranges refreshes the cache", "[scan]") {
  LaserScanf scan(0.0f, 0.5f, 0.0f, 5.0f, {1.0f, 1.0f});
  CHECK(scan.valid_count() == 2);
  scan.set_ranges({std::numeric_limits<float>::quiet_NaN(), 3.0f});
  CHECK(scan.valid_count() == 1);
  CHECK(scan.valid_points()[0].isApprox(Point2f(3 * std::cos(0.5f), 3 * std::sin(0.5f))));
  CHECK_THROWS_WITH(scan.set_ranges({1.0f}),
                    "rangenav: LaserScan::set_ranges: argument "
                    "'ranges.size()' = 1 must equal beam_count = 2");
}

TEST_CASE("ScanGeometry::from_fov gives the SICK S300 layout", "[scan]") {
  const auto g = ScanGeometry<double>::from_fov(deg_to_rad(270.0), deg_to_rad(0.5), 0.0, 30.0);
  CHECK(g.beam_count == 541);
  CHECK(g.angle_min == Approx(deg_to_rad(-135.0)));
  CHECK(g.angle_max() == Approx(deg_to_rad(135.0)));
}

TEST_CASE("LaserScan rejects bad geometry with a clear message", "[scan]") {
  CHECK_THROWS_WITH(LaserScand(0.0, 0.0, 0.0, 10.0, {1.0}),
                    "rangenav: LaserScan: argument 'angle_increment' = 0 must be finite and > 0");
  CHECK_THROWS_WITH(LaserScand(0.0, 0.1, 0.0, 10.0, {}),
                    "rangenav: LaserScan: argument 'beam_count' = 0 must be > 0");
  CHECK_THROWS_WITH(LaserScand(0.0, 0.1, 5.0, 5.0, {1.0}),
                    "rangenav: LaserScan: argument 'range_max' = 5 must exceed range_min = 5");
  CHECK_THROWS_AS(LaserScand(qnan, 0.1, 0.0, 5.0, {1.0}), invalid_argument);
  CHECK_THROWS_WITH(LaserScand(0.0, 0.1, 0.0, 5.0, {1.0, 2.0}, {1.0}),
                    "rangenav: LaserScan: argument 'intensities.size()' = 1 must be 0 or the "
                    "beam count 2");
  CHECK_THROWS_AS(LaserScand(0.0, 0.1, 0.0, 5.0, std::vector<double>(100, 1.0)), invalid_argument);
}
