#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "rangenav/search/grid_index.hpp"
#include "rangenav/search/kd_tree.hpp"
#include "rangenav/search/nearest_neighbor_search.hpp"

using namespace rangenav;

// ---- static conformance table ----------------------------------------------------------------
static_assert(NearestNeighborSearch<BruteForceSearch<2, double>>);
static_assert(NearestNeighborSearch<BruteForceSearch<3, float>>);
static_assert(NearestNeighborSearch<KdTree<2, double>>);
static_assert(NearestNeighborSearch<KdTree<2, float>>);
static_assert(NearestNeighborSearch<KdTree<3, double>>);
static_assert(NearestNeighborSearch<KdTree<3, float>>);
static_assert(NearestNeighborSearch<GrowingKdTree<2, double>>);
static_assert(NearestNeighborSearch<GrowingKdTree<3, float>>);
static_assert(NearestNeighborSearch<GridIndex2<double>>);
static_assert(NearestNeighborSearch<GridIndex2<float>>);
static_assert(!NearestNeighborSearch<std::vector<Eigen::Vector2d>>);
static_assert(!NearestNeighborSearch<int>);

namespace {

template <int D, class S>
std::vector<Point<D, S>> random_points(std::size_t n, std::mt19937& rng, S extent) {
  std::uniform_real_distribution<S> u(-extent, extent);
  std::vector<Point<D, S>> pts(n);
  for (auto& p : pts)
    for (int d = 0; d < D; ++d)
      p[d] = u(rng);
  return pts;
}

// Compares a search structure against brute force on random queries: the same distances for
// nearest (bounded and unbounded), knn and radius; indices resolve to points at those distances.
template <class Search, int D, class S>
void check_against_brute_force(const Search& search, const BruteForceSearch<D, S>& brute,
                               std::mt19937& rng, S extent) {
  REQUIRE(search.size() == brute.size());
  std::vector<Neighbor<S>> a, b;
  const auto queries = random_points<D, S>(200, rng, extent * S(1.2));
  const S tol = std::is_same_v<S, float> ? S(1e-5) : S(1e-12);
  for (const auto& q : queries) {
    const auto n1 = search.nearest(q);
    const auto n2 = brute.nearest(q);
    REQUIRE(n1.has_value() == n2.has_value());
    if (n1) {
      CHECK(n1->distance_sq == Approx(n2->distance_sq).margin(tol));
      CHECK((search.point(n1->index) - q).squaredNorm() == Approx(n1->distance_sq).margin(tol));
    }
    // A bound below the true nearest distance finds nothing; above it finds the same point.
    if (n2 && n2->distance_sq > S(0)) {
      CHECK_FALSE(search.nearest(q, n2->distance_sq * S(0.999)).has_value());
      const auto bounded = search.nearest(q, n2->distance_sq * S(1.001) + tol);
      REQUIRE(bounded.has_value());
      CHECK(bounded->distance_sq == Approx(n2->distance_sq).margin(tol));
    }
    for (std::size_t k : {1u, 5u, 17u}) {
      REQUIRE(search.knn(q, k, a) == brute.knn(q, k, b));
      for (std::size_t i = 0; i < a.size(); ++i) {
        CHECK(a[i].distance_sq == Approx(b[i].distance_sq).margin(tol));
        if (i > 0) CHECK(a[i - 1].distance_sq <= a[i].distance_sq);
      }
    }
    const S r_sq = extent * extent * S(0.02);
    REQUIRE(search.radius(q, r_sq, a) == brute.radius(q, r_sq, b));
    for (std::size_t i = 0; i < a.size(); ++i) {
      CHECK(a[i].distance_sq < r_sq);
      CHECK(a[i].distance_sq == Approx(b[i].distance_sq).margin(tol));
    }
    // knn under a bound returns only points strictly inside the bound.
    search.knn(q, 50, a, r_sq);
    brute.knn(q, 50, b, r_sq);
    CHECK(a.size() == b.size());
    for (const auto& nb : a)
      CHECK(nb.distance_sq < r_sq);
  }
}

template <int D, class S>
void static_tree_case() {
  std::mt19937 rng(42 + D);
  // 5000 and 20000 points are cut into 2 and 8 parts (KdTree::part_size).
  for (std::size_t n : {1u, 7u, 100u, 3000u, 5000u, 20000u}) {
    const auto pts = random_points<D, S>(n, rng, S(10));
    const KdTree<D, S> tree(pts);
    const BruteForceSearch<D, S> brute(pts);
    check_against_brute_force(tree, brute, rng, S(10));
  }
}

template <int D, class S>
void growing_tree_case() {
  std::mt19937 rng(7 + D);
  GrowingKdTree<D, S> tree;
  std::vector<Point<D, S>> all;
  std::uniform_int_distribution<int> batch(1, 300);
  for (int round = 0; round < 25; ++round) {
    const auto pts = random_points<D, S>(static_cast<std::size_t>(batch(rng)), rng, S(10));
    REQUIRE(tree.insert(pts) == pts.size());
    all.insert(all.end(), pts.begin(), pts.end());
    // Logarithmic chain: at most log2(n) + 1 trees.
    CHECK(static_cast<double>(tree.tree_count()) <=
          std::log2(static_cast<double>(all.size())) + 1.0);
    if (round % 6 == 5) check_against_brute_force(tree, BruteForceSearch<D, S>(all), rng, S(10));
  }
  // Indices are stable: point(i) is the i-th inserted point.
  for (std::size_t i = 0; i < all.size(); ++i)
    REQUIRE(tree.point(i) == all[i]);
  // Single-point insertion follows the binary-counter pattern.
  GrowingKdTree<D, S> single;
  for (std::size_t i = 0; i < 64; ++i)
    single.insert_point(all[i]);
  CHECK(single.tree_count() == 1);
  check_against_brute_force(
      single, BruteForceSearch<D, S>(std::vector<Point<D, S>>(all.begin(), all.begin() + 64)), rng,
      S(10));
}

}  // namespace

TEST_CASE("KdTree matches brute force in 2D and 3D, float and double", "[search]") {
  static_tree_case<2, double>();
  static_tree_case<2, float>();
  static_tree_case<3, double>();
  static_tree_case<3, float>();
}

TEST_CASE("KdTree built on several threads answers as on one, ties across its cuts included",
          "[search]") {
  // Points on an integer grid, many of them twice: the median planes pass through points, and
  // equal coordinates and equal distances fall on both sides of a cut.
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> cell(-12, 12);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 9000; ++i) {
    const Eigen::Vector3d p(double(cell(rng)), double(cell(rng)), 0.25 * cell(rng));
    pts.push_back(p);
    if (i % 3 == 0) pts.push_back(p);
  }
  REQUIRE(pts.size() >= 4 * KdTree<3, double>::part_size);
  KdTreeParams two;
  two.num_threads = 2;
  const KdTree<3, double> serial(pts), parallel(pts, two);
  const BruteForceSearch<3, double> brute(pts);
  check_against_brute_force(serial, brute, rng, 12.0);
  std::vector<Neighbor<double>> a, b;
  std::uniform_real_distribution<double> u(-13.0, 13.0);
  for (int i = 0; i < 300; ++i) {
    // Queries on grid points and planes as well as between them.
    const Eigen::Vector3d q = i % 2 == 0
                                  ? Eigen::Vector3d(double(cell(rng)), double(cell(rng)), u(rng))
                                  : Eigen::Vector3d(u(rng), u(rng), u(rng));
    REQUIRE(serial.knn(q, 9, a) == parallel.knn(q, 9, b));
    for (std::size_t j = 0; j < a.size(); ++j) {
      CHECK(a[j].index == b[j].index);
      CHECK(a[j].distance_sq == b[j].distance_sq);
    }
    const auto n1 = serial.nearest(q), n2 = parallel.nearest(q);
    REQUIRE(n1.has_value());
    REQUIRE(n2.has_value());
    CHECK(n1->index == n2->index);
  }
  KdTreeParams none;
  none.num_threads = 0;
  CHECK_THROWS_WITH((KdTree<3, double>(pts, none)),
                    "rangenav: KdTree: argument 'num_threads' = 0 must be >= 1");
}

TEST_CASE("GrowingKdTree matches brute force while growing", "[search]") {
  growing_tree_case<2, double>();
  growing_tree_case<2, float>();
  growing_tree_case<3, double>();
  growing_tree_case<3, float>();
}

TEST_CASE("GridIndex2 matches brute force while growing, with and without overflow", "[search]") {
  const auto run = [](auto scalar, std::size_t max_cells, double cell) {
    using S = decltype(scalar);
    std::mt19937 rng(11);
    GridIndex2<S> grid(GridIndexParams<S>{static_cast<S>(cell), max_cells});
    std::vector<Point<2, S>> all;
    for (int round = 0; round < 8; ++round) {
      // Batches spread outwards, so the array grows several times.
      const auto pts = random_points<2, S>(150, rng, S(2 + 2 * round));
      REQUIRE(grid.insert(pts) == pts.size());
      all.insert(all.end(), pts.begin(), pts.end());
      if (round % 3 == 2) check_against_brute_force(grid, BruteForceSearch<2, S>(all), rng, S(16));
    }
    for (std::size_t i = 0; i < all.size(); ++i)
      REQUIRE(grid.point(i) == all[i]);
    check_against_brute_force(grid, BruteForceSearch<2, S>(all), rng, S(16));
    CHECK(grid.memory_bytes() >= all.size() * sizeof(Point<2, S>));
  };
  run(double{}, std::size_t(1) << 24, 0.25);
  run(float{}, std::size_t(1) << 24, 0.5);
  run(double{}, 400, 0.25);  // most points overflow the capped array
  run(double{}, 1, 3.0);     // no array at all: every point in the overflow list

  GridIndex2<double> grid;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  CHECK(grid.insert(std::vector<Eigen::Vector2d>{{0, 0}, {nan, 1}, {1e9, 0}}) == 2);
  CHECK_FALSE(grid.insert_point({nan, 0}));
  REQUIRE(grid.nearest({1e9 - 1, 0}));
  CHECK(grid.nearest({1e9 - 1, 0})->index == 1);
  CHECK_FALSE(grid.nearest({0.5, 0}, 0.2).has_value());
  CHECK_FALSE(GridIndex2<double>().nearest({0, 0}).has_value());

  // Queries far off the array, unbounded: the same answers as brute force (before, a query
  // 10^6 m off visited the cells of 4 million rings, about 10^13 of them, and did not return).
  // Points beyond any int64 cell go to the overflow list.
  {
    std::mt19937 rng(5);
    auto pts = random_points<2, double>(500, rng, 10.0);
    pts.emplace_back(1e300, 0.0);
    pts.emplace_back(-3e18, 5.0);
    GridIndex2<double> far_grid;
    REQUIRE(far_grid.insert(pts) == pts.size());
    const BruteForceSearch<2, double> brute(pts);
    std::vector<Neighbor<double>> a, b;
    for (const Eigen::Vector2d& q :
         {Eigen::Vector2d(1e6, 3e5), Eigen::Vector2d(-40.0, 12.0), Eigen::Vector2d(0.0, -2e12),
          Eigen::Vector2d(-3e18, 0.0), Eigen::Vector2d(1e300, 1e300)}) {
      INFO("query " << q.transpose());
      REQUIRE(far_grid.knn(q, 5, a) == brute.knn(q, 5, b));
      for (std::size_t j = 0; j < a.size(); ++j)
        CHECK(a[j].index == b[j].index);
      const auto n1 = far_grid.nearest(q), n2 = brute.nearest(q);
      REQUIRE(n1.has_value() == n2.has_value());
      if (n1) CHECK(n1->index == n2->index);
      CHECK(far_grid.radius(q, 1e4, a) == brute.radius(q, 1e4, b));
    }
  }
  CHECK_THROWS_WITH(GridIndex2<double>(GridIndexParams<double>{0.0}),
                    "rangenav: GridIndex: argument 'cell_size' = 0 must be finite and > 0");
}

TEST_CASE("kd-trees skip non-finite points and map back to the source index", "[search]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Eigen::Vector2d> pts = {
      {0, 0}, {nan, 1}, {1, 0}, {std::numeric_limits<double>::infinity(), 0}, {0, 2}};
  const KdTree<2, double> tree(pts);
  REQUIRE(tree.size() == 3);
  const auto nb = tree.nearest({0.9, 0.1});
  REQUIRE(nb);
  CHECK(tree.point(nb->index) == Eigen::Vector2d(1, 0));
  CHECK(tree.source_index(nb->index) == 2);
  CHECK(tree.source_index(tree.nearest({0, 1.9})->index) == 4);
  GrowingKdTree<2, double> growing;
  CHECK(growing.insert(pts) == 3);
  CHECK_FALSE(growing.insert_point({nan, 0}));
  CHECK(growing.size() == 3);
}

TEST_CASE("kd-trees answer queries on empty and degenerate sets", "[search]") {
  std::vector<Neighbor<double>> out;
  const KdTree<3, double> empty(std::vector<Eigen::Vector3d>{});
  CHECK(empty.size() == 0);
  CHECK_FALSE(empty.nearest({0, 0, 0}).has_value());
  CHECK(empty.knn({0, 0, 0}, 3, out) == 0);
  CHECK(empty.radius({0, 0, 0}, 1.0, out) == 0);
  const GrowingKdTree<2, double> growing;
  CHECK_FALSE(growing.nearest({0, 0}).has_value());
  // All points identical: every query returns them, at equal distance.
  const std::vector<Eigen::Vector3d> same(50, Eigen::Vector3d(1, 2, 3));
  const KdTree<3, double> tree(same);
  CHECK(tree.knn({1, 2, 4}, 10, out) == 10);
  for (const auto& nb : out)
    CHECK(nb.distance_sq == Approx(1.0));
  CHECK(tree.radius({1, 2, 3}, 1e-9, out) == 50);
  CHECK(tree.knn({0, 0, 0}, 0, out) == 0);
}

TEST_CASE("KdTree rejects non-finite points in an adopted array", "[search]") {
  std::vector<Eigen::Vector2d> pts = {{0, 0}, {std::nan(""), 0}};
  CHECK_THROWS_WITH((KdTree<2, double>(std::move(pts))),
                    "rangenav: KdTree: argument 'points[1]' = (non-finite) must be finite");
}
