#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "rangenav/registration/normals.hpp"
#include "rangenav/search/kd_tree.hpp"

using namespace rangenav;

namespace {

/// Points on the six faces of the box [0, 4] x [0, 3] x [0, 2] with their outward normals.
void box(std::mt19937& rng, std::vector<Eigen::Vector3d>& pts, std::vector<Eigen::Vector3d>& nrm) {
  std::uniform_real_distribution<double> u(0, 1);
  const Eigen::Vector3d size(4, 3, 2);
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side)
      for (int i = 0; i < 1500; ++i) {
        Eigen::Vector3d p(u(rng) * size.x(), u(rng) * size.y(), u(rng) * size.z());
        p[axis] = side * size[axis];
        pts.push_back(p);
        nrm.push_back((side == 0 ? -1.0 : 1.0) * Eigen::Vector3d::Unit(axis));
      }
}

/// Distance from p to the nearest edge of the box (where a neighbourhood spans two faces).
double edge_distance(const Eigen::Vector3d& p) {
  const Eigen::Vector3d size(4, 3, 2);
  double nearest[3];
  for (int a = 0; a < 3; ++a)
    nearest[a] = std::min(p[a], size[a] - p[a]);
  std::sort(nearest, nearest + 3);
  return nearest[1];  // the smallest is 0 (on a face); the next is the distance to an edge
}

}  // namespace

TEST_CASE("estimate_normals finds the faces' normals, turned towards the origin",
          "[registration]") {
  std::mt19937 rng(2);
  std::vector<Eigen::Vector3d> pts, truth;
  box(rng, pts, truth);
  // Seen from inside the box (the sensor at its centre, the frame's origin).
  for (auto& p : pts)
    p -= Eigen::Vector3d(2, 1.5, 1);
  const KdTree<3, double> tree(pts);
  const auto normals = estimate_normals(tree, 10);
  REQUIRE(normals.size() == pts.size());
  std::size_t checked = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (edge_distance(pts[i] + Eigen::Vector3d(2, 1.5, 1)) < 0.3) continue;
    ++checked;
    CHECK(normals[i].norm() == Approx(1));
    CHECK(normals[i].dot(-truth[i]) > 0.999);  // inward: towards the origin
  }
  CHECK(checked > pts.size() / 2);
}

TEST_CASE("estimate_covariances: eps across the surface, 1 along it (Segal et al.)",
          "[registration]") {
  std::mt19937 rng(3);
  std::vector<Eigen::Vector3d> pts, truth;
  box(rng, pts, truth);
  const KdTree<3, double> tree(pts);
  const auto cov = estimate_covariances(tree, 10, 1, 1e-3);
  REQUIRE(cov.size() == pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (edge_distance(pts[i]) < 0.3) continue;
    const Eigen::Vector3d& n = truth[i];
    CHECK(n.dot(cov[i] * n) == Approx(1e-3).margin(1e-5));
    CHECK(cov[i].trace() == Approx(2.001));
    CHECK((cov[i] - cov[i].transpose()).norm() < 1e-12);
  }
}

TEST_CASE("normals and covariances of a cloud follow its order; degenerate spots",
          "[registration]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Eigen::Vector2d> line;
  for (int i = 0; i < 30; ++i)
    line.emplace_back(0.1 * i, 1.0);
  line.insert(line.begin() + 5, Eigen::Vector2d(nan, 0));
  const auto normals = estimate_normals(line, 5);
  REQUIRE(normals.size() == line.size());
  CHECK(normals[5].isZero(0));                         // the NaN point
  CHECK(normals[0].isApprox(Eigen::Vector2d(0, -1)));  // the line y = 1, towards the origin
  const auto cov = estimate_covariances(line, 5, 2, 0.01);
  CHECK(cov[5] == Eigen::Matrix2d::Identity());
  CHECK(cov[0].isApprox(Eigen::Vector2d(1, 0.01).asDiagonal().toDenseMatrix()));
  // All points at one spot: no surface (zero normal, identity covariance).
  const std::vector<Eigen::Vector2d> spot(8, Eigen::Vector2d(1, 1));
  CHECK(estimate_normals(spot, 4)[0].isZero(0));
  CHECK(estimate_covariances(spot, 4)[0] == Eigen::Matrix2d::Identity());
  CHECK_THROWS_WITH(estimate_normals(line, 2),
                    "rangenav: estimate_normals: argument 'k' = 2 must be >= dimension + 1");
  CHECK_THROWS_AS(estimate_covariances(line, 5, 0), invalid_argument);
  CHECK_THROWS_AS(estimate_covariances(line, 5, 1, 0.0), invalid_argument);
}

TEST_CASE("neighbor_lists: each point's k nearest and the reach beyond them", "[registration]") {
  // Against the exhaustive search: the lists are its k-NN answers (the point itself first), every
  // point outside list i is at least reach[i] from point i, and the thread count changes nothing.
  std::mt19937 rng(5);
  std::vector<Eigen::Vector3d> pts, truth;
  box(rng, pts, truth);
  const KdTree<3, double> tree(pts);
  const BruteForceSearch<3, double> brute(pts);
  const NeighborLists<double> lists = neighbor_lists(tree, 8), lists2 = neighbor_lists(tree, 8, 2);
  REQUIRE(lists.size() == pts.size());
  CHECK(lists.indices == lists2.indices);
  CHECK(lists.reach == lists2.reach);
  std::vector<Neighbor<double>> knn;
  for (std::size_t i = 0; i < pts.size(); i += 7) {
    brute.knn(pts[i], 8, knn);
    const auto list = lists.of(i);
    REQUIRE(list.size() == 8);
    CHECK(list[0] == i);
    for (std::size_t m = 0; m < 8; ++m)
      CHECK((pts[list[m]] - pts[i]).squaredNorm() == knn[m].distance_sq);
    CHECK(lists.reach[i] == Approx(std::sqrt(knn[7].distance_sq)));
    std::size_t nearer_outside = 0;
    for (std::size_t q = 0; q < pts.size(); ++q)
      if (std::find(list.begin(), list.end(), q) == list.end() &&
          (pts[q] - pts[i]).norm() < lists.reach[i])
        ++nearer_outside;
    CHECK(nearer_outside == 0);
  }
  // Fewer points than k: every list holds them all, nothing lies beyond.
  const std::vector<Eigen::Vector2d> three{{0, 0}, {1, 0}, {0, 1}};
  const NeighborLists<double> all = neighbor_lists(KdTree<2, double>(three), 5);
  CHECK(all.of(1).size() == 3);
  CHECK(std::isinf(all.reach[1]));
  CHECK_THROWS_AS(neighbor_lists(tree, 0), invalid_argument);
  CHECK_THROWS_AS(neighbor_lists(tree, 4, 0), invalid_argument);
  CHECK_THROWS_AS(estimate_covariances(KdTree<2, double>(three), lists), invalid_argument);
  // Normals and covariances from the lists are those from k.
  CHECK(estimate_normals(tree, lists) == estimate_normals(tree, 8));
  CHECK(estimate_covariances(tree, lists, 2) == estimate_covariances(tree, 8, 1));
}
