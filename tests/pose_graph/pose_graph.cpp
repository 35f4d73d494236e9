#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "pose_graph_support.hpp"
#include "rangenav/core/lie.hpp"
#include "rangenav/pose_graph/pose_graph.hpp"

using namespace rangenav;
using rangenav::test::perturbed;
using rangenav::test::position_error;

namespace {

const double pi = std::numbers::pi;

// A loop of n poses where every edge measures "forward by L, turn by α" with nα ≠ 2π. The turns
// must add up to 2π around the loop, so the angular misclosure 2π − nα is spread evenly: every
// edge keeps its translation exactly and turns by 2π/n instead of α, the poses form a regular
// n-gon of side L, and χ² = ω_θ·(2π − nα)²/n. In 3D the same loop lies in the plane z = 0.
template <int D>
void check_polygon_ring() {
  using Graph = PoseGraph<D>;
  using Pose = typename Graph::Pose;
  const int n = 9;
  const double side = 2.0, alpha = 2 * pi / n + 0.03, omega_t = 10.0, omega_r = 50.0;
  const auto planar = [](double x, double y, double theta) {
    Pose p = Pose::Identity();
    p.translation().template head<2>() = Point2d(x, y);
    p.linear().template topLeftCorner<2, 2>() = Eigen::Rotation2Dd(theta).toRotationMatrix();
    return p;
  };
  typename Graph::Information information = omega_t * Graph::Information::Identity();
  information.template bottomRightCorner<lie::rotation_dof<D>, lie::rotation_dof<D>>() *=
      omega_r / omega_t;
  if constexpr (D == 3) information.template bottomRightCorner<3, 3>() /= 4;  // e_q ≈ φ/2
  std::vector<Pose> truth{Pose::Identity()};
  for (int i = 1; i < n; ++i)
    truth.push_back(truth.back() * planar(side, 0, 2 * pi / n));
  Graph graph;
  std::mt19937 rng(7);
  for (int i = 0; i < n; ++i)
    graph.add_node(i == 0 ? truth[0] : perturbed<D>(truth[i], 0.2, 0.1, rng));
  for (int i = 0; i < n; ++i)
    graph.add_edge(i, (i + 1) % n, planar(side, 0, alpha), information);

  const auto result = graph.optimize();
  REQUIRE(result.converged());
  const double misclosure = 2 * pi - n * alpha;
  // g2o's rotation error: the angle in 2D, the quaternion's sin(angle/2) in 3D, whose
  // information is ω_r/4 there.
  const double e = D == 2 ? misclosure / n : std::sin(misclosure / n / 2);
  const double omega_e = D == 2 ? omega_r : omega_r / 4;
  CHECK(result.chi2_final == Approx(n * omega_e * e * e).epsilon(1e-9));
  CHECK(position_error<D>(graph.poses(), truth) < 1e-6);
}

}  // namespace

TEST_CASE("pose graph: a ring whose turns do not add up to 2 pi has the closed-form solution",
          "[pose_graph]") {
  check_polygon_ring<2>();
  check_polygon_ring<3>();
}

TEST_CASE("pose graph: consistent measurements around a circle recover the true poses",
          "[pose_graph]") {
  // Poses on a circle of radius 5 facing along it; measurements are the true relative poses, so
  // the optimum is the truth (χ² = 0) whatever the (perturbed) start.
  const int n = 24;
  std::vector<Transform2d> truth;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * pi * i / n;
    truth.push_back(make_transform2(5 * std::cos(a), 5 * std::sin(a), a + pi / 2));
  }
  PoseGraph2d graph;
  std::mt19937 rng(3);
  for (int i = 0; i < n; ++i)
    graph.add_node(i == 0 ? truth[0] : perturbed<2>(truth[i], 0.5, 0.3, rng));
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    graph.add_edge(i, j, truth[i].inverse() * truth[j], PoseGraph2d::Information::Identity());
  }
  const auto result = graph.optimize();
  REQUIRE(result.converged());
  CHECK(result.chi2_final < 1e-16);
  CHECK(position_error<2>(graph.poses(), truth) < 1e-7);
}
