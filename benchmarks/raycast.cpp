// Ray casting in the simulator (rangenav::sim): time per simulated scan or frame and rays per
// second. The "100-wall world" is 100 random walls (0.5-3 m) in a 12 m x 12 m square room; the
// scanner sits in the middle. Compared: the World's uniform grid walked by a DDA (what the
// simulator uses), testing every wall, and a Boost.Geometry rtree of the walls' bounding boxes
// queried with each beam's segment (candidates then tested exactly).

#include <benchmark/benchmark.h>

#include <boost/geometry.hpp>
#include <boost/geometry/index/rtree.hpp>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

using namespace rangenav;
using namespace rangenav::sim;

namespace {

World hundred_walls(double cell_size = 0) {
  World w;
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> pos(-5.5, 5.5), len(0.5, 3.0),
      ang(-std::numbers::pi, std::numbers::pi);
  const std::vector<Point2d> room{{-6, -6}, {6, -6}, {6, 6}, {-6, 6}};
  w.add_polygon(room);
  while (w.walls().size() < 100) {
    const Point2d a(pos(rng), pos(rng));
    const double t = ang(rng);
    if (a.norm() < 1.0) continue;  // keep the scanner's spot free
    w.add_wall(a, a + len(rng) * Point2d(std::cos(t), std::sin(t)));
  }
  w.build_index(cell_size);
  return w;
}

LaserScannerParams scan361() {
  LaserScannerParams p;
  p.geometry = ScanGeometry<double>::from_fov(deg_to_rad(180.0), deg_to_rad(0.5), 0.05, 30.0);
  p.noise.sigma = 0;
  return p;
}

void BM_Scan361_100Walls_Grid(benchmark::State& state) {
  const World w = hundred_walls(static_cast<double>(state.range(0)) / 100.0);
  const LaserScanner2D laser(scan361());
  std::mt19937 rng(1);
  std::vector<double> ranges;
  double theta = 0;
  for (auto _ : state) {
    laser.ranges_into(w, {0, 0, theta}, rng, ranges);
    benchmark::DoNotOptimize(ranges.data());
    theta = normalize_angle(theta + 0.1);
  }
  state.counters["rays/s"] = benchmark::Counter(361.0 * static_cast<double>(state.iterations()),
                                                benchmark::Counter::kIsRate);
  state.counters["cell_m"] = w.cell_size();
}
// Argument: grid cell size in cm (0 = automatic).
BENCHMARK(BM_Scan361_100Walls_Grid)
    ->Arg(0)
    ->Arg(25)
    ->Arg(50)
    ->Arg(100)
    ->Arg(200)
    ->Unit(benchmark::kMicrosecond);

void BM_Scan361_100Walls_EveryWall(benchmark::State& state) {
  const World w = hundred_walls();
  std::vector<Point2d> dirs;
  for (int i = 0; i < 361; ++i) {
    const double a = deg_to_rad(-90.0 + 0.5 * i);
    dirs.emplace_back(std::cos(a), std::sin(a));
  }
  for (auto _ : state) {
    for (const auto& d : dirs)
      benchmark::DoNotOptimize(w.cast_ray_2d_exhaustive({0, 0}, d, 0.3, 30).range);
  }
  state.counters["rays/s"] = benchmark::Counter(361.0 * static_cast<double>(state.iterations()),
                                                benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Scan361_100Walls_EveryWall)->Unit(benchmark::kMicrosecond);

void BM_Scan361_100Walls_BoostRtree(benchmark::State& state) {
  namespace bg = boost::geometry;
  namespace bgi = boost::geometry::index;
  using P = bg::model::point<double, 2, bg::cs::cartesian>;
  using B = bg::model::box<P>;
  using S = bg::model::segment<P>;
  const World w = hundred_walls();
  std::vector<std::pair<B, std::size_t>> boxes;
  for (std::size_t i = 0; i < w.walls().size(); ++i) {
    const auto& wall = w.walls()[i];
    const Point2d lo = wall.a.cwiseMin(wall.b), hi = wall.a.cwiseMax(wall.b);
    boxes.push_back({B(P(lo.x(), lo.y()), P(hi.x(), hi.y())), i});
  }
  const bgi::rtree<std::pair<B, std::size_t>, bgi::quadratic<16>> tree(boxes);
  std::vector<Point2d> dirs;
  for (int i = 0; i < 361; ++i) {
    const double a = deg_to_rad(-90.0 + 0.5 * i);
    dirs.emplace_back(std::cos(a), std::sin(a));
  }
  std::vector<std::pair<B, std::size_t>> hits;
  for (auto _ : state) {
    for (const auto& d : dirs) {
      hits.clear();
      const S beam(P(0, 0), P(30 * d.x(), 30 * d.y()));
      tree.query(bgi::intersects(beam), std::back_inserter(hits));
      double best = 30;
      for (const auto& h : hits) {  // exact ray-segment test, as World does
        const auto& wall = w.walls()[h.second];
        const Point2d e = wall.b - wall.a;
        const double den = d.x() * e.y() - d.y() * e.x();
        if (den == 0) continue;
        const double t = (wall.a.x() * e.y() - wall.a.y() * e.x()) / den;
        const double s = (wall.a.x() * d.y() - wall.a.y() * d.x()) / den;
        if (s >= 0 && s <= 1 && t >= 0) best = std::min(best, t);
      }
      benchmark::DoNotOptimize(best);
    }
  }
  state.counters["rays/s"] = benchmark::Counter(361.0 * static_cast<double>(state.iterations()),
                                                benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Scan361_100Walls_BoostRtree)->Unit(benchmark::kMicrosecond);

void BM_ApartmentS300Scan(benchmark::State& state) {
  const Scene s = apartment();
  LaserScannerParams p;  // S300 defaults: 541 beams, 1 cm noise
  const LaserScanner2D laser(p);
  std::mt19937 rng(1);
  std::vector<double> ranges;
  std::size_t k = 0;
  for (auto _ : state) {
    const Point2d q = s.tour[k++ % s.tour.size()];
    laser.ranges_into(s.world, {q.x(), q.y(), 0.3}, rng, ranges);
    benchmark::DoNotOptimize(ranges.data());
  }
  state.counters["rays/s"] = benchmark::Counter(541.0 * static_cast<double>(state.iterations()),
                                                benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ApartmentS300Scan)->Unit(benchmark::kMicrosecond);

void BM_ApartmentPitchingScan(benchmark::State& state) {
  const Scene s = apartment();
  const PitchingScanner scanner;
  std::mt19937 rng(1);
  std::size_t k = 0;
  for (auto _ : state) {
    const Point2d q = s.tour[k % s.tour.size()];
    auto scan = scanner.scan(s.world, {q.x(), q.y(), 0.3}, scanner.scan_time(k), rng);
    ++k;
    benchmark::DoNotOptimize(scan.pitch);
  }
  state.counters["rays/s"] = benchmark::Counter(181.0 * static_cast<double>(state.iterations()),
                                                benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ApartmentPitchingScan)->Unit(benchmark::kMicrosecond);

void BM_ApartmentTofFrame(benchmark::State& state) {
  const Scene s = apartment();
  TofCameraParams p;
  p.jump_edges = state.range(0) != 0;
  p.tilt = deg_to_rad(20.0);
  const TofCamera cam(p);
  std::mt19937 rng(1);
  for (auto _ : state) {
    auto img = cam.capture(s.world, {3.0, 3.4, -std::numbers::pi / 2}, rng);
    benchmark::DoNotOptimize(img.depth.data());
  }
  state.counters["pixels/s"] = benchmark::Counter(
      176.0 * 144.0 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
// Argument: jump edges (mixed pixels) off / on.
BENCHMARK(BM_ApartmentTofFrame)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
