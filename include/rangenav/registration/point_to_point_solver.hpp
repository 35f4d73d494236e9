#pragma once
// Point-to-point solver: the rigid transform T minimising
//   E(R, t) = sum_i w_i |m_i - (R d_i + t)|^2      (Eq. (1) of paper 000)
// over a set of pairs, in closed form in 2D (the atan2 form, Eq. (5)-(6) of paper 003) and 3D (SVD
// of the cross-covariance, Arun / Umeyama, with the reflection case corrected). The weights w_i
// are 1, or the IRLS weights rho'(|m_i - T d_i|^2) of a robust kernel at the current transform
// (one re-weighting per ICP iteration). With a pose prior the objective is no longer closed-form:
// Gauss-Newton steps on E plus the prior's term start from the closed-form solution.
//
// The protocol (TransformSolver) is in transform_solver.hpp. The closed form returns nullopt when
// the pairs do not determine a transform (too few, all data points identical, collinear in 3D).

#include <Eigen/Core>
#include <Eigen/SVD>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <optional>
#include <span>
#include <tuple>
#include <vector>

#include "rangenav/core/parallel.hpp"
#include "rangenav/core/robust_kernel.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/registration/correspondence.hpp"
#include "rangenav/registration/gauss_newton.hpp"
#include "rangenav/registration/transform_solver.hpp"

namespace rangenav {

namespace detail {

/// The closed-form weighted point-to-point solution (see the file comment); `weight(i)` gives
/// w_i >= 0, or `unit_weights` for all ones (then no multiplication at all).
struct UnitWeights {};
inline constexpr UnitWeights unit_weights{};

/// Pairs per block of the sums below (on several threads, blocks are summed in order): a 2D
/// scan's pairs (a few hundred) are one block, summed exactly as serially.
inline constexpr std::size_t closed_form_block = 1024;

/// Sums over the pairs of the closed form, blocked (sum_blocks) over up to num_threads threads.
template <class T, class Scalar, int D, class F>
[[nodiscard]] T sum_pairs(std::span<const Correspondence<D, Scalar>> pairs, int num_threads,
                          F&& f) {
  return sum_blocks<T>(pairs.size(), closed_form_block, num_threads,
                       [&](std::size_t begin, std::size_t end) {
                         T sum = T::Zero();
                         for (std::size_t i = begin; i < end; ++i)
                           f(i, sum);
                         return sum;
                       });
}

/// Weighted centroids of the model and data points and the weight sum n (the pair count for
/// unit weights); nullopt when n is not positive.
template <int D, class Scalar, class Weight>
[[nodiscard]] std::optional<std::tuple<Point<D, Scalar>, Point<D, Scalar>, Scalar>>
weighted_centroids(std::span<const Correspondence<D, Scalar>> pairs, const Weight& weight,
                   int num_threads) {
  constexpr bool unit = std::is_same_v<Weight, UnitWeights>;
  // [c_m sum, c_d sum, n]
  using Sums = Eigen::Matrix<Scalar, 2 * D + 1, 1>;
  const Sums sums = sum_pairs<Sums>(pairs, num_threads, [&](std::size_t i, Sums& s) {
    if constexpr (unit) {
      s.template head<D>() += pairs[i].model;
      s.template segment<D>(D) += pairs[i].data;
    } else {
      const Scalar w = weight(i);
      s.template head<D>() += w * pairs[i].model;
      s.template segment<D>(D) += w * pairs[i].data;
      s[2 * D] += w;
    }
  });
  const Scalar n = unit ? static_cast<Scalar>(pairs.size()) : sums[2 * D];
  if (!(n > Scalar(0))) return std::nullopt;
  return std::tuple{Point<D, Scalar>(sums.template head<D>() / n),
                    Point<D, Scalar>(sums.template segment<D>(D) / n), n};
}

template <class Scalar, class Weight>
[[nodiscard]] std::optional<Transform<2, Scalar>> point_to_point_closed_form(
    std::span<const Correspondence<2, Scalar>> pairs, const Weight& weight, int num_threads) {
  constexpr bool unit = std::is_same_v<Weight, UnitWeights>;
  const auto centroids = weighted_centroids<2, Scalar>(pairs, weight, num_threads);
  if (!centroids) return std::nullopt;
  // Named copies: clang 14 does not let a lambda capture a structured binding.
  const Point<2, Scalar> cm = std::get<0>(*centroids), cd = std::get<1>(*centroids);
  const Scalar n = std::get<2>(*centroids);
  // [sin sum, cos sum, spread^2]
  using Sums = Eigen::Matrix<Scalar, 3, 1>;
  const Sums sums = sum_pairs<Sums>(pairs, num_threads, [&](std::size_t i, Sums& s) {
    const Point<2, Scalar> m = pairs[i].model - cm, d = pairs[i].data - cd;
    if constexpr (unit) {
      s[0] += m.y() * d.x() - m.x() * d.y();
      s[1] += m.x() * d.x() + m.y() * d.y();
      s[2] += d.squaredNorm();
    } else {
      const Scalar w = weight(i);
      s[0] += w * (m.y() * d.x() - m.x() * d.y());
      s[1] += w * (m.x() * d.x() + m.y() * d.y());
      s[2] += w * d.squaredNorm();
    }
  });
  const Scalar sin_sum = sums[0], cos_sum = sums[1], spread_sq = sums[2];
  // All data points identical: the rotation is undetermined.
  if (!(spread_sq > n * std::numeric_limits<Scalar>::epsilon() * (Scalar(1) + cd.squaredNorm())))
    return std::nullopt;
  const Scalar theta = std::atan2(sin_sum, cos_sum);
  Transform<2, Scalar> t = Transform<2, Scalar>::Identity();
  t.linear() = Eigen::Rotation2D<Scalar>(theta).toRotationMatrix();
  t.translation() = cm - t.linear() * cd;
  if (!t.matrix().allFinite()) return std::nullopt;
  return t;
}

/// 3D: R = V diag(1, 1, det(V U^T)) U^T from the SVD H = U S V^T of the cross-covariance
/// H = sum w d' m'^T (the diagonal term corrects a reflection); t = c_m - R c_d.
template <class Scalar, class Weight>
[[nodiscard]] std::optional<Transform<3, Scalar>> point_to_point_closed_form(
    std::span<const Correspondence<3, Scalar>> pairs, const Weight& weight, int num_threads) {
  constexpr bool unit = std::is_same_v<Weight, UnitWeights>;
  const auto centroids = weighted_centroids<3, Scalar>(pairs, weight, num_threads);
  if (!centroids) return std::nullopt;
  // Named copies: clang 14 does not let a lambda capture a structured binding.
  const Point<3, Scalar> cm = std::get<0>(*centroids), cd = std::get<1>(*centroids);
  const Scalar n = std::get<2>(*centroids);
  // [H | data covariance]
  using Sums = Eigen::Matrix<Scalar, 3, 6>;
  const Sums sums = sum_pairs<Sums>(pairs, num_threads, [&](std::size_t i, Sums& s) {
    const Point<3, Scalar> d = pairs[i].data - cd;
    if constexpr (unit) {
      s.template leftCols<3>().noalias() += d * (pairs[i].model - cm).transpose();
      s.template rightCols<3>().noalias() += d * d.transpose();
    } else {
      const Point<3, Scalar> wd = weight(i) * d;
      s.template leftCols<3>().noalias() += wd * (pairs[i].model - cm).transpose();
      s.template rightCols<3>().noalias() += wd * d.transpose();
    }
  });
  const Eigen::Matrix<Scalar, 3, 3> h = sums.template leftCols<3>();
  const Eigen::Matrix<Scalar, 3, 3> data_cov = sums.template rightCols<3>();
  // Identical or collinear data points leave a rotation undetermined (second singular value
  // of the data spread ~ 0).
  const Eigen::JacobiSVD<Eigen::Matrix<Scalar, 3, 3>> spread(data_cov);
  const auto sv = spread.singularValues();
  const Scalar tiny = Scalar(64) * std::numeric_limits<Scalar>::epsilon();
  if (!(sv(0) > tiny * n * (Scalar(1) + cd.squaredNorm())) || !(sv(1) > tiny * sv(0)))
    return std::nullopt;
  const Eigen::JacobiSVD<Eigen::Matrix<Scalar, 3, 3>> svd(
      h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix<Scalar, 3, 3> u = svd.matrixU(), v = svd.matrixV();
  Eigen::Matrix<Scalar, 3, 1> diag(1, 1, (v * u.transpose()).determinant() < 0 ? -1 : 1);
  Transform<3, Scalar> t = Transform<3, Scalar>::Identity();
  t.linear() = v * diag.asDiagonal() * u.transpose();
  t.translation() = cm - t.linear() * cd;
  if (!t.matrix().allFinite()) return std::nullopt;
  return t;
}

}  // namespace detail

/// Point-to-point solver in D = 2 or 3 dimensions (see the file comment). Models TransformSolver.
template <int D, std::floating_point Scalar = double>
struct PointToPointSolver {
  static_assert(D == 2 || D == 3, "PointToPointSolver: dimension must be 2 or 3");
  static constexpr std::size_t min_pairs = D == 2 ? 2 : 3;  ///< fewer do not determine one

  /// Robust kernel on the squared pair distance |m - T d|^2 (m^2): its delta is a distance.
  RobustKernel<Scalar> kernel{};
  /// Gauss-Newton steps after the closed form when a prior is given.
  int gauss_newton_steps = 3;
  /// Steps stop when the update moves less than this (m, and rad).
  Scalar step_epsilon = Scalar(1e-7);

  /// The closed-form solution of the (unit-weight) pairs.
  [[nodiscard]] std::optional<Transform<D, Scalar>> solve(
      std::span<const Correspondence<D, Scalar>> pairs) const {
    if (pairs.size() < min_pairs) return std::nullopt;
    return detail::point_to_point_closed_form<Scalar>(pairs, detail::unit_weights, 1);
  }

  /// The next transform of an ICP iteration (see the file comment).
  [[nodiscard]] std::optional<Transform<D, Scalar>> solve(
      std::span<const Correspondence<D, Scalar>> pairs, const SolveContext<D, Scalar>& ctx) const {
    if (pairs.size() < min_pairs) return std::nullopt;
    std::optional<Transform<D, Scalar>> t;
    if (kernel.type == RobustKernelType::none) {
      t = detail::point_to_point_closed_form<Scalar>(pairs, detail::unit_weights, ctx.num_threads);
    } else {
      const detail::AffineApply<D, Scalar> apply(ctx.current);
      t = detail::point_to_point_closed_form<Scalar>(
          pairs,
          [&](std::size_t i) {
            return kernel.weight((pairs[i].model - apply(pairs[i].data)).squaredNorm());
          },
          ctx.num_threads);
    }
    if (!t || ctx.prior == nullptr) return t;
    return detail::gauss_newton<D, Scalar>(pairs, *t, ctx, gauss_newton_steps, step_epsilon,
                                           Scalar(0), scratch_, Residual{this})
        .value_or(*t);
  }

  /// The normal equations of sum_i rho(|T d_i - m_i|^2) at t.
  [[nodiscard]] NormalEquations<D, Scalar> linearize(
      std::span<const Correspondence<D, Scalar>> pairs, const Transform<D, Scalar>& t,
      int num_threads) const {
    return detail::linearize_at<D, Scalar>(pairs, t, num_threads, scratch_, Residual{this});
  }

 private:
  // r = R^T (T d - m) in the data frame, Jacobian A(d) = [I | S(d)].
  struct Residual {
    const PointToPointSolver* solver;
    template <class Apply>
    bool operator()(const Correspondence<D, Scalar>& pr, const Apply& apply,
                    const Eigen::Matrix<Scalar, D, D>& rt, NormalEquations<D, Scalar>& eq) const {
      const Point<D, Scalar> r = rt * (apply(pr.data) - pr.model);
      detail::add_point_residual<D, Scalar>(
          eq, solver->kernel, detail::rotation_jacobian<Scalar>(pr.data), r,
          Eigen::Matrix<Scalar, D, D>::Identity(), static_cast<std::size_t>(D));
      return true;
    }
  };

  mutable std::vector<detail::Linearization<D, Scalar>> scratch_;
};

}  // namespace rangenav
