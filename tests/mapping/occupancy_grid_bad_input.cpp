// OccupancyGrid's bad-input table (issue 21): boxes and points whose cells overflow an index,
// non-finite poses, readings far beyond the grid, cells outside the grid. Each gives an
// invalid_argument naming the argument, or a finite result computed in bounded time (the ray of
// a 5e8 m reading is clipped to the grid instead of walked cell by cell).
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <vector>

#include "bad_input.hpp"
#include "rangenav/mapping/occupancy_grid.hpp"

using namespace rangenav;
using Catch::Matchers::Contains;
using Index = OccupancyGrid::Index;
using rangenav::test::error_of;

namespace {
constexpr double qnan = std::numeric_limits<double>::quiet_NaN();
constexpr double inf = std::numeric_limits<double>::infinity();

OccupancyGridParams unit_cells() {
  OccupancyGridParams p;
  p.resolution = 1.0;
  p.max_free_range = 5.0;
  return p;
}

/// Cells whose state differs from unknown.
int observed(const OccupancyGrid& g) {
  int n = 0;
  for (int y = 0; y < g.height(); ++y)
    for (int x = 0; x < g.width(); ++x)
      n += g.is_unknown({x, y}) ? 0 : 1;
  return n;
}
}  // namespace

TEST_CASE("OccupancyGrid: boxes and origins that overflow are invalid_arguments",
          "[mapping][bad]") {
  const auto covering = [](Point2d lo, Point2d hi, double margin) {
    return error_of<invalid_argument>([&] { (void)OccupancyGrid::covering(lo, hi, margin); });
  };
  // +-1e300 built a 1-cell grid through an overflowed conversion before.
  CHECK_THAT(covering({-1e300, 0}, {1e300, 1}, 0.5),
             Contains("argument 'x extent of [lo, hi] + margin' = 2.0000000000000001e+300 m "
                      "needs more than 32768 cells of 0.050000000000000003 m"));
  CHECK_THAT(covering({-1e308, 0}, {1e308, 1}, 0.5),
             Contains("argument 'x extent of [lo, hi] + margin' = inf"));
  CHECK_THAT(covering({0, 0}, {1, 1e4}, 0.5), Contains("argument 'y extent"));
  CHECK_THAT(covering({0, qnan}, {1, 1}, 0.5), Contains("the box [lo, hi] must be finite"));
  CHECK_THAT(covering({0, 0}, {1, 1}, inf), Contains("argument 'margin' = inf"));
  CHECK_THAT(covering({0, 0}, {1, 1}, -1), Contains("argument 'margin' = -1"));
  OccupancyGridParams huge;
  huge.resolution = 1e307;
  CHECK_THAT(error_of<invalid_argument>([&] {
               (void)OccupancyGrid({1.7e308, 0}, 10, 10, huge);
             }),
             Contains("origin + size * resolution overflows"));
  CHECK_THAT(error_of<invalid_argument>([] {
               (void)OccupancyGrid({0, 0}, 0, 10, {});
             }),
             Contains("argument 'width' = 0"));
  CHECK_THAT(error_of<invalid_argument>([] {
               (void)OccupancyGrid({0, 0}, 10, 40000, {});
             }),
             Contains("argument 'height' = 40000"));
  // Each side within bounds, the grid not: 18 GB of cells.
  CHECK_THAT(error_of<invalid_argument>([] {
               (void)OccupancyGrid({0, 0}, 32768, 32768, {});
             }),
             Contains("argument 'width * height' = 1073741824 must be <= 134217728 cells"));
  OccupancyGridParams p;
  p.resolution = qnan;
  CHECK_THAT(error_of<invalid_argument>([&] {
               (void)OccupancyGrid({0, 0}, 10, 10, p);
             }),
             Contains("argument 'resolution' = nan"));
}

TEST_CASE("OccupancyGrid: far and non-finite points map to cells outside, never an overflow",
          "[mapping][bad]") {
  const OccupancyGrid g({0, 0}, 10, 10, unit_cells());
  for (const Point2d& p : std::vector<Point2d>{
           {1e12, 0}, {-1e12, 5}, {5, 1e300}, {qnan, 5}, {inf, -inf}, {-1e308, 1e308}}) {
    INFO(p.transpose());
    const Index c = g.cell_of(p);
    CHECK_FALSE(g.contains(c));
    CHECK(std::abs(c.x()) <= (1 << 30));
    CHECK(std::abs(c.y()) <= (1 << 30));
  }
  CHECK(g.cell_of({9.5, 0.5}) == Index(9, 0));
  // Rays are clipped to the grid and a border of one grid width: a bounded number of cells.
  const auto count = [&](const Point2d& a, const Point2d& b) {
    int n = 0;
    g.trace(a, b, [&](const Index&) { ++n; });
    return n;
  };
  CHECK(count({0.5, 0.5}, {5e8, 0.5}) == 20 + 1);     // x from cell 0 to 20
  CHECK(count({-1e12, 0.5}, {1e12, 0.5}) == 30 + 1);  // x from -10 to 20
  CHECK(count({0.5, 0.5}, {qnan, 0.5}) == 0);
  CHECK(count({0.5, 0.5}, {0.5, inf}) == 0);
  CHECK(count({-1e12, -1e12}, {-2e12, -1e12}) == 0);  // nowhere near the grid
}

TEST_CASE("OccupancyGrid: integrate validates the pose and clips the rays", "[mapping][bad]") {
  OccupancyGrid g({0, 0}, 10, 10, unit_cells());
  const LaserScand beam(0.0, 0.1, 0.0, 1e9, {5e8});
  for (const double bad : {qnan, inf, -inf}) {
    CHECK_THAT(error_of<invalid_argument>([&] {
                 (void)g.integrate({bad, 0.5, 0}, beam);
               }),
               Contains("OccupancyGrid::integrate: argument 'sensor_pose.x'"));
    CHECK_THAT(error_of<invalid_argument>([&] {
                 (void)g.integrate({0.5, 0.5, bad}, beam);
               }),
               Contains("argument 'sensor_pose.theta'"));
  }
  CHECK(observed(g) == 0);
  // A 5e8 m reading (valid for range_max 1e9) hung before: the ray walked 1e10 cells.
  const ScanClassification c = g.integrate({0.5, 0.5, 0}, beam);
  CHECK(c.static_beams.size() == 1);
  CHECK(observed(g) == 10);  // the row the beam crosses, cleared; its end is far outside
  for (int x = 0; x < 10; ++x)
    CHECK(g.is_free({x, 0}));
  // A sensor 1e12 m away: its rays never reach the grid.
  OccupancyGrid far({0, 0}, 10, 10, unit_cells());
  (void)far.integrate({1e12, 0, 0}, LaserScand(-1.0, 0.5, 0.0, 30.0, {2, 3, 4, 5, 31}));
  CHECK(observed(far) == 0);
}

TEST_CASE("OccupancyGrid: cells outside the grid given to an accessor are invalid_arguments",
          "[mapping][bad]") {
  OccupancyGrid g({0, 0}, 4, 3, unit_cells());
  for (const Index& c : std::vector<Index>{{-1, 0}, {4, 0}, {0, 3}, {0, -2147483647 - 1}}) {
    INFO(c.transpose());
    const auto outside = Contains("is outside the 4 x 3 grid");
    CHECK_THAT(error_of<invalid_argument>([&] { (void)g.log_odds_at(c); }), outside);
    CHECK_THAT(error_of<invalid_argument>([&] { (void)g.probability(c); }), outside);
    CHECK_THAT(error_of<invalid_argument>([&] { (void)g.is_occupied(c); }), outside);
    CHECK_THAT(error_of<invalid_argument>([&] { (void)g.is_transient(c); }), outside);
    CHECK_THAT(error_of<invalid_argument>([&] { (void)g.is_seen_occupied(c); }), outside);
    CHECK_THAT(error_of<invalid_argument>([&] { (void)g.mean_hit_point(c); }), outside);
    CHECK_THAT(error_of<invalid_argument>([&] { g.clear_cell(c); }), outside);
    CHECK_THAT(error_of<invalid_argument>([&] { g.set_log_odds(c, 1.0); }), outside);
  }
  CHECK_THAT(error_of<invalid_argument>([&] {
               g.set_log_odds({1, 1}, qnan);
             }),
             Contains("argument 'l' = nan must not be NaN"));
  g.set_log_odds({1, 1}, -inf);  // clamped, as any value beyond the bounds
  CHECK(g.probability({1, 1}) == Approx(g.params().min_probability));
}
