#pragma once
// The Gauss-Newton engine shared by the least-squares solvers (point-to-point with a prior,
// point-to-plane, GICP): the deterministic blocked reduction of the normal equations over the
// pairs, the step, and the loop. Conventions (tangent space, normal equations, prior) are those
// of transform_solver.hpp.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include "rangenav/core/parallel.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/registration/correspondence.hpp"
#include "rangenav/registration/transform_solver.hpp"

namespace rangenav::detail {

/// Pairs per block of the deterministic reduction. A constant: the sum must not depend on the
/// thread count.
inline constexpr std::size_t reduction_block = 256;

/// The first and second moments of a set of data points (data frame), for the metric in which
/// the step's and the information's eigenvalues are compared: a rotation is measured by the RMS
/// displacement it causes on the points. About an axis a through the centroid that is
/// sqrt(a^T G a) per radian with G = tr(C) I - C (3D; tr(C) in 2D), C the points' covariance
/// (G is their inertia tensor per point), so the rotations scaled by G^-1/2 and the translations
/// are both "metres of point motion": a long corridor's roll, with its short lever, is not
/// mistaken for a weak direction.
template <int D, class Scalar>
struct PointMoments {
  static constexpr int rot = pose_dof<D> - D;
  std::size_t count = 0;
  Point<D, Scalar> sum = Point<D, Scalar>::Zero();
  Eigen::Matrix<Scalar, D, D> outer = Eigen::Matrix<Scalar, D, D>::Zero();

  void add(const Point<D, Scalar>& p) {
    ++count;
    sum += p;
    outer.noalias() += p * p.transpose();
  }
  PointMoments& operator+=(const PointMoments& o) {
    count += o.count;
    sum += o.sum;
    outer += o.outer;
    return *this;
  }
  [[nodiscard]] Point<D, Scalar> centroid() const {
    return count > 0 ? Point<D, Scalar>(sum / static_cast<Scalar>(count))
                     : Point<D, Scalar>::Zero();
  }
  /// G^-1/2 (see the struct comment); nothing when the points do not spread (all at one spot).
  [[nodiscard]] std::optional<Eigen::Matrix<Scalar, rot, rot>> rotation_scale() const {
    if (count == 0) return std::nullopt;
    const Point<D, Scalar> c = centroid();
    const Eigen::Matrix<Scalar, D, D> cov = outer / static_cast<Scalar>(count) - c * c.transpose();
    const Scalar trace = cov.trace();
    if (!(trace > Scalar(0))) return std::nullopt;
    if constexpr (D == 2) {
      return Eigen::Matrix<Scalar, 1, 1>(Scalar(1) / std::sqrt(trace));
    } else {
      const Eigen::Matrix<Scalar, 3, 3> g = trace * Eigen::Matrix<Scalar, 3, 3>::Identity() - cov;
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix<Scalar, 3, 3>> eig;
      eig.computeDirect(g);
      // Points on a line through the centroid have no lever about it: floor that axis at a
      // millionth of the largest, so the scaling stays finite (the direction then reads as weak).
      const Point<3, Scalar> inv_sqrt =
          eig.eigenvalues().cwiseMax(Scalar(1e-12) * trace).cwiseSqrt().cwiseInverse();
      return Eigen::Matrix<Scalar, 3, 3>(eig.eigenvectors() * inv_sqrt.asDiagonal() *
                                         eig.eigenvectors().transpose());
    }
  }
};

/// Normal equations plus the moments of the contributing data points.
template <int D, class Scalar>
struct Linearization {
  NormalEquations<D, Scalar> equations;
  PointMoments<D, Scalar> points;

  Linearization& operator+=(const Linearization& o) {
    equations += o.equations;
    points += o.points;
    return *this;
  }
};

/// Sums `residual(pair, equations)` (which adds the pair's terms and returns whether it did) over
/// the pairs in fixed blocks, each in order, then the blocks in order; on up to num_threads
/// threads. `scratch` keeps one partial sum per block between calls.
template <int D, class Scalar, class Residual>
Linearization<D, Scalar> linearize_pairs(std::span<const Correspondence<D, Scalar>> pairs,
                                         int num_threads,
                                         std::vector<Linearization<D, Scalar>>& scratch,
                                         const Residual& residual) {
  scratch.assign(block_count(pairs.size(), reduction_block), Linearization<D, Scalar>{});
  for_each_block(pairs.size(), reduction_block, num_threads,
                 [&](std::size_t b, std::size_t begin, std::size_t end, int) {
                   // Summed locally and stored once: neighbouring blocks' sums share cache
                   // lines, and two threads adding into them would contend at every pair.
                   Linearization<D, Scalar> lin;
                   for (std::size_t i = begin; i < end; ++i)
                     if (residual(pairs[i], lin.equations)) lin.points.add(pairs[i].data);
                   scratch[b] = lin;
                 });
  Linearization<D, Scalar> total;
  for (const auto& lin : scratch)
    total += lin;
  return total;
}

/// M with d = M z: z are the centred, scaled coordinates in which a rotation turns about the
/// centroid c (data frame) and is scaled by W = G^-1/2 (PointMoments). A rotation w about c
/// moves the points as rho' + S(p - c) w, so rho = rho' - S(c) w, and w = W w~.
template <int D, class Scalar>
[[nodiscard]] PoseMatrix<D, Scalar> centred_coordinates(
    const Point<D, Scalar>& centroid,
    const Eigen::Matrix<Scalar, pose_dof<D> - D, pose_dof<D> - D>& scale) {
  constexpr int dof = pose_dof<D>;
  PoseMatrix<D, Scalar> m = PoseMatrix<D, Scalar>::Identity();
  m.template bottomRightCorner<dof - D, dof - D>() = scale;
  m.template topRightCorner<D, dof - D>() = -rotation_jacobian<Scalar>(centroid) * scale;
  return m;
}

/// The part of a symmetric positive semi-definite matrix h (over the tangent space) along the
/// directions that reach `ratio` of its strongest, in the centred coordinates z (d = M z) where
/// the ratio compares metres of point motion: sum over the kept eigenpairs of M^-T (l v v^T) M^-1.
/// Also gives those eigenpairs (in z) for a caller that solves with them.
template <int D, class Scalar>
struct ObservedPart {
  PoseMatrix<D, Scalar> m;                                   ///< d = M z
  Eigen::SelfAdjointEigenSolver<PoseMatrix<D, Scalar>> eig;  ///< of M^T h M
  int first_kept = pose_dof<D>;                              ///< eigenpairs [first_kept, dof)

  ObservedPart(const PoseMatrix<D, Scalar>& h, const Point<D, Scalar>& centroid,
               const Eigen::Matrix<Scalar, pose_dof<D> - D, pose_dof<D> - D>& scale, Scalar ratio)
      : m(centred_coordinates<D, Scalar>(centroid, scale)), eig(m.transpose() * h * m) {
    const auto& values = eig.eigenvalues();
    if (!(values(pose_dof<D> - 1) > Scalar(0))) return;
    first_kept = 0;
    while (first_kept < pose_dof<D> && !(values(first_kept) >= ratio * values(pose_dof<D> - 1)))
      ++first_kept;
  }

  /// The kept part of h, back in the tangent coordinates d.
  [[nodiscard]] PoseMatrix<D, Scalar> matrix() const {
    constexpr int dof = pose_dof<D>;
    PoseMatrix<D, Scalar> kept = PoseMatrix<D, Scalar>::Zero();
    for (int k = first_kept; k < dof; ++k)
      kept.noalias() +=
          eig.eigenvalues()(k) * eig.eigenvectors().col(k) * eig.eigenvectors().col(k).transpose();
    const PoseMatrix<D, Scalar> m_inv = m.inverse();
    return m_inv.transpose() * kept * m_inv;
  }
};

/// The observed part (ObservedPart with `ratio`) of h, a matrix over the tangent space such as
/// the normal equations' Hessian at the solution, with the rotations scaled by the moments of the
/// pairs' data points; nothing when those points do not spread.
template <int D, class Scalar>
[[nodiscard]] std::optional<PoseMatrix<D, Scalar>> observed_part(
    const PoseMatrix<D, Scalar>& h, std::span<const Correspondence<D, Scalar>> pairs,
    Scalar ratio) {
  PointMoments<D, Scalar> points;
  for (const auto& pr : pairs)
    points.add(pr.data);
  const auto scale = points.rotation_scale();
  if (!scale) return std::nullopt;
  return ObservedPart<D, Scalar>(h, points.centroid(), *scale, ratio).matrix();
}

/// The Gauss-Newton step d of the residuals' normal equations `eq` (unscaled), plus the prior's
/// term at t when there is one. The residuals count only along the directions they observe
/// (ObservedPart with `degeneracy_ratio`): a direction they leave free (the axis of a corridor)
/// keeps its start instead of following the noise of the normals (Zhang, Kaess & Singh, ICRA
/// 2016), or follows the prior. With a prior the residuals' terms are divided by their variance
/// (floored at 1 micrometre squared) so that both are in the prior's units. Nothing when the
/// system determines no step or the step is not finite.
template <int D, class Scalar>
[[nodiscard]] std::optional<PoseTangent<D, Scalar>> gauss_newton_step(
    const NormalEquations<D, Scalar>& eq, const PosePrior<D, Scalar>* prior,
    const Transform<D, Scalar>& t, const PointMoments<D, Scalar>& points, Scalar degeneracy_ratio) {
  constexpr int dof = pose_dof<D>;
  using Tangent = PoseTangent<D, Scalar>;
  using Matrix = PoseMatrix<D, Scalar>;
  using Scale = Eigen::Matrix<Scalar, dof - D, dof - D>;
  std::optional<Scale> scale = points.rotation_scale();
  if (!scale) {
    if (prior == nullptr) return std::nullopt;
    scale = Scale::Identity();  // no residual geometry: the prior alone
  }
  const ObservedPart<D, Scalar> observed(eq.hessian, points.centroid(), *scale, degeneracy_ratio);
  const Matrix& m = observed.m;
  const Tangent b = m.transpose() * eq.gradient;
  const auto& values = observed.eig.eigenvalues();
  const auto& vectors = observed.eig.eigenvectors();
  Tangent z = Tangent::Zero();
  if (prior == nullptr) {
    if (observed.first_kept == dof) return std::nullopt;
    for (int k = observed.first_kept; k < dof; ++k)
      z -= vectors.col(k) * (vectors.col(k).dot(b) / values(k));
  } else {
    const Scalar inv_variance = Scalar(1) / std::max(eq.residual_variance(), Scalar(1e-12));
    NormalEquations<D, Scalar> p;
    add_prior(p, *prior, t);
    Matrix h = m.transpose() * p.hessian * m;
    Tangent g = m.transpose() * p.gradient;
    for (int k = observed.first_kept; k < dof; ++k) {
      const Tangent v = vectors.col(k);
      h.noalias() += (inv_variance * values(k)) * v * v.transpose();
      g += (inv_variance * v.dot(b)) * v;
    }
    h.diagonal().array() += std::numeric_limits<Scalar>::epsilon() * h.trace();
    z = -h.ldlt().solve(g);
  }
  const Tangent d = m * z;
  if (!d.allFinite()) return std::nullopt;
  return d;
}

/// t [+] d with the rotation applied about the point c of the data frame: the same first-order
/// motion as retract(t, d) (p -> p + rho + S(p) w), but a point at c moves by exactly
/// rho + S(c) w, so the directions a truncated step leaves alone (centred coordinates) stay put
/// to every order, not just the first.
template <int D, class Scalar>
[[nodiscard]] Transform<D, Scalar> retract_about(const Transform<D, Scalar>& t,
                                                 const PoseTangent<D, Scalar>& d,
                                                 const Point<D, Scalar>& c) {
  PoseTangent<D, Scalar> rotation_only = PoseTangent<D, Scalar>::Zero();
  rotation_only.template tail<pose_dof<D> - D>() = d.template tail<pose_dof<D> - D>();
  const Transform<D, Scalar> turn = retract(Transform<D, Scalar>::Identity(), rotation_only);
  Transform<D, Scalar> delta = turn;
  delta.translation() = c + d.template head<D>() +
                        rotation_jacobian<Scalar>(c) * d.template tail<pose_dof<D> - D>() -
                        turn.linear() * c;
  return t * delta;
}

/// Gauss-Newton on sum_i rho(s_i) (+ the prior's term) from `start`, at most `steps` steps over
/// the same pairs, stopping when a step moves less than step_epsilon. `residual(pair, apply, rt,
/// equations)` adds one pair's terms at the transform whose point map is `apply` and whose
/// inverse rotation is `rt`, and returns whether it did. Nothing when fewer than dof pairs
/// contribute at the start or the first step is undetermined (e.g. all data points at one spot).
template <int D, class Scalar, class Residual>
[[nodiscard]] std::optional<Transform<D, Scalar>> gauss_newton(
    std::span<const Correspondence<D, Scalar>> pairs, Transform<D, Scalar> t,
    const SolveContext<D, Scalar>& ctx, int steps, Scalar step_epsilon, Scalar degeneracy_ratio,
    std::vector<Linearization<D, Scalar>>& scratch, const Residual& residual) {
  for (int step = 0; step < steps; ++step) {
    const AffineApply<D, Scalar> apply(t);
    const Eigen::Matrix<Scalar, D, D> rt = t.linear().transpose();
    Linearization<D, Scalar> lin = linearize_pairs<D, Scalar>(
        pairs, ctx.num_threads, scratch,
        [&](const Correspondence<D, Scalar>& pr, NormalEquations<D, Scalar>& eq) {
          return residual(pr, apply, rt, eq);
        });
    if (lin.equations.pairs < static_cast<std::size_t>(pose_dof<D>)) {
      if (step == 0) return std::nullopt;
      break;
    }
    const auto d =
        gauss_newton_step<D, Scalar>(lin.equations, ctx.prior, t, lin.points, degeneracy_ratio);
    if (!d) {
      if (step == 0) return std::nullopt;
      break;
    }
    t = retract_about(t, *d, lin.points.centroid());
    if (d->norm() < step_epsilon) break;
  }
  if (!t.matrix().allFinite()) return std::nullopt;
  return t;
}

/// The normal equations of a solver's objective at t (no prior), for its information.
template <int D, class Scalar, class Residual>
[[nodiscard]] NormalEquations<D, Scalar> linearize_at(
    std::span<const Correspondence<D, Scalar>> pairs, const Transform<D, Scalar>& t,
    int num_threads, std::vector<Linearization<D, Scalar>>& scratch, const Residual& residual) {
  const AffineApply<D, Scalar> apply(t);
  const Eigen::Matrix<Scalar, D, D> rt = t.linear().transpose();
  return linearize_pairs<D, Scalar>(
             pairs, num_threads, scratch,
             [&](const Correspondence<D, Scalar>& pr, NormalEquations<D, Scalar>& eq) {
               return residual(pr, apply, rt, eq);
             })
      .equations;
}

}  // namespace rangenav::detail
