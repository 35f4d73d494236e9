// Polygon clipping for the geometric map (paper 004 §3.4): union and intersection test of two
// overlapping concave 64-vertex polygons with each PolygonClipper backend (Boost.Geometry, and
// Clipper's Vatti algorithm when RANGENAV_HAVE_CLIPPER), on two pairs: /0 two star polygons whose
// boundaries cross 86 times, /1 two three-lobed polygons whose boundaries cross twice (the cost
// of an overlay grows with the crossings, the counter `crossings`); and GeometricMap insertion: the
// kitchen's five true planes seen in 20 key frames, each view a 64-vertex jagged hull of a random
// window of the plane, tilted and shifted a little, as plane extraction would deliver them.

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include "rangenav/geometry/planar_polygon.hpp"
#include "rangenav/geometry/polygon_clipper.hpp"
#include "rangenav/mapping/geometric_map.hpp"
#include "rangenav/sim/worlds.hpp"
#ifdef RANGENAV_HAVE_CLIPPER
#include "rangenav/geometry/vatti_clipper.hpp"
#endif

namespace {

using rangenav::Point2d;
using rangenav::Point3d;
using rangenav::Polygon2;

// A star-shaped concave polygon with n vertices around `center`, radii alternating between
// [r0, r1] and half of that.
Polygon2<> star(Point2d center, int n, double r0, double r1, std::mt19937& rng) {
  std::uniform_real_distribution<double> radius(r0, r1);
  Polygon2<> p;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    const double r = (i % 2 == 0) ? radius(rng) : 0.5 * radius(rng);
    p.outer.push_back(center + r * Point2d(std::cos(a), std::sin(a)));
  }
  return p;
}

// A concave polygon with n vertices and three lobes around `center`: radius 1 + 0.3 sin(3 a +
// phase) m at the angle a.
Polygon2<> lobes(Point2d center, int n, double phase) {
  Polygon2<> p;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    const double r = 1 + 0.3 * std::sin(3 * a + phase);
    p.outer.push_back(center + r * Point2d(std::cos(a), std::sin(a)));
  }
  return p;
}

struct PolygonPair {
  Polygon2<> a, b;
};

// Pair 0: the stars (centres 0.67 m apart); pair 1: the lobed polygons (the same offset).
const PolygonPair& concave_pair(std::int64_t which) {
  static const PolygonPair stars = [] {
    std::mt19937 rng(64);
    PolygonPair p{star({0, 0}, 64, 0.8, 1.2, rng), star({0.6, 0.3}, 64, 0.8, 1.2, rng)};
    return p;
  }();
  static const PolygonPair lobed{lobes({0, 0}, 64, 0), lobes({0.6, 0.3}, 64, 1)};
  return which == 0 ? stars : lobed;
}

// Points where the two outer rings cross (Boost.Geometry's intersection of the closed rings as
// linestrings).
double crossings(const PolygonPair& pair) {
  namespace bg = boost::geometry;
  const auto line = [](const Polygon2<>& p) {
    bg::model::linestring<rangenav::BoostPoint2<>> l;
    for (const auto& v : p.outer)
      l.emplace_back(v.x(), v.y());
    l.push_back(l.front());
    return l;
  };
  std::vector<rangenav::BoostPoint2<>> points;
  bg::intersection(line(pair.a), line(pair.b), points);
  return static_cast<double>(points.size());
}

template <class Clipper>
void union_of(benchmark::State& state) {
  const Clipper clipper;
  const auto& pair = concave_pair(state.range(0));
  std::size_t vertices = 0;
  for (auto _ : state) {
    const auto u = clipper.union_of(pair.a, pair.b);
    vertices = u.front().outer.size();
    benchmark::DoNotOptimize(vertices);
  }
  state.counters["union_vertices"] = static_cast<double>(vertices);
  state.counters["crossings"] = crossings(pair);
}

template <class Clipper>
void intersects(benchmark::State& state) {
  const Clipper clipper;
  const auto& pair = concave_pair(state.range(0));
  for (auto _ : state) {
    bool hit = clipper.intersects(pair.a, pair.b);
    benchmark::DoNotOptimize(hit);
  }
}

// The polygons plane extraction would hand to the map: for each of `frames` key frames and each
// true kitchen plane, a random window covering 40-80 % of the plane along each axis, its boundary
// sampled at 64 points with 5 mm in-plane jitter, on a plane tilted by up to 0.3 deg and shifted
// by up to 5 mm.
std::vector<rangenav::PlanarPolygon<>> kitchen_views(int frames) {
  const auto scene = rangenav::sim::kitchen();
  std::mt19937 rng(2013);
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> gauss(0, 1);
  std::vector<rangenav::PlanarPolygon<>> views;
  for (int f = 0; f < frames; ++f) {
    for (const auto& truth : scene.planes) {
      const rangenav::Plane3<> plane{truth.normal, truth.d};
      const auto frame = rangenav::PlaneFrame<>::of(plane);
      Eigen::AlignedBox2d box;
      for (const auto& w : truth.outline)
        box.extend(frame.to_plane(w));
      const Point2d size = box.sizes();
      const Point2d extent(size.x() * (0.4 + 0.4 * unit(rng)), size.y() * (0.4 + 0.4 * unit(rng)));
      const Point2d lo = box.min() + Point2d((size.x() - extent.x()) * unit(rng),
                                             (size.y() - extent.y()) * unit(rng));
      const Point3d axis = Point3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
      const Point3d normal = Eigen::AngleAxisd(0.005 * unit(rng), axis) * plane.normal;
      const Point3d centre = frame.to_world(lo + 0.5 * extent) + 0.005 * gauss(rng) * plane.normal;
      const auto tilted = rangenav::Plane3<>::through(centre, normal);
      rangenav::PlanarPolygon<> view{tilted, rangenav::PlaneFrame<>::of(tilted), {}};
      for (int i = 0; i < 64; ++i) {  // 16 samples per side, counter-clockwise
        const double s = (i % 16) / 16.0;
        const int side = i / 16;
        Point2d p = side == 0   ? Point2d(s, 0)
                    : side == 1 ? Point2d(1, s)
                    : side == 2 ? Point2d(1 - s, 1)
                                : Point2d(0, 1 - s);
        p = lo + p.cwiseProduct(extent) + 0.005 * Point2d(gauss(rng), gauss(rng));
        view.polygon.outer.push_back(view.frame.to_plane(tilted.project(frame.to_world(p))));
      }
      views.push_back(std::move(view));
    }
  }
  return views;
}

template <class Clipper>
void map_insert(benchmark::State& state) {
  static const auto views = kitchen_views(20);
  std::size_t shapes = 0, vertices = 0;
  for (auto _ : state) {
    rangenav::GeometricMap<double, Clipper> map;
    map.insert(views);
    shapes = map.size();
    vertices = map.vertex_count();
    benchmark::DoNotOptimize(shapes);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) *
                          static_cast<std::int64_t>(views.size()));
  state.counters["polygons"] = static_cast<double>(views.size());
  state.counters["map_shapes"] = static_cast<double>(shapes);
  state.counters["map_vertices"] = static_cast<double>(vertices);
}

}  // namespace

BENCHMARK_TEMPLATE(union_of, rangenav::BoostGeometryClipper)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(intersects, rangenav::BoostGeometryClipper)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(map_insert, rangenav::BoostGeometryClipper)->Unit(benchmark::kMillisecond);
#ifdef RANGENAV_HAVE_CLIPPER
BENCHMARK_TEMPLATE(union_of, rangenav::VattiClipper)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(intersects, rangenav::VattiClipper)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(map_insert, rangenav::VattiClipper)->Unit(benchmark::kMillisecond);
#endif

BENCHMARK_MAIN();
