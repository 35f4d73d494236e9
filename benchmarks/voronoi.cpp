// Voronoi path graph (paper 000 §4): build + pruning next to Boost.Polygon's bare
// construct_voronoi on the same (already snapped) points, for 1k, 10k and 100k map points, and
// A* query time on the largest graph.
//
// Two layouts: "random" (uniform points in a square, 10 points per m^2) and "rooms" (points
// scattered along the walls of a k x k grid of 4 m rooms with 1 m doors, 5 cm apart on average:
// what a sparse point map of a building looks like).

#include <benchmark/benchmark.h>

#include <algorithm>
#include <boost/polygon/voronoi.hpp>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <random>
#include <vector>

#include "rangenav/planning/a_star.hpp"
#include "rangenav/planning/voronoi_path_graph.hpp"

namespace {

using rangenav::Point2d;

std::vector<Point2d> random_map(std::size_t n) {
  std::mt19937 rng(42);
  const double side = std::sqrt(static_cast<double>(n) / 10.0);
  std::uniform_real_distribution<double> u(0.0, side);
  std::vector<Point2d> pts(n);
  for (auto& p : pts) {
    const double x = u(rng);  // sequenced: the order of argument evaluation is unspecified
    p = Point2d(x, u(rng));
  }
  return pts;
}

int rooms_per_side(std::size_t n) {
  // Wall length of k x k rooms of 4 m: 2 (k + 1) 4 k metres; one point per 5 cm.
  const double length = static_cast<double>(n) * 0.05;
  return std::max(1, static_cast<int>(std::lround((-1.0 + std::sqrt(1.0 + length / 2.0)) / 2.0)));
}

std::vector<Point2d> rooms_map(std::size_t n) {
  const int k = rooms_per_side(n);
  const double room = 4.0, size = k * room;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> along(0.0, size);
  std::uniform_int_distribution<int> line(0, k);
  std::uniform_int_distribution<int> axis(0, 1);
  std::normal_distribution<double> jitter(0.0, 0.005);
  std::vector<Point2d> pts;
  pts.reserve(n);
  while (pts.size() < n) {
    const int l = line(rng);
    const double t = along(rng);
    const bool outer = l == 0 || l == k;
    if (!outer && std::abs(std::fmod(t, room) - room / 2) < 0.5) continue;  // a door
    const double c = l * room + jitter(rng);
    pts.push_back(axis(rng) ? Point2d(c, t) : Point2d(t, c));
  }
  return pts;
}

std::vector<Point2d> make_map(int layout, std::size_t n) {
  return layout == 0 ? random_map(n) : rooms_map(n);
}

double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Build + prune (the reported time) and Boost.Polygon's bare construct_voronoi on the same points
// (already snapped to the 1 mm grid), run in alternating order in every iteration so both see the
// same machine load; counters: bare_ms and the ratios of the means and of the fastest runs.
void BM_GraphBuildVsBareVoronoi(benchmark::State& state) {
  const auto pts =
      make_map(static_cast<int>(state.range(0)), static_cast<std::size_t>(state.range(1)));
  std::vector<boost::polygon::point_data<std::int32_t>> grid;
  grid.reserve(pts.size());
  for (const auto& p : pts)
    grid.emplace_back(static_cast<std::int32_t>(std::lround(p.x() / 0.001)),
                      static_cast<std::int32_t>(std::lround(p.y() / 0.001)));
  std::size_t edges = 0, nodes = 0, iteration = 0;
  double ours_sum = 0, bare_sum = 0, ours_min = 1e9, bare_min = 1e9;
  auto ours = [&] {
    const double t0 = cpu_seconds();
    rangenav::VoronoiPathGraph graph(pts);
    benchmark::DoNotOptimize(graph.edges().data());
    edges = graph.edge_count();
    nodes = graph.node_count();
    return cpu_seconds() - t0;
  };
  auto bare = [&] {
    const double t0 = cpu_seconds();
    boost::polygon::voronoi_diagram<double> vd;
    boost::polygon::construct_voronoi(grid.begin(), grid.end(), &vd);
    benchmark::DoNotOptimize(vd.num_edges());
    return cpu_seconds() - t0;
  };
  for (auto _ : state) {
    double t_ours = 0, t_bare = 0;
    if (iteration++ % 2 == 0) {
      t_ours = ours();
      t_bare = bare();
    } else {
      t_bare = bare();
      t_ours = ours();
    }
    state.SetIterationTime(t_ours);
    ours_sum += t_ours;
    bare_sum += t_bare;
    ours_min = std::min(ours_min, t_ours);
    bare_min = std::min(bare_min, t_bare);
  }
  state.counters["bare_ms"] = 1e3 * bare_sum / static_cast<double>(iteration);
  state.counters["ratio"] = ours_sum / bare_sum;
  state.counters["ratio_min"] = ours_min / bare_min;
  state.counters["nodes"] = static_cast<double>(nodes);
  state.counters["edges"] = static_cast<double>(edges);
  state.SetLabel(state.range(0) == 0 ? "random" : "rooms");
}

void layouts(benchmark::internal::Benchmark* b) {
  for (int layout : {0, 1})
    for (int n : {1000, 10000, 100000})
      b->Args({layout, n});
}

BENCHMARK(BM_GraphBuildVsBareVoronoi)
    ->Apply(layouts)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

// A* on the 100k-point rooms map: corner room to opposite corner room, start and goal attached
// (plan), and the node-to-node search alone (shortest_path).
struct LargestGraph {
  rangenav::VoronoiPathGraph graph{rooms_map(100000)};
  rangenav::AStar planner{graph};
  double size = rooms_per_side(100000) * 4.0;
};

LargestGraph& largest() {
  static LargestGraph g;
  return g;
}

void BM_AStarPlan(benchmark::State& state) {
  auto& g = largest();
  const Point2d start(2.0, 1.0), goal(g.size - 2.0, g.size - 1.0);
  double length = 0;
  std::size_t expanded = 0;
  for (auto _ : state) {
    const auto result = g.planner.plan(start, goal);
    benchmark::DoNotOptimize(result.path.length);  // const: the "+m,r" overload miscompiles doubles
    length = result.path.length;
    expanded = result.expanded;
  }
  state.counters["path_m"] = length;
  state.counters["expanded"] = static_cast<double>(expanded);
  state.counters["graph_nodes"] = static_cast<double>(g.graph.node_count());
}
BENCHMARK(BM_AStarPlan)->Unit(benchmark::kMillisecond);

void BM_AStarNodeToNode(benchmark::State& state) {
  auto& g = largest();
  const auto first = g.planner.plan({2.0, 1.0}, {g.size - 2.0, g.size - 1.0});
  if (!first.found()) {
    state.SkipWithError("no path on the rooms map");
    return;
  }
  const auto from = first.path.nodes.front(), to = first.path.nodes.back();
  for (auto _ : state)
    benchmark::DoNotOptimize(g.planner.shortest_path(from, to));
}
BENCHMARK(BM_AStarNodeToNode)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
