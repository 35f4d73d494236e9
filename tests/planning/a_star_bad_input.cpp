// A*'s bad-input table (issue 21): goals whose distances overflow, start == goal, bad parameters.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <vector>

#include "bad_input.hpp"
#include "rangenav/planning/a_star.hpp"
#include "rangenav/planning/voronoi_path_graph.hpp"

using namespace rangenav;
using Catch::Matchers::Contains;
using rangenav::test::error_of;

namespace {
/// Two walls 2 m apart, sampled every 0.2 m: the graph is the corridor's centre line (y = 1).
std::vector<Point2d> corridor() {
  std::vector<Point2d> pts;
  for (int k = 0; k <= 100; ++k) {
    pts.emplace_back(0.2 * k, 0.0);
    pts.emplace_back(0.2 * k, 2.0);
  }
  return pts;
}
}  // namespace

TEST_CASE("A*: goals beyond max_coordinate and non-finite ones are invalid_arguments",
          "[planning][bad]") {
  const VoronoiPathGraph graph(corridor());
  AStar planner(graph);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // (1e300, 1e300) was "found" with an infinite length before.
  CHECK_THAT(error_of<invalid_argument>([&] {
               (void)planner.plan({5, 1}, {1e300, 1e300});
             }),
             Contains("AStar::plan: argument 'goal' = 1.0000000000000001e+300 "
                      "1.0000000000000001e+300 exceeds AStar::max_coordinate = 1e150 m"));
  CHECK_THAT(error_of<invalid_argument>([&] {
               (void)planner.plan({-1e151, 1}, {5, 1});
             }),
             Contains("argument 'start' = -1e+151 1 exceeds AStar::max_coordinate"));
  CHECK_THAT(error_of<invalid_argument>([&] {
               (void)planner.plan({5, 1}, {nan, 1});
             }),
             Contains("argument 'goal' = nan 1 must be finite"));
  // Far, but within the bound: a finite answer.
  const PlanResult far = planner.plan({5, 1}, {1e149, 1});
  CHECK(std::isfinite(far.path.length));
  CHECK_THAT(error_of<invalid_argument>([&] { AStar(graph, {.shortcut_length = nan}); }),
             Contains("argument 'params.shortcut_length' = nan"));
  CHECK_THAT(error_of<invalid_argument>([&] { AStar(graph, {.attach_candidates = 0}); }),
             Contains("argument 'params.attach_candidates' = 0"));
  // More candidates than nodes: all nodes are candidates (the count was truncated to 32 bits).
  AStar many(graph, {.attach_candidates = (std::size_t{1} << 32) + 1});
  CHECK(many.plan({5, 1}, {18, 1}).found());
}

TEST_CASE("A*: start == goal is a path of length 0, a close goal a straight segment",
          "[planning][bad]") {
  const VoronoiPathGraph graph(corridor());
  AStar planner(graph);
  // It was a 0.14 m detour through the nearest node before.
  const PlanResult same = planner.plan({5.03, 1.02}, {5.03, 1.02});
  REQUIRE(same.found());
  CHECK(same.path.length == 0.0);
  CHECK(same.path.waypoints == std::vector<Point2d>{{5.03, 1.02}});
  CHECK(same.path.nodes.empty());
  const PlanResult close = planner.plan({5.03, 1.02}, {5.5, 0.9});
  REQUIRE(close.found());
  CHECK(close.path.length == Approx((Point2d(5.5, 0.9) - Point2d(5.03, 1.02)).norm()));
  CHECK(close.path.waypoints.size() == 2);
  CHECK(close.path.edges == std::vector<AStar::index_type>{AStar::npos});
  // Without shortcut_ends the attachment of paper 000 §4 alone: through the graph.
  AStar paper(graph, {.shortcut_ends = false});
  CHECK(paper.plan({5.03, 1.02}, {5.03, 1.02}).path.length > 0.0);
}
