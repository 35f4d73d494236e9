#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "pose_graph_support.hpp"
#include "rangenav/core/lie.hpp"
#include "rangenav/pose_graph/pose_graph.hpp"
#include "rangenav/sim/robot.hpp"
#include "rangenav/sim/world.hpp"

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
  for (std::size_t i = 0; i < truth.size(); ++i)
    graph.add_node(i == 0 ? truth[0] : perturbed<D>(truth[i], 0.2, 0.1, rng));
  for (std::size_t i = 0; i < truth.size(); ++i)
    graph.add_edge(i, (i + 1) % truth.size(), planar(side, 0, alpha), information);

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
  for (std::size_t i = 0; i < truth.size(); ++i)
    graph.add_node(i == 0 ? truth[0] : perturbed<2>(truth[i], 0.5, 0.3, rng));
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const std::size_t j = (i + 1) % truth.size();
    graph.add_edge(i, j, truth[i].inverse() * truth[j], PoseGraph2d::Information::Identity());
  }
  const auto result = graph.optimize();
  REQUIRE(result.converged());
  CHECK(result.chi2_final < 1e-16);
  CHECK(position_error<2>(graph.poses(), truth) < 1e-7);
}

namespace {

// Key poses every 0.5 m of a simulated differential-drive robot (sim/robot.hpp) that drives three
// laps of a 12 m x 6 m rounded rectangle, each lap shifted sideways a little.
std::vector<Transform2d> simulated_laps() {
  sim::World world;
  world.build_index();
  sim::DifferentialDriveRobot robot({}, {0, 0, 0});
  std::mt19937 rng(1);
  std::vector<Transform2d> key_poses{robot.pose().to_isometry()};
  double travelled = 0;
  const auto drive = [&](double v, double omega, double seconds) {
    const int steps = static_cast<int>(std::lround(seconds / robot.dt()));
    for (int k = 0; k < steps; ++k) {
      robot.step(world, v, omega, rng);
      travelled += std::abs(v) * robot.dt();
      if (travelled >= 0.5) {
        key_poses.push_back(robot.pose().to_isometry());
        travelled = 0;
      }
    }
  };
  for (int lap = 0; lap < 3; ++lap)
    for (int side = 0; side < 4; ++side) {
      drive(0.5, 0.0, (side % 2 == 0 ? 12.0 : 6.0) / 0.5 + lap * 0.2);
      drive(0.5, 0.5, pi);  // a quarter circle of radius 1 m
    }
  return key_poses;
}

// A helix of three turns (radius 6 m, 3 m per turn, a pose every 0.5 m) in 3D: the robot climbs a
// ramp in a parking garage; the heading follows the tangent and the body pitches with the slope.
std::vector<Transform3d> helix() {
  std::vector<Transform3d> poses;
  const double radius = 6, rise = 3, step = 0.5;
  const double pitch = std::atan2(rise, 2 * pi * radius);
  const int n = static_cast<int>(3 * 2 * pi * radius / std::cos(pitch) / step);
  for (int i = 0; i < n; ++i) {
    const double a = i * step * std::cos(pitch) / radius;
    Transform3d t = Transform3d::Identity();
    t.translation() = Point3d(radius * std::cos(a), radius * std::sin(a), rise * a / (2 * pi));
    t.linear() = (Eigen::AngleAxisd(a + pi / 2, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY()))
                     .toRotationMatrix();
    poses.push_back(t);
  }
  return poses;
}

// Edges and residual degrees of freedom: at the maximum-likelihood estimate of a correct linear
// Gaussian model, χ² follows a χ² distribution with (measurements − unknowns) degrees of freedom.
template <int D>
double degrees_of_freedom(const PoseGraph<D>& graph) {
  return double(lie::pose_dof<D>) * (double(graph.edge_count()) - double(graph.node_count() - 1));
}

template <int D>
void check_simulated(const std::vector<Transform<D>>& truth, double closure_radius) {
  std::mt19937 rng(17);
  auto s = test::simulate_graph<D>(truth, closure_radius, 20, rng);
  REQUIRE(s.loop_closures.size() > 20);
  const double rmse_before = test::position_rmse<D>(s.graph.poses(), truth);
  const auto result = s.graph.optimize();
  REQUIRE(result.converged());
  const double rmse_after = test::position_rmse<D>(s.graph.poses(), truth);
  INFO("RMSE " << rmse_before << " m -> " << rmse_after << " m, chi2 " << result.chi2_final);
  CHECK(rmse_after < rmse_before / 5);
  CHECK(rmse_after < 0.15);
  const double dof = degrees_of_freedom<D>(s.graph);
  CHECK(std::abs(result.chi2_final - dof) < 4 * std::sqrt(2 * dof));
  // The same from the rotation-first initialisation: the same minimum.
  auto again = test::simulate_graph<D>(truth, closure_radius, 20, rng);
  REQUIRE(again.graph.initialize());
  const auto result2 = again.graph.optimize();
  CHECK(test::position_rmse<D>(again.graph.poses(), truth) < 0.15);
  const double dof2 = degrees_of_freedom<D>(again.graph);
  CHECK(std::abs(result2.chi2_final - dof2) < 4 * std::sqrt(2 * dof2));
}

}  // namespace

TEST_CASE("pose graph: simulated laps with noise: the error shrinks, chi2 matches the noise",
          "[pose_graph][sim]") {
  check_simulated<2>(simulated_laps(), 1.0);
  check_simulated<3>(helix(), 3.5);
}

TEST_CASE("pose graph: a false loop closure is rejected by dynamic covariance scaling",
          "[pose_graph][robust]") {
  const auto truth = simulated_laps();
  // A place-recognition error: poses ~8 m apart declared to be the same place.
  std::size_t a = 5, b = 0;
  for (std::size_t j = 0; j < truth.size(); ++j)
    if (std::abs((truth[j].translation() - truth[a].translation()).norm() - 8.0) < 0.3) b = j;
  REQUIRE(b > a);
  const auto build = [&](const PoseGraph2d::Loss& loss) {
    std::mt19937 rng(23);
    auto s = test::simulate_graph<2>(truth, 1.0, 20, rng, loss);
    const std::size_t wrong = s.graph.add_edge(
        a, b, Transform2d::Identity(),
        information_from_covariance<2, double>(test::diagonal_covariance<2>(0.05, 0.01)), loss);
    return std::pair{std::move(s), wrong};
  };
  // Least squares bends the whole map to satisfy it.
  auto [plain, wrong_plain] = build(PoseGraph2d::Loss{});
  plain.graph.optimize();
  const double rmse_plain = test::position_rmse<2>(plain.graph.poses(), truth);
  // DCS on every loop closure (Φ = 1, Agarwal et al.'s default) lets it go.
  auto [robust, wrong] = build(DynamicCovarianceScaling<double>{1.0});
  const auto result = robust.graph.optimize();
  REQUIRE(result.converged());
  const double rmse_robust = test::position_rmse<2>(robust.graph.poses(), truth);
  INFO("RMSE plain " << rmse_plain << " m, with DCS " << rmse_robust << " m");
  CHECK(rmse_plain > 5 * rmse_robust);
  CHECK(rmse_robust < 0.15);
  CHECK(robust.graph.edge_weight(wrong) < 1e-3);
  // The true loop closures keep their weight: χ² of a true 3-DOF edge has median 2.37, where
  // DCS with Φ = 1 weighs it (2/3.37)² = 0.35.
  std::vector<double> weights;
  for (const std::size_t e : robust.loop_closures)
    weights.push_back(robust.graph.edge_weight(e));
  std::nth_element(weights.begin(), weights.begin() + weights.size() / 2, weights.end());
  CHECK(weights[weights.size() / 2] > 0.2);

  // The same from the rotation-first initialisation, which re-weights robust edges as well.
  auto [initialized, wrong_init] = build(DynamicCovarianceScaling<double>{1.0});
  REQUIRE(initialized.graph.initialize());
  initialized.graph.optimize();
  CHECK(test::position_rmse<2>(initialized.graph.poses(), truth) < 0.15);
  CHECK(initialized.graph.edge_weight(wrong_init) < 1e-3);

  // A Cauchy kernel with a scale of 3 standard deviations also rejects it.
  auto [cauchy, wrong_cauchy] = build(RobustKernel<double>::cauchy(3.0));
  cauchy.graph.optimize();
  CHECK(test::position_rmse<2>(cauchy.graph.poses(), truth) < 0.15);
  CHECK(cauchy.graph.edge_weight(wrong_cauchy) < 1e-3);
}

TEST_CASE("pose graph: incremental use re-optimises warm to the batch optimum",
          "[pose_graph][incremental]") {
  const auto truth = simulated_laps();
  std::mt19937 rng(31);
  auto batch = test::simulate_graph<2>(truth, 1.0, 20, rng);
  const PoseGraph2d reference_start = batch.graph;
  const auto batch_result = batch.graph.optimize();
  REQUIRE(batch_result.converged());

  // The same nodes and edges, added in three chunks (node by node, each edge once both of its
  // nodes exist), optimising after each chunk from the previous estimate.
  PoseGraph2d graph;
  std::size_t next_edge = 0;
  std::vector<std::size_t> order(reference_start.edge_count());
  for (std::size_t e = 0; e < order.size(); ++e)
    order[e] = e;
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    const auto& ex = reference_start.edge(x);
    const auto& ey = reference_start.edge(y);
    return std::max(ex.from, ex.to) < std::max(ey.from, ey.to);
  });
  PoseGraph2d::Result last;
  for (const std::size_t end : {truth.size() / 3, 2 * truth.size() / 3, truth.size()}) {
    for (std::size_t i = graph.node_count(); i < end; ++i)
      // A new node starts at its predecessor's estimate times the odometry.
      graph.add_node(
          i == 0 ? truth[0] : graph.pose(i - 1) * reference_start.edge(i - 1).measurement, i == 0);
    while (next_edge < order.size()) {
      const auto& e = reference_start.edge(order[next_edge]);
      if (std::max(e.from, e.to) >= end) break;
      graph.add_edge(e.from, e.to, e.measurement, e.information);
      ++next_edge;
    }
    last = graph.optimize();
    REQUIRE(last.converged());
  }
  CHECK(last.chi2_final == Approx(batch_result.chi2_final).epsilon(1e-7));
  CHECK(test::position_error<2>(graph.poses(), batch.graph.poses()) < 1e-5);
  // A warm restart of a converged graph has nothing left to do.
  const auto again = batch.graph.optimize();
  CHECK(again.iterations <= 2);
  CHECK(again.chi2_final <= batch_result.chi2_final * (1 + 1e-12));
}

TEST_CASE("pose graph: fixed nodes stay, and each unanchored part keeps its first node",
          "[pose_graph]") {
  const auto truth = simulated_laps();
  std::mt19937 rng(41);
  auto s = test::simulate_graph<2>(truth, 1.0, 20, rng);
  const std::size_t middle = truth.size() / 2;
  const Transform2d held = s.graph.pose(middle);  // the drifted odometry estimate
  s.graph.set_fixed(middle);
  CHECK(s.graph.is_fixed(middle));
  s.graph.optimize();
  CHECK(s.graph.pose(middle).isApprox(held, 1e-15));
  CHECK(s.graph.pose(0).isApprox(truth[0], 1e-15));

  // Two separate rings and no fixed node: the gauge holds the first node of each.
  PoseGraph2d graph;
  std::mt19937 noise(2);
  for (int ring = 0; ring < 2; ++ring) {
    const std::size_t first = graph.node_count();
    for (int i = 0; i < 6; ++i)
      graph.add_node(perturbed<2>(make_transform2(10.0 * ring + i, 0.0, 0.0), 0.1, 0.05, noise));
    for (std::size_t i = 0; i < 6; ++i)
      graph.add_edge(first + i, first + (i + 1) % 6,
                     i < 5 ? make_transform2(1.0, 0.0, 0.0) : make_transform2(-5.0, 0.0, 0.0),
                     PoseGraph2d::Information::Identity());
  }
  const Transform2d first0 = graph.pose(0), first6 = graph.pose(6);
  const auto result = graph.optimize();
  REQUIRE(result.converged());
  CHECK(result.chi2_final < 1e-12);
  CHECK(graph.pose(0).isApprox(first0, 1e-15));
  CHECK(graph.pose(6).isApprox(first6, 1e-15));
  CHECK((first0.inverse() * graph.pose(3)).translation().isApprox(Point2d(3, 0), 1e-6));
}

TEST_CASE("pose graph: bad input is rejected at the boundary", "[pose_graph][errors]") {
  PoseGraph3d graph;
  const auto a = graph.add_node(Transform3d::Identity());
  const auto b = graph.add_node(Transform3d::Identity());
  const PoseGraph3d::Information info = PoseGraph3d::Information::Identity();
  CHECK_THROWS_AS(graph.add_edge(a, 7, Transform3d::Identity(), info), invalid_argument);
  CHECK_THROWS_AS(graph.add_edge(a, a, Transform3d::Identity(), info), invalid_argument);
  Transform3d sheared = Transform3d::Identity();
  sheared.matrix()(0, 1) = 0.5;
  CHECK_THROWS_AS(graph.add_edge(a, b, sheared, info), invalid_argument);
  Transform3d nan = Transform3d::Identity();
  nan.translation().x() = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(graph.add_node(nan), invalid_argument);
  PoseGraph3d::Information asymmetric = info;
  asymmetric(0, 1) = 0.3;
  CHECK_THROWS_AS(graph.add_edge(a, b, Transform3d::Identity(), asymmetric), invalid_argument);
  PoseGraph3d::Information indefinite = info;
  indefinite(2, 2) = -1;
  CHECK_THROWS_AS(graph.add_edge(a, b, Transform3d::Identity(), indefinite), invalid_argument);
  CHECK_THROWS_AS(
      graph.add_edge(a, b, Transform3d::Identity(), info, DynamicCovarianceScaling<double>{0.0}),
      invalid_argument);
  CHECK_THROWS_AS(
      graph.add_edge(a, b, Transform3d::Identity(), info, RobustKernel<double>::huber(-1.0)),
      invalid_argument);
  CHECK(graph.edge_count() == 0);
  // A semidefinite information (a measurement that says nothing about z) is accepted.
  PoseGraph3d::Information planar = info;
  planar(2, 2) = 0;
  CHECK_NOTHROW(graph.add_edge(a, b, Transform3d::Identity(), planar));
  CHECK_THROWS_AS(graph.pose(2), invalid_argument);
  PoseGraphOptions<double> options;
  options.max_iterations = -1;
  CHECK_THROWS_AS(graph.optimize(options), invalid_argument);
  options = {};
  options.initial_lambda = 0;
  CHECK_THROWS_AS(graph.optimize(options), invalid_argument);
  if constexpr (!have_cholmod) {
    options = {};
    options.backend = SparseBackend::cholmod;
    CHECK_THROWS_AS(graph.optimize(options), invalid_argument);
  }
  // Nothing to optimise: no free node.
  PoseGraph2d single;
  single.add_node(Transform2d::Identity());
  CHECK(single.optimize().termination == PoseGraphTermination::nothing_to_optimize);
}
