// Euclidean clustering, alpha-shape concave hulls and iterative RANSAC plane extraction
// (paper 004 §3.3), against brute force and closed-form shapes.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <numeric>
#include <random>
#include <span>
#include <tuple>
#include <vector>

#include "rangenav/core/cloud.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/geometry/concave_hull.hpp"
#include "rangenav/geometry/euclidean_clustering.hpp"
#include "rangenav/geometry/plane_extraction.hpp"
#include "rangenav/search/kd_tree.hpp"
#include "rangenav/search/nearest_neighbor_search.hpp"

using namespace rangenav;

namespace {

// ---- clustering ---------------------------------------------------------------------------

std::size_t find_root(std::vector<std::size_t>& parent, std::size_t i) {
  while (parent[i] != i)
    i = parent[i] = parent[parent[i]];
  return i;
}

/// Brute-force connected components under `tolerance` (all pairs, union-find), each sorted.
std::vector<std::vector<std::uint32_t>> brute_force_clusters(const std::vector<Point3d>& pts,
                                                             double tolerance) {
  std::vector<std::size_t> parent(pts.size());
  std::iota(parent.begin(), parent.end(), std::size_t{0});
  for (std::size_t i = 0; i < pts.size(); ++i)
    for (std::size_t j = i + 1; j < pts.size(); ++j)
      if ((pts[i] - pts[j]).squaredNorm() < tolerance * tolerance)
        parent[find_root(parent, i)] = find_root(parent, j);
  std::vector<std::vector<std::uint32_t>> by_root(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i)
    by_root[find_root(parent, i)].push_back(static_cast<std::uint32_t>(i));
  std::vector<std::vector<std::uint32_t>> out;
  for (auto& c : by_root)
    if (!c.empty()) out.push_back(std::move(c));
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::vector<std::uint32_t>> sorted_clusters(std::vector<std::vector<std::uint32_t>> c) {
  for (auto& v : c)
    std::sort(v.begin(), v.end());
  std::sort(c.begin(), c.end());
  return c;
}

}  // namespace

TEST_CASE("euclidean_clusters equals brute-force connected components", "[geometry]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 2.0);
  std::normal_distribution<double> blob(0.0, 0.05);
  std::vector<Point3d> pts;
  for (int b = 0; b < 6; ++b) {
    const Point3d c(u(rng), u(rng), u(rng));
    for (int k = 0; k < 60; ++k)
      pts.push_back(c + Point3d(blob(rng), blob(rng), blob(rng)));
  }
  for (int k = 0; k < 40; ++k)
    pts.emplace_back(u(rng), u(rng), u(rng));  // scattered points, mostly singletons
  const KdTree<3, double> tree(pts);
  for (const double tol : {0.03, 0.08, 0.2}) {
    const auto clusters =
        euclidean_clusters(tree, {tol, 1, std::numeric_limits<std::size_t>::max()});
    CHECK(sorted_clusters(clusters) == brute_force_clusters(pts, tol));
    for (std::size_t i = 1; i < clusters.size(); ++i)
      CHECK(clusters[i - 1].size() >= clusters[i].size());
  }
  // The same partition through the brute-force search model.
  const BruteForceSearch<3, double> brute(pts);
  CHECK(sorted_clusters(euclidean_clusters(brute, {0.08, 1, 1000})) ==
        brute_force_clusters(pts, 0.08));
}

TEST_CASE("euclidean_clusters keeps known clusters within the size bounds", "[geometry]") {
  // Three lines of points 1 cm apart, 20, 50 and 80 points, 1 m from each other.
  std::vector<Point3d> pts;
  for (int line = 0; line < 3; ++line)
    for (int k = 0; k < 20 + 30 * line; ++k)
      pts.emplace_back(0.01 * k, 1.0 * line, 0.0);
  const KdTree<3, double> tree(pts);
  const auto all = euclidean_clusters(tree, {0.015, 1, 1000});
  REQUIRE(all.size() == 3);
  CHECK(all[0].size() == 80);
  CHECK(all[1].size() == 50);
  CHECK(all[2].size() == 20);
  const auto mid = euclidean_clusters(tree, {0.015, 30, 60});
  REQUIRE(mid.size() == 1);
  CHECK(mid[0].size() == 50);
  CHECK(euclidean_clusters(tree, {0.009, 2, 1000}).empty());  // every point alone
  CHECK(euclidean_clusters(KdTree<3, double>(std::vector<Point3d>{}), {}).empty());
  CHECK_THROWS_WITH(
      euclidean_clusters(tree, {0.0, 1, 10}),
      "rangenav: euclidean_clusters: argument 'params.tolerance' = 0 must be finite and > 0");
  CHECK_THROWS_WITH(
      euclidean_clusters(tree, {0.1, 10, 5}),
      "rangenav: euclidean_clusters: argument 'params.max_cluster_size' = 5 must be >= "
      "params.min_cluster_size = 10");
}

TEST_CASE("organized_euclidean_clusters equals kd-tree clustering on an organised frame",
          "[geometry]") {
  // A 120 x 90 depth-camera-like frame (pixel pitch 1 cm at the surfaces, depth noise 2 mm):
  // a back wall at x = 3, a box face 0.3 m in front of it, a thin pole 0.1 m in front of the
  // wall, a row of isolated returns, and NaN pixels (no return) in a stripe and at random.
  const std::size_t width = 120, height = 90;
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 0.002);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Cloud<3, double> cloud;
  cloud.width = width;
  cloud.height = height;
  for (std::size_t r = 0; r < height; ++r)
    for (std::size_t c = 0; c < width; ++c) {
      const double y = 0.01 * double(c), z = 0.01 * double(r);
      double x = 3.0;
      if (c >= 20 && c < 50 && r >= 10 && r < 60) x = 2.7;  // box
      if (c >= 80 && c < 83) x = 2.9;                       // pole, full height
      Point3d p(x + noise(rng), y, z);
      if (r == 70 && c % 7 == 0) p.x() = 1.0 + 0.01 * double(c);  // isolated returns
      if ((c >= 60 && c < 63 && r < 40) || u(rng) < 0.02) p = Point3d::Constant(nan);
      cloud.points.push_back(p);
    }
  std::vector<Point3d> finite;
  std::vector<std::uint32_t> frame_index;
  for (std::size_t i = 0; i < cloud.points.size(); ++i)
    if (cloud.points[i].allFinite()) {
      finite.push_back(cloud.points[i]);
      frame_index.push_back(static_cast<std::uint32_t>(i));
    }
  const KdTree<3, double> tree(finite);
  for (const EuclideanClusteringParams params :
       {EuclideanClusteringParams{0.025, 1, 1000000}, EuclideanClusteringParams{0.025, 50, 3000}}) {
    auto reference = euclidean_clusters(tree, params);
    for (auto& cluster : reference)  // kd-tree indices -> frame indices
      for (auto& i : cluster)
        i = frame_index[i];
    const auto organised = organized_euclidean_clusters(cloud, params);
    CHECK(sorted_clusters(organised) == sorted_clusters(reference));
    for (std::size_t i = 1; i < organised.size(); ++i)
      CHECK(organised[i - 1].size() >= organised[i].size());
    for (const auto& cluster : organised)
      CHECK(std::is_sorted(cluster.begin(), cluster.end()));
  }
  // The wall left and right of the full-height pole (the NaN stripe ends at row 40 and splits
  // nothing), the box, the pole and 18 isolated returns.
  const auto all = organized_euclidean_clusters(cloud, {0.025, 1, 1000000});
  CHECK(all.size() == 4 + 18);
  CHECK(organized_euclidean_clusters(cloud, {0.025, 100, 1000000}).size() == 4);
  // Bad input.
  const std::vector<Point3d> six(6, Point3d::Zero());
  CHECK_THROWS_WITH(organized_euclidean_clusters(std::span<const Point3d>(six), 4, 2),
                    "rangenav: organized_euclidean_clusters: argument 'width*height' = 8 must "
                    "equal points.size() = 6");
  Cloud<3, double> flat;
  flat.points = six;
  flat.width = 6;
  CHECK_THROWS_WITH(organized_euclidean_clusters(flat),
                    "rangenav: organized_euclidean_clusters: argument 'cloud.height' = 1 must be > "
                    "1 (an organised cloud)");
  CHECK_THROWS_WITH(
      organized_euclidean_clusters(cloud, {-1.0, 1, 10}),
      "rangenav: organized_euclidean_clusters: argument 'params.tolerance' = -1 must be finite "
      "and > 0");
}

TEST_CASE("organized_euclidean_clusters equals brute-force 8-neighbour components", "[geometry]") {
  // Reference: every 8-neighbour pair of finite points closer than the tolerance united, clusters
  // in increasing index order, ordered by size (ties: smallest first index). The row-run
  // implementation skips diagonal tests that a two-link path already covers; jittered samples
  // at a tolerance near the pixel pitch make many links (diagonals alone, too) come and go.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (int trial = 0; trial < 40; ++trial) {
    const std::size_t width = 5 + rng() % 40, height = 2 + rng() % 30;
    const double jitter = 0.001 * double(trial % 5), tol = 0.009 + 0.0007 * double(trial % 9);
    std::vector<Point3d> pts;
    for (std::size_t r = 0; r < height; ++r)
      for (std::size_t c = 0; c < width; ++c) {
        Point3d p(0.01 * double(c) + jitter * (u(rng) - 0.5),
                  0.01 * double(r) + jitter * (u(rng) - 0.5), (u(rng) < 0.05 ? 0.5 : 0.0));
        const double x = u(rng);
        if (x < 0.08) p = Point3d::Constant(nan);
        if (x > 0.98) p.y() = inf;
        pts.push_back(p);
      }
    std::vector<std::size_t> parent(pts.size());
    std::iota(parent.begin(), parent.end(), std::size_t{0});
    const auto ok = [&](std::size_t i) { return pts[i].allFinite(); };
    for (std::size_t r = 0; r < height; ++r)
      for (std::size_t c = 0; c < width; ++c)
        for (int dr = -1; dr <= 1; ++dr)
          for (int dc = -1; dc <= 1; ++dc) {
            const auto rr = static_cast<std::ptrdiff_t>(r) + dr;
            const auto cc = static_cast<std::ptrdiff_t>(c) + dc;
            if (rr < 0 || cc < 0 || rr >= std::ptrdiff_t(height) || cc >= std::ptrdiff_t(width))
              continue;
            const std::size_t i = r * width + c, j = std::size_t(rr) * width + std::size_t(cc);
            if (ok(i) && ok(j) && (pts[i] - pts[j]).squaredNorm() < tol * tol) {
              const std::size_t a = find_root(parent, i), b = find_root(parent, j);
              parent[std::max(a, b)] = std::min(a, b);
            }
          }
    for (const std::size_t min_size : {std::size_t{1}, std::size_t{3}}) {
      std::vector<std::vector<std::uint32_t>> by_root(pts.size()), reference;
      for (std::size_t i = 0; i < pts.size(); ++i)
        if (ok(i)) by_root[find_root(parent, i)].push_back(static_cast<std::uint32_t>(i));
      for (auto& cl : by_root)
        if (cl.size() >= min_size && cl.size() <= 200) reference.push_back(cl);
      std::stable_sort(reference.begin(), reference.end(),
                       [](const auto& a, const auto& b) { return a.size() > b.size(); });
      std::size_t finite = 0;
      CHECK(organized_euclidean_clusters(std::span<const Point3d>(pts), width, height,
                                         {tol, min_size, 200}, &finite) == reference);
      CHECK(finite == static_cast<std::size_t>(std::count_if(
                          pts.begin(), pts.end(), [](const Point3d& p) { return p.allFinite(); })));
    }
  }
}

// ---- concave hull -------------------------------------------------------------------------

namespace {

/// Grid samples at `step` of the points inside a predicate over [x0, x1] x [y0, y1].
template <class Inside>
std::vector<Point2d> grid_samples(double x0, double y0, double x1, double y1, double step,
                                  Inside inside) {
  std::vector<Point2d> pts;
  const int nx = static_cast<int>(std::lround((x1 - x0) / step));
  const int ny = static_cast<int>(std::lround((y1 - y0) / step));
  for (int i = 0; i <= nx; ++i)
    for (int j = 0; j <= ny; ++j) {
      const Point2d p(x0 + step * i, y0 + step * j);
      if (inside(p)) pts.push_back(p);
    }
  return pts;
}

bool is_simple_ccw(const std::vector<Point2d>& ring) {
  if (Polygon2<double>::ring_signed_area(ring) <= 0) return false;
  std::vector<Point2d> sorted = ring;  // no repeated vertex
  std::sort(sorted.begin(), sorted.end(), [](const Point2d& a, const Point2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  return std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end();
}

}  // namespace

TEST_CASE("concave_hull of an L-shape follows its concave corner", "[geometry]") {
  // L = [0, 2] x [0, 1] united with [0, 1] x [1, 2]: area 3, perimeter 8.
  const double step = 0.02;
  const auto pts = grid_samples(
      0, 0, 2, 2, step, [](const Point2d& p) { return p.y() <= 1 + 1e-9 || p.x() <= 1 + 1e-9; });
  const auto hulls = concave_hull(pts, {0.03, 0.001, 0.0});
  REQUIRE(hulls.size() == 1);
  const auto& poly = hulls[0];
  CHECK(poly.holes.empty());
  CHECK(is_simple_ccw(poly.outer));
  // The samples' alpha shape is the L with its reflex corner cut by half a grid cell: the
  // triangle (1, 1), (1 + s, 1), (1, 1 + s) is a Delaunay triangle of circumradius s / sqrt 2.
  CHECK(poly.area() == Approx(3.0 + step * step / 2).epsilon(1e-9));
  // Every boundary vertex lies on the L's boundary; the corner (1, 1) is cut off.
  bool corner = false;
  for (const Point2d& p : poly.outer) {
    const bool on_edge = std::abs(p.x()) < 1e-9 || std::abs(p.y()) < 1e-9 ||
                         (std::abs(p.x() - 2) < 1e-9 && p.y() <= 1 + 1e-9) ||
                         (std::abs(p.y() - 2) < 1e-9 && p.x() <= 1 + 1e-9) ||
                         (std::abs(p.x() - 1) < 1e-9 && p.y() >= 1 - 1e-9) ||
                         (std::abs(p.y() - 1) < 1e-9 && p.x() >= 1 - 1e-9);
    CHECK(on_edge);
    corner = corner || (p - Point2d(1, 1)).norm() < 1e-9;
  }
  CHECK(!corner);
  // A huge alpha gives the convex hull instead: area 4 - 1/2.
  const auto convex = concave_hull(pts, {10.0, 0.001, 0.0});
  REQUIRE(convex.size() == 1);
  CHECK(convex[0].area() == Approx(3.5).epsilon(1e-9));
}

TEST_CASE("concave_hull of a square with a hole has one clockwise hole", "[geometry]") {
  // [0, 2]^2 without the open square (0.6, 1.4)^2: area 4 - 0.64 = 3.36, and as in the L-shape
  // every corner of the hole is cut by a triangle of half a grid cell, s^2 / 2 = 0.0002.
  const auto pts = grid_samples(0, 0, 2, 2, 0.02, [](const Point2d& p) {
    return !(p.x() > 0.6 + 1e-9 && p.x() < 1.4 - 1e-9 && p.y() > 0.6 + 1e-9 && p.y() < 1.4 - 1e-9);
  });
  const auto hulls = concave_hull(pts, {0.03, 0.001, 0.0});
  REQUIRE(hulls.size() == 1);
  REQUIRE(hulls[0].holes.size() == 1);
  CHECK(Polygon2<double>::ring_signed_area(hulls[0].outer) == Approx(4.0));
  CHECK(Polygon2<double>::ring_signed_area(hulls[0].holes[0]) == Approx(-0.64 + 4 * 0.0002));
  CHECK(hulls[0].area() == Approx(3.36 + 4 * 0.0002));
}

TEST_CASE("concave_hull of disc samples approaches the disc", "[geometry]") {
  // Uniform random samples of a disc of radius 1: the hull's area tends to pi from below and its
  // vertices lie near the circle.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Point2d> pts;
  while (pts.size() < 20000) {
    const Point2d p(u(rng), u(rng));
    if (p.norm() <= 1.0) pts.push_back(p);
  }
  const auto hulls = concave_hull(pts, {0.1, 0.001, 0.0});
  REQUIRE(hulls.size() == 1);
  CHECK(hulls[0].holes.empty());
  CHECK(is_simple_ccw(hulls[0].outer));
  CHECK(hulls[0].area() == Approx(std::numbers::pi).epsilon(0.01));
  CHECK(hulls[0].area() < std::numbers::pi);
  for (const Point2d& p : hulls[0].outer)
    CHECK(p.norm() > 0.95);
}

TEST_CASE("concave_hull separates pieces and handles degenerate input", "[geometry]") {
  // Two unit squares 0.5 m apart: two polygons, largest first; min_area drops the small one.
  auto pts = grid_samples(0, 0, 1, 1, 0.05, [](const Point2d&) { return true; });
  for (const Point2d& p : grid_samples(1.5, 0, 2.0, 0.5, 0.05, [](const Point2d&) { return true; }))
    pts.push_back(p);
  const auto two = concave_hull(pts, {0.05, 0.001, 0.0});
  REQUIRE(two.size() == 2);
  CHECK(two[0].area() == Approx(1.0));
  CHECK(two[1].area() == Approx(0.25));
  CHECK(concave_hull(pts, {0.05, 0.001, 0.3}).size() == 1);
  // Fewer than three distinct points, collinear points, alpha below the spacing: nothing.
  CHECK(concave_hull(std::vector<Point2d>{{0, 0}, {1, 0}, {1, 0}}).empty());
  CHECK(concave_hull(std::vector<Point2d>{{0, 0}, {1, 0}, {2, 0}, {3, 0}}).empty());
  CHECK(concave_hull(pts, {0.01, 0.001, 0.0}).empty());
  CHECK(concave_hull(std::vector<Point2d>{}).empty());
  CHECK_THROWS_WITH(concave_hull(std::vector<Point2d>{{0, 0}, {std::nan(""), 1}}),
                    "rangenav: ConcaveHull::compute: argument 'cloud[1]' = nan 1 must be finite");
  CHECK_THROWS_WITH(ConcaveHull({-1.0, 0.001, 0.0}),
                    "rangenav: ConcaveHull: argument 'params.alpha' = -1 must be finite and > 0");
}

TEST_CASE("concave_hull thinning is invariant under shifts by whole cells", "[geometry]") {
  // The thinning cells are the floor division of grid coordinates by the cell edge (computed
  // through a multiplication by its inverse plus a correction): shifting the input by whole
  // cells, to negative coordinates, across zero or onto exact multiples, must give the same
  // polygons, shifted, and the same pieces. Points on grid steps so that snapping is exact.
  const double res = 0.001, alpha = 0.04;
  const double steps = std::floor(0.5 * alpha / res);  // the cell edge in grid steps
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> jitter(-2, 2);
  std::vector<Point2d> base;
  for (int i = 0; i <= 150; ++i)
    for (int j = 0; j <= 100; ++j) {
      const Point2d p(0.004 * i, 0.004 * j);
      const bool hole = (p - Point2d(0.2, 0.2)).norm() < 0.08;
      const bool notch = p.x() > 0.45 && p.y() < 0.15;
      if (!hole && !notch)
        base.emplace_back(res * (4 * i + jitter(rng)), res * (4 * j + jitter(rng)));
    }
  ConcaveHullParams params{alpha, res, 0.0, 0.5};
  std::vector<std::int32_t> piece0, piece1;
  const auto hull0 = ConcaveHull(params).compute(base, &piece0);
  REQUIRE(hull0.size() == 1);
  CHECK(hull0[0].holes.size() == 1);
  for (const double cells : {-7.0, 3.0, -40.0, 1.0}) {
    const Point2d shift(cells * steps * res, -2 * cells * steps * res);
    std::vector<Point2d> moved = base;
    for (Point2d& p : moved)
      p += shift;
    const auto hull1 = ConcaveHull(params).compute(moved, &piece1);
    REQUIRE(hull1.size() == hull0.size());
    CHECK(piece1 == piece0);
    REQUIRE(hull1[0].outer.size() == hull0[0].outer.size());
    REQUIRE(hull1[0].holes.size() == hull0[0].holes.size());
    double worst = 0;
    for (std::size_t v = 0; v < hull0[0].outer.size(); ++v)
      worst = std::max(worst, (hull1[0].outer[v] - shift - hull0[0].outer[v]).norm());
    for (std::size_t v = 0; v < hull0[0].holes[0].size(); ++v)
      worst = std::max(worst, (hull1[0].holes[0][v] - shift - hull0[0].holes[0][v]).norm());
    CHECK(worst < 1e-9);
  }
}

TEST_CASE("concave_hull thinning of a sparse wide input keeps every square patch", "[geometry]") {
  // Five square lattice patches of 7..11 points a side (4 mm pitch) spread over 2 m: the box is
  // much wider than the input is large, so the thinning cells are found point by point (not by
  // the coordinate tables of dense inputs). Ground truth: each patch's alpha shape (alpha 4 cm)
  // is its square, area ((m - 1) 4 mm)^2, and its points form one piece; also after shifts by
  // whole and fractional cells onto negative coordinates.
  const double res = 0.001, alpha = 0.04;
  for (const double shift_x : {0.0, -1.3, -0.0207, 0.5}) {
    const double shift_y = -shift_x / 2;
    std::vector<Point2d> points;
    std::vector<int> patch_of;
    for (int p = 0; p < 5; ++p) {
      const int m = 7 + p;
      for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j) {
          points.emplace_back(shift_x + 0.5 * p + 0.004 * i, shift_y + 0.004 * j);
          patch_of.push_back(p);
        }
    }
    std::vector<std::int32_t> piece;
    const auto hull = ConcaveHull({alpha, res, 0.0, 0.5}).compute(points, &piece);
    REQUIRE(hull.size() == 5);
    for (std::size_t k = 0; k < hull.size(); ++k) {  // largest first: the 11-point patch
      const double side = 0.004 * double(11 - 1 - k);
      CHECK(hull[k].holes.empty());
      CHECK(hull[k].area() == Approx(side * side).epsilon(1e-9));
    }
    for (std::size_t i = 0; i < points.size(); ++i)
      CHECK(piece[i] == 4 - patch_of[i]);
  }
}

TEST_CASE("concave_hull sparse interior gives the same alpha shape", "[geometry]") {
  // Deep interior cells keep a site only at even cell coordinates; the file comment proves that
  // the alpha shape does not change. Random unions of discs and rectangles with holes, sampled
  // on jittered grids of random pitch, random alpha, thinning 0.5 and 0.3: the same polygons,
  // vertex for vertex, and the same piece for every point.
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 12; ++trial) {
    struct Disc {
      Point2d c;
      double r;
      bool hole;
    };
    std::vector<Disc> discs;
    for (int k = 0; k < 6; ++k)
      discs.push_back({Point2d(1.5 * u(rng), 1.0 * u(rng)), 0.15 + 0.35 * u(rng), k >= 4});
    const double bx = 0.3 + 0.6 * u(rng);  // a rectangle from (bx, 0.2) to (bx + 0.7, 0.6)
    const auto inside = [&](const Point2d& p) {
      bool in = p.x() > bx && p.x() < bx + 0.7 && p.y() > 0.2 && p.y() < 0.6;
      for (const Disc& d : discs)
        if (!d.hole && (p - d.c).norm() < d.r) in = true;
      for (const Disc& d : discs)
        if (d.hole && (p - d.c).norm() < 0.3 * d.r) in = false;
      return in;
    };
    const double step = 0.004 + 0.004 * u(rng), alpha = 0.03 + 0.04 * u(rng);
    std::uniform_real_distribution<double> jitter(-0.4 * step, 0.4 * step);
    std::vector<Point2d> pts;
    for (double x = -0.5; x < 2.2; x += step)
      for (double y = -0.5; y < 1.6; y += step) {
        const Point2d p(x + jitter(rng), y + jitter(rng));
        if (inside(p)) pts.push_back(p);
      }
    for (const double thinning : {0.5, 0.3}) {
      ConcaveHullParams params{alpha, 0.001, 0.0, thinning};
      std::vector<std::int32_t> piece_sparse, piece_dense;
      const auto sparse = ConcaveHull(params).compute(pts, &piece_sparse);
      params.sparse_interior = false;
      const auto dense = ConcaveHull(params).compute(pts, &piece_dense);
      REQUIRE(!dense.empty());
      REQUIRE(sparse.size() == dense.size());
      for (std::size_t k = 0; k < dense.size(); ++k) {
        CHECK(sparse[k].outer == dense[k].outer);
        CHECK(sparse[k].holes == dense[k].holes);
      }
      CHECK(piece_sparse == piece_dense);
      // One hull object reused across calls (as PlaneExtractor does), a small unthinned input
      // in between: the same pieces per point as fresh objects.
      ConcaveHull reused(params);
      std::vector<std::int32_t> piece_again, piece_small, piece_small_fresh;
      const std::vector<Point2d> small(pts.begin(), pts.begin() + 40);  // < 64: no thinning
      (void)reused.compute(pts, &piece_again);
      (void)reused.compute(small, &piece_small);
      (void)ConcaveHull(params).compute(small, &piece_small_fresh);
      CHECK(piece_small == piece_small_fresh);
      (void)reused.compute(pts, &piece_again);
      CHECK(piece_again == piece_dense);
    }
  }
}

TEST_CASE("concave_hull interior thinning keeps the shape, its holes, pieces and areas",
          "[geometry]") {
  // Jittered samples every 5 mm of: a 1.2 m x 0.8 m rectangle with a 0.3 m disc hole, a 0.4 m
  // disc 0.2 m to its right and an L-shaped bay cut into its lower edge.
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> jitter(-0.002, 0.002);
  const auto inside = [](const Point2d& p) {
    const bool rect = p.x() >= 0 && p.x() <= 1.2 && p.y() >= 0 && p.y() <= 0.8;
    const bool hole = (p - Point2d(0.4, 0.4)).norm() < 0.15;
    const bool bay = p.x() > 0.8 && p.x() < 1.0 && p.y() < 0.3 && !(p.x() > 0.9 && p.y() < 0.2);
    const bool disc = (p - Point2d(1.6, 0.4)).norm() <= 0.2;
    return (rect && !hole && !bay) || disc;
  };
  std::vector<Point2d> pts;
  for (int i = -10; i <= 370; ++i)
    for (int j = -10; j <= 170; ++j) {
      const Point2d p(0.005 * i + jitter(rng), 0.005 * j + jitter(rng));
      if (inside(p)) pts.push_back(p);
    }
  std::vector<std::int32_t> piece_full, piece_thin;
  ConcaveHullParams params{0.05, 0.001, 0.0};
  const auto full = ConcaveHull(params).compute(pts, &piece_full);
  // Boundary cells keep their extremes towards every empty neighbour (all_corners) or, the
  // default, corner extremes only at convex corners and notches of the occupied cells.
  for (const auto& [thinning, all_corners] : {std::pair{0.25, true}, std::pair{0.5, true},
                                              std::pair{0.25, false}, std::pair{0.5, false}}) {
    params.thinning = thinning;
    params.all_corners = all_corners;
    const auto thin = ConcaveHull(params).compute(pts, &piece_thin);
    REQUIRE(full.size() == 2);
    REQUIRE(thin.size() == 2);
    for (std::size_t k = 0; k < 2; ++k) {
      CHECK(thin[k].holes.size() == full[k].holes.size());
      CHECK(thin[k].area() == Approx(full[k].area()).epsilon(0.003));
      CHECK(is_simple_ccw(thin[k].outer));
    }
    // The boundary is made of points kept as they are: far fewer sites, same outline within a
    // few millimetres (every vertex of the thinned outline is an input point near the full one).
    CHECK(thin[0].outer.size() < full[0].outer.size());
    CHECK(thin[0].holes.size() == 1);
    std::size_t same = 0;
    for (std::size_t i = 0; i < pts.size(); ++i)
      same += piece_thin[i] == piece_full[i] ? 1 : 0;
    CHECK(double(same) >= 0.999 * double(pts.size()));
  }
  CHECK(full[0].area() == Approx(1.2 * 0.8 - std::numbers::pi * 0.15 * 0.15 - 0.04).epsilon(0.01));
  params.thinning = 0.75;
  CHECK_THROWS_WITH(ConcaveHull(params),
                    "rangenav: ConcaveHull: argument 'params.thinning' = 0.75 must be in [0, 0.5]");
}

// ---- plane extraction ---------------------------------------------------------------------

namespace {

/// A corner of a room: floor z = 0 ([0, 2] x [0, 2]), wall x = 0 (y in [0, 2], z in [0, 1.5])
/// and a table top z = 0.7 ([1, 1.6] x [0.8, 1.4]); samples every 2.5 cm with Gaussian noise.
std::vector<Point3d> room_corner(double sigma, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma > 0 ? sigma : 1.0);
  const auto n = [&]() { return sigma > 0 ? noise(rng) : 0.0; };
  std::vector<Point3d> pts;
  const double s = 0.025;
  for (int i = 0; i <= 80; ++i)
    for (int j = 0; j <= 80; ++j) {
      pts.emplace_back(s * i, s * j, n());               // floor
      if (i <= 60) pts.emplace_back(n(), s * j, s * i);  // wall
    }
  for (int i = 0; i <= 24; ++i)
    for (int j = 0; j <= 24; ++j)
      pts.emplace_back(1.0 + s * i, 0.8 + s * j, 0.7 + n());
  return pts;
}

const ExtractedPlane* find_plane(const std::vector<ExtractedPlane>& planes, const Point3d& normal,
                                 double d) {
  for (const auto& p : planes) {
    Plane3<double> pl = p.shape.plane;
    if (pl.normal.dot(normal) < 0) pl = pl.flipped();
    if (pl.normal.dot(normal) > 0.999 && std::abs(pl.d - d) < 0.01) return &p;
  }
  return nullptr;
}

}  // namespace

TEST_CASE("PlaneExtractor finds the planes of a room corner with their outlines", "[geometry]") {
  const auto pts = room_corner(0.005, 11);
  PlaneExtractionParams params;
  params.distance_threshold = 0.02;
  params.min_inliers = 200;
  params.hull.alpha = 0.05;
  params.viewpoint = Point3d(3, 3, 2);
  PlaneExtractor extractor(params);
  std::mt19937 rng(1);
  std::vector<ExtractedPlane> planes;
  CHECK(extractor.extract(pts, rng, planes) == 3);
  REQUIRE(planes.size() == 3);
  const auto* floor = find_plane(planes, {0, 0, 1}, 0.0);
  const auto* wall = find_plane(planes, {1, 0, 0}, 0.0);
  const auto* table = find_plane(planes, {0, 0, 1}, -0.7);
  REQUIRE(floor != nullptr);
  REQUIRE(wall != nullptr);
  REQUIRE(table != nullptr);
  CHECK(floor->shape.plane.normal.z() > 0.999);  // faces the viewpoint
  CHECK(wall->shape.plane.normal.x() > 0.999);
  CHECK(floor->inliers >= 81 * 81 - 100);
  CHECK(floor->rms == Approx(0.005).epsilon(0.2));
  // Outline areas against the true rectangles (noise and the 2 cm band blur the borders).
  CHECK(floor->shape.area() == Approx(4.0).epsilon(0.03));
  CHECK(wall->shape.area() == Approx(3.0).epsilon(0.03));
  CHECK(table->shape.area() == Approx(0.36).epsilon(0.06));
  for (const auto& p : planes)
    CHECK(is_simple_ccw(p.shape.polygon.outer));
  for (const Point3d& v : table->shape.outer_world()) {
    CHECK(v.z() == Approx(0.7).margin(0.01));
    CHECK(v.x() > 0.98);
    CHECK(v.x() < 1.62);
  }
}

TEST_CASE("PlaneExtractor's rms is the RMS distance of its inliers, far from the origin",
          "[geometry]") {
  // One tilted 0.6 m x 0.6 m patch, 1 cm pitch, uniform noise of +-4 mm along its normal, 200 m
  // from the world origin: every point is an inlier of the one plane, and the reported rms (from
  // the moments) is the brute-force RMS of n . p + d over the points.
  const Point3d centre(200.0, -120.0, 35.0);
  const Point3d normal = Point3d(0.3, -0.2, 1.0).normalized();
  const Point3d u = normal.cross(Point3d::UnitX()).normalized(), v = normal.cross(u);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> noise(-0.004, 0.004);
  std::vector<Point3d> pts;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 60; ++j)
      pts.push_back(centre + 0.01 * (i - 30) * u + 0.01 * (j - 30) * v + noise(rng) * normal);
  PlaneExtractionParams params;
  params.min_inliers = 200;
  PlaneExtractor extractor(params);
  std::vector<ExtractedPlane> planes;
  REQUIRE(extractor.extract(pts, rng, planes) == 1);
  const ExtractedPlane& e = planes.front();
  REQUIRE(e.inliers == pts.size());
  double sum_sq = 0;
  for (const Point3d& p : pts)
    sum_sq += std::pow(e.shape.plane.signed_distance(p), 2);
  CHECK(e.rms == Approx(std::sqrt(sum_sq / double(pts.size()))).epsilon(1e-9));
  CHECK(e.rms == Approx(0.004 / std::sqrt(3.0)).epsilon(0.05));  // uniform noise's RMS
  CHECK(std::abs(e.shape.plane.normal.dot(normal)) > 0.9999);
}

TEST_CASE("PlaneExtractor honours the orientation constraint and is deterministic", "[geometry]") {
  const auto pts = room_corner(0.0, 2);
  PlaneExtractionParams params;
  params.min_inliers = 200;
  params.axis = Point3d(0, 0, 2);  // horizontal planes only
  PlaneExtractor extractor(params);
  std::mt19937 rng(5);
  std::vector<ExtractedPlane> planes;
  extractor.extract(pts, rng, planes);
  REQUIRE(planes.size() == 2);
  for (const auto& p : planes)
    CHECK(std::abs(p.shape.plane.normal.z()) > 0.999);
  CHECK(find_plane(planes, {0, 0, 1}, -0.7) != nullptr);

  // The same seed gives the same planes; a cluster subset gives only its plane.
  PlaneExtractor again(params);
  std::mt19937 rng2(5);
  std::vector<ExtractedPlane> planes2;
  again.extract(pts, rng2, planes2);
  REQUIRE(planes2.size() == planes.size());
  for (std::size_t i = 0; i < planes.size(); ++i) {
    CHECK(planes2[i].shape.plane.normal == planes[i].shape.plane.normal);
    CHECK(planes2[i].shape.polygon.outer == planes[i].shape.polygon.outer);
  }
  std::vector<std::uint32_t> table;
  for (std::size_t i = 0; i < pts.size(); ++i)
    if (pts[i].z() > 0.6 && pts[i].x() > 0.5) table.push_back(static_cast<std::uint32_t>(i));
  std::vector<ExtractedPlane> only;
  CHECK(PlaneExtractor(PlaneExtractionParams{}).extract(pts, table, rng, only) == 1);
  REQUIRE(only.size() == 1);
  CHECK(only[0].inliers == 625);
  CHECK(find_plane(only, {0, 0, 1}, -0.7) != nullptr);
}

TEST_CASE("PlaneExtractor scores hypotheses on a subset and finds the same planes", "[geometry]") {
  // The room corner with the hypotheses scored on 300 points, on 2000 (the default) and on all:
  // the same three planes, inliers and outlines within a few percent.
  const auto pts = room_corner(0.005, 11);
  std::vector<std::vector<ExtractedPlane>> runs;
  for (const std::size_t subset : {std::size_t{0}, std::size_t{300}, std::size_t{2000}}) {
    PlaneExtractionParams params;
    params.min_inliers = 200;
    params.evaluation_subset = subset;
    PlaneExtractor extractor(params);
    std::mt19937 rng(3);
    runs.emplace_back();
    extractor.extract(pts, rng, runs.back());
  }
  for (const auto& planes : runs) {
    REQUIRE(planes.size() == 3);
    for (const auto& [normal, d, inliers, area] :
         {std::tuple{Point3d(0, 0, 1), 0.0, 81 * 81, 4.0},
          std::tuple{Point3d(1, 0, 0), 0.0, 81 * 61, 3.0},
          std::tuple{Point3d(0, 0, 1), -0.7, 25 * 25, 0.36}}) {
      const auto* plane = find_plane(planes, normal, d);
      REQUIRE(plane != nullptr);
      CHECK(double(plane->inliers) == Approx(inliers).epsilon(0.03));
      CHECK(plane->shape.area() == Approx(area).epsilon(0.06));
    }
  }
}

TEST_CASE("PlaneExtractor with a pose equals extraction on the transformed points", "[geometry]") {
  // The mapper hands sensor-frame points and the sensor pose; the extractor transforms each
  // cluster point as it copies it. Reference: the points transformed beforehand (x_w = R x + t),
  // the same seed: the same planes (normals, offsets, hulls, inliers) up to rounding.
  const auto world = room_corner(0.005, 11);
  Transform3d pose = Transform3d::Identity();
  pose.linear() = Eigen::AngleAxisd(0.7, Point3d(0.2, -0.5, 1).normalized()).toRotationMatrix();
  pose.translation() = Point3d(1.5, -2.0, 0.4);
  std::vector<Point3d> local(world.size());
  for (std::size_t i = 0; i < world.size(); ++i)
    local[i] = pose.inverse() * world[i];
  std::vector<Point3d> again(world.size());  // the reference's own world points
  for (std::size_t i = 0; i < world.size(); ++i)
    again[i] = pose.linear() * local[i] + pose.translation();
  std::vector<std::uint32_t> all(world.size());
  std::iota(all.begin(), all.end(), 0u);
  PlaneExtractionParams params;
  params.min_inliers = 200;
  std::vector<ExtractedPlane> by_pose, reference;
  std::mt19937 rng1(3), rng2(3);
  PlaneExtractor(params).extract(local, all, pose, rng1, by_pose);
  PlaneExtractor(params).extract(again, all, rng2, reference);
  REQUIRE(reference.size() == 3);
  REQUIRE(by_pose.size() == reference.size());
  for (std::size_t k = 0; k < reference.size(); ++k) {
    CHECK(by_pose[k].inliers == reference[k].inliers);
    CHECK(by_pose[k].shape.plane.normal.isApprox(reference[k].shape.plane.normal, 1e-12));
    CHECK(by_pose[k].shape.plane.d == Approx(reference[k].shape.plane.d).margin(1e-12));
    CHECK(by_pose[k].shape.area() == Approx(reference[k].shape.area()).epsilon(1e-12));
  }
  // The room corner's floor and wall, found in the world frame.
  CHECK(find_plane(by_pose, {0, 0, 1}, 0.0) != nullptr);
  CHECK(find_plane(by_pose, {1, 0, 0}, 0.0) != nullptr);
}

TEST_CASE("PlaneExtractor stops on small clusters and rejects bad input", "[geometry]") {
  std::mt19937 rng(1);
  std::vector<ExtractedPlane> out;
  PlaneExtractionParams params;
  params.min_inliers = 50;
  PlaneExtractor ex(params);
  // Points on no plane (a sphere shell): nothing.
  std::vector<Point3d> shell;
  std::normal_distribution<double> g(0.0, 1.0);
  for (int k = 0; k < 400; ++k)
    shell.push_back(Point3d(g(rng), g(rng), g(rng)).normalized());
  CHECK(ex.extract(shell, rng, out) == 0);
  // Fewer points than min_inliers: nothing, no RANSAC.
  std::vector<Point3d> few(10, Point3d(1, 2, 3));
  CHECK(ex.extract(few, rng, out) == 0);
  const std::vector<std::uint32_t> bad{0, 10};
  CHECK_THROWS_WITH(ex.extract(few, bad, rng, out),
                    "rangenav: PlaneExtractor::extract: argument 'cluster index' = 10 must be < "
                    "points.size() = 10");
  PlaneExtractionParams wrong;
  wrong.min_inliers = 2;
  CHECK_THROWS_WITH(PlaneExtractor{wrong},
                    "rangenav: PlaneExtractor: argument 'params.min_inliers' = 2 must be >= 3");
  wrong = {};
  wrong.confidence = 1.0;
  CHECK_THROWS_WITH(PlaneExtractor{wrong},
                    "rangenav: PlaneExtractor: argument 'params.confidence' = 1 must be in (0, 1)");
}

TEST_CASE("PlaneExtractor goes on after a RANSAC plane made of small pieces", "[geometry]") {
  // Ground truth: a floor z = 0 ([0, 0.5]^2, 1 cm pitch, 2,601 points) and eight coplanar
  // patches on the plane x = 2 (0.2 m x 0.2 m each, 441 points, 0.1 m apart: separate pieces of
  // the alpha shape), 3,528 points together. RANSAC's best plane is the patches' (more inliers
  // than the floor), but its surface, the largest piece, has fewer than min_inliers points. The
  // floor is still a plane of the cluster and must come out; the patches stay unassigned.
  std::vector<Point3d> pts;
  for (int i = 0; i <= 50; ++i)
    for (int j = 0; j <= 50; ++j)
      pts.emplace_back(0.01 * i, 0.01 * j, 0.0);
  for (int k = 0; k < 8; ++k)
    for (int i = 0; i <= 20; ++i)
      for (int j = 0; j <= 20; ++j)
        pts.emplace_back(2.0, 0.3 * k + 0.01 * i, 0.5 + 0.01 * j);
  PlaneExtractionParams params;
  params.min_inliers = 1000;
  params.hull.alpha = 0.05;
  for (const std::uint32_t seed : {1u, 2u, 3u}) {
    std::mt19937 rng(seed);
    std::vector<ExtractedPlane> planes;
    CHECK(PlaneExtractor(params).extract(pts, rng, planes) == 1);
    REQUIRE(planes.size() == 1);
    const auto* floor = find_plane(planes, {0, 0, 1}, 0.0);
    REQUIRE(floor != nullptr);
    CHECK(floor->inliers == 51 * 51);
    CHECK(floor->shape.area() == Approx(0.25).epsilon(0.03));
  }
  // With no failed hypothesis allowed, the cluster ends at the patches' plane (the old
  // behaviour): the bound is what lets the floor through.
  params.max_failed_hypotheses = 0;
  std::mt19937 rng(1);
  std::vector<ExtractedPlane> planes;
  CHECK(PlaneExtractor(params).extract(pts, rng, planes) == 0);
}
