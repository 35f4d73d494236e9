#pragma once
// Helpers shared by the pose-graph tests: random perturbations of poses and errors against truth.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <random>
#include <vector>

#include <Eigen/Cholesky>

#include "rangenav/core/lie.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/pose_graph/pose_graph.hpp"
#include "rangenav/pose_graph/relative_pose_error.hpp"

namespace rangenav::test {

/// A random tangent vector with independent normal entries: `sigma_t` for translation, `sigma_r`
/// for rotation.
template <int D, class Engine>
lie::PoseTangent<D> random_tangent(double sigma_t, double sigma_r, Engine& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  lie::PoseTangent<D> xi;
  for (int k = 0; k < lie::pose_dof<D>; ++k)
    xi(k) = normal(rng) * (k < D ? sigma_t : sigma_r);
  return xi;
}

/// pose·Exp(ξ) with a random ξ (random_tangent).
template <int D, class Engine>
Transform<D> perturbed(const Transform<D>& pose, double sigma_t, double sigma_r, Engine& rng) {
  return pose * lie::se_exp<D>(random_tangent<D>(sigma_t, sigma_r, rng));
}

/// The largest distance between corresponding positions.
template <int D>
double position_error(const std::vector<Transform<D>>& a, const std::vector<Transform<D>>& b) {
  double worst = 0;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    worst = std::max(worst, (a[i].translation() - b[i].translation()).norm());
  return worst;
}

/// Root mean square of the distances between corresponding positions.
template <int D>
double position_rmse(const std::vector<Transform<D>>& a, const std::vector<Transform<D>>& b) {
  double sum = 0;
  const std::size_t n = std::min(a.size(), b.size());
  for (std::size_t i = 0; i < n; ++i)
    sum += (a[i].translation() - b[i].translation()).squaredNorm();
  return std::sqrt(sum / double(n));
}

/// A pose graph built from true poses: every edge measures the true relative pose times a
/// random error drawn from the edge's covariance (over translation and rotation vector), and its
/// information is that covariance's (information_from_covariance), so the graph is a correct
/// statistical model of its measurements.
template <int D>
struct SimulatedGraph {
  std::vector<Transform<D>> truth;
  PoseGraph<D> graph;
  std::vector<std::size_t> loop_closures;  ///< edge ids
  std::size_t odometry_edges{0};

  /// Adds an edge from a to b measuring the true relative pose with an error drawn from
  /// `covariance`; returns its id.
  template <class Engine>
  std::size_t add_edge(std::size_t a, std::size_t b, const lie::PoseMatrix<D>& covariance,
                       Engine& rng, const typename PoseGraph<D>::Loss& loss = {}) {
    const Eigen::LLT<lie::PoseMatrix<D>> llt(covariance);
    std::normal_distribution<double> normal(0.0, 1.0);
    lie::PoseTangent<D> w;
    for (int k = 0; k < lie::pose_dof<D>; ++k)
      w(k) = normal(rng);
    const Transform<D> z =
        truth[a].inverse() * truth[b] * lie::se_exp<D>(lie::PoseTangent<D>(llt.matrixL() * w));
    return graph.add_edge(a, b, z, information_from_covariance<D, double>(covariance), loss);
  }
};

/// A diagonal covariance over (translation, rotation vector).
template <int D>
lie::PoseMatrix<D> diagonal_covariance(double sigma_t, double sigma_r) {
  lie::PoseTangent<D> d;
  for (int k = 0; k < lie::pose_dof<D>; ++k)
    d(k) = k < D ? sigma_t * sigma_t : sigma_r * sigma_r;
  return d.asDiagonal();
}

/// Builds a SimulatedGraph over `truth`: odometry edges between consecutive poses, loop closures
/// between poses at least `min_gap` apart in sequence whose positions are within `radius`; the
/// nodes start at the chained odometry (node 0 fixed at the truth).
template <int D, class Engine>
SimulatedGraph<D> simulate_graph(const std::vector<Transform<D>>& truth, double radius,
                                 std::size_t min_gap, Engine& rng,
                                 const typename PoseGraph<D>::Loss& closure_loss = {}) {
  SimulatedGraph<D> s;
  s.truth = truth;
  const auto odometry = diagonal_covariance<D>(0.02, 0.005);
  const auto closure = diagonal_covariance<D>(0.05, 0.01);
  s.graph.add_node(truth[0], true);
  for (std::size_t i = 1; i < truth.size(); ++i)
    s.graph.add_node(truth[i]);
  for (std::size_t i = 1; i < truth.size(); ++i)
    s.add_edge(i - 1, i, odometry, rng);
  s.odometry_edges = truth.size() - 1;
  for (std::size_t i = 0; i < truth.size(); ++i)
    for (std::size_t j = i + min_gap; j < truth.size(); ++j)
      if ((truth[i].translation() - truth[j].translation()).norm() < radius)
        s.loop_closures.push_back(s.add_edge(i, j, closure, rng, closure_loss));
  // Start from the odometry chained from the first pose.
  for (std::size_t i = 1; i < truth.size(); ++i)
    s.graph.set_pose(i, s.graph.pose(i - 1) * s.graph.edge(i - 1).measurement);
  return s;
}

}  // namespace rangenav::test
