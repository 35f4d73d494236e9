// VirtualMap's bad-input table (issue 21): resolutions whose bin count would exhaust memory or
// overflow the rounding, non-finite motions and mountings.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "bad_input.hpp"
#include "rangenav/egocentric/virtual_map.hpp"

using namespace rangenav;
using Catch::Matchers::Contains;
using rangenav::test::error_of;

TEST_CASE("VirtualMap: bin counts beyond max_bins and non-finite motions are invalid_arguments",
          "[egocentric][bad]") {
  const auto make = [](double resolution) {
    VirtualMapParams<double> p;
    p.resolution = resolution;
    return error_of<invalid_argument>([&] { ObstacleMap<double> map(p); });
  };
  // 1e-9 rad asked for 6e9 bins (std::bad_alloc), 1e-300 rounded an infinite count.
  CHECK_THAT(make(1e-9), Contains("VirtualMap: argument 'resolution' = 1.0000000000000001e-09 "
                                  "gives more than 1048576 bins"));
  CHECK_THAT(make(1e-300), Contains("gives more than 1048576 bins"));
  CHECK_THAT(make(std::numeric_limits<double>::denorm_min()), Contains("gives more than"));
  CHECK_THAT(make(0.0), Contains("argument 'resolution' = 0 must be finite and > 0"));
  VirtualMapParams<float> pf;
  pf.resolution = 1e-30f;
  CHECK_THAT(error_of<invalid_argument>([&] { StructureMap<float> map(pf); }),
             Contains("gives more than 1048576 bins"));

  ObstacleMap<double> map;
  const LaserScand scan(-1.0, 0.5, 0.0, 30.0, {2, 3, 4, 5, 6});
  map.insert(scan);
  REQUIRE(map.valid_count() == 5);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  CHECK_THAT(error_of<invalid_argument>([&] {
               (void)map.transform({nan, 0, 0});
             }),
             Contains("VirtualMap::transform: argument 'motion.x' = nan must be finite"));
  CHECK_THAT(error_of<invalid_argument>([&] {
               (void)map.update({0, 0, inf}, scan, {});
             }),
             Contains("VirtualMap::update: argument 'motion.theta' = inf"));
  CHECK_THAT(error_of<invalid_argument>([&] {
               (void)map.insert(scan, {{0, nan, 0}, 0.3});
             }),
             Contains("VirtualMap::insert: argument 'mount.pose.y' = nan"));
  CHECK_THAT(error_of<invalid_argument>([&] {
               (void)map.insert(scan, {{0, 0, 0}, inf});
             }),
             Contains("argument 'mount.height' = inf"));
  CHECK(map.valid_count() == 5);  // nothing was changed by the rejected calls
  // A finite but huge motion leaves every point behind: flagged as merged, nothing NaN.
  const auto stats = map.transform({1e300, -1e300, 1.0});
  CHECK(stats.merged + stats.aged_out == 5);
  CHECK(map.valid_count() == 0);
  for (const auto& b : map.bins())
    CHECK(std::isfinite(b.range));
}
