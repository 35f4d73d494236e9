#pragma once
// Helpers shared by the pose-graph tests: random perturbations of poses and errors against truth.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <random>
#include <vector>

#include "rangenav/core/lie.hpp"
#include "rangenav/core/types.hpp"

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

}  // namespace rangenav::test
