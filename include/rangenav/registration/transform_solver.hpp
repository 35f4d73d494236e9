#pragma once
// The solver stage of ICP: the TransformSolver protocol and what every least-squares solver shares
// (the tangent space of a pose, the normal equations, the Gaussian pose prior, the robust weights,
// the deterministic blocked reduction and the Gauss-Newton step).
//
// Tangent space. A pose T (data -> model) is perturbed on the right, in the data frame:
//   T [+] d = T * Delta(d),   Delta(d) = [Exp(w) | rho],   d = (rho, w)
// with rho a translation (2 or 3 values) and w the rotation (the angle in 2D, the rotation vector
// in 3D): translation first, 3 values in 2D (x, y, theta), 6 in 3D (x, y, z, wx, wy, wz). It is
// g2o's edge convention (the error of a relative-pose edge is Z^-1 * T), so an ICP information
// matrix is a pose-graph edge information as it stands (in 3D g2o's rotation part is the
// quaternion's vector part, about half of w: see the pose graph's conversion helper).
//
// A point p of the data moves to T (Delta(d) p) ~ T p + R (rho + S(p) w), S(p) = -[p]x in 3D and
// (-p_y, p_x)^T in 2D, so every residual's Jacobian is built from A(p) = [I | S(p)] (D x dof).
//
// Solver protocol (the TransformSolver concept):
//   S::min_pairs                          pairs below which solve() answers nullopt;
//   s.solve(pairs, ctx)                   the next transform from the kept pairs of one ICP
//                                         iteration, starting at ctx.current, with ctx.prior's
//                                         term added when given; nullopt when the pairs do not
//                                         determine a transform;
//   s.linearize(pairs, t, num_threads)    the normal equations of the solver's objective at t
//                                         (for the information matrix of the result).
// Solvers that read per-point model attributes say so through ModelNormalSolver /
// CovarianceSolver below, so a driver (a mapper, align()) knows what to hand them.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/parallel.hpp"
#include "rangenav/core/robust_kernel.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/registration/correspondence.hpp"

namespace rangenav {

/// Degrees of freedom of a rigid motion in D dimensions: 3 in 2D, 6 in 3D.
template <int D>
inline constexpr int pose_dof = D == 2 ? 3 : 6;

/// The default fraction of the strongest direction below which a direction of the normal
/// equations counts as unobserved (rotations scaled by the points' RMS lever arm, so the ratio is
/// unit-free): there the errors of the normals, not the residual noise, set what the equations
/// say (a corridor's axis, the in-plane motions over a lone floor). Solvers leave such directions
/// to the prior or to the start; ICP reports no information along them.
inline constexpr double default_degeneracy_ratio = 0.01;

/// A tangent vector d = (rho, w) of a D-dimensional pose (see the file comment).
template <int D, class Scalar = double>
using PoseTangent = Eigen::Matrix<Scalar, pose_dof<D>, 1>;

/// A dof x dof matrix over the tangent space (an information or a covariance).
template <int D, class Scalar = double>
using PoseMatrix = Eigen::Matrix<Scalar, pose_dof<D>, pose_dof<D>>;

/// T [+] d = T * Delta(d): the pose moved by the tangent vector d in its own (data) frame.
template <int D, class Scalar>
[[nodiscard]] Transform<D, Scalar> retract(const Transform<D, Scalar>& t,
                                           const PoseTangent<D, Scalar>& d) {
  Transform<D, Scalar> delta = Transform<D, Scalar>::Identity();
  delta.translation() = d.template head<D>();
  if constexpr (D == 2) {
    delta.linear() = Eigen::Rotation2D<Scalar>(d(2)).toRotationMatrix();
  } else {
    const Point<3, Scalar> w = d.template tail<3>();
    const Scalar angle = w.norm();
    if (angle > Scalar(0))
      delta.linear() = Eigen::AngleAxis<Scalar>(angle, w / angle).toRotationMatrix();
  }
  return t * delta;
}

/// The tangent vector d with b = a [+] d (a, b rigid): rho = R_a^T (t_b - t_a), w = Log(R_a^T R_b).
template <int D, class Scalar>
[[nodiscard]] PoseTangent<D, Scalar> local_coordinates(const Transform<D, Scalar>& a,
                                                       const Transform<D, Scalar>& b) {
  PoseTangent<D, Scalar> d;
  d.template head<D>() = a.linear().transpose() * (b.translation() - a.translation());
  const Eigen::Matrix<Scalar, D, D> r = a.linear().transpose() * b.linear();
  if constexpr (D == 2) {
    d(2) = std::atan2(r(1, 0), r(0, 0));
  } else {
    const Eigen::AngleAxis<Scalar> aa(r);
    d.template tail<3>() = aa.axis() * aa.angle();
  }
  return d;
}

/// A Gaussian prior on the transform: T = mean [+] d with d ~ N(0, information^-1), in the tangent
/// space of the file comment (e.g. the odometry increment and its noise). ICP adds the term
/// e^T information e, e = local_coordinates(mean, T), to its normal equations every iteration,
/// the residuals' terms divided by their current variance (the MAP estimate under Gaussian
/// residuals of that variance), so the prior carries the directions the geometry leaves free
/// (the axis of a corridor) and yields to the data where they are constrained.
template <int D, class Scalar = double>
struct PosePrior {
  Transform<D, Scalar> mean = Transform<D, Scalar>::Identity();  ///< the expected transform
  /// Symmetric positive semi-definite; zero rows leave a direction to the data alone.
  PoseMatrix<D, Scalar> information = PoseMatrix<D, Scalar>::Zero();

  /// A prior from a covariance (symmetric positive definite) instead of an information.
  [[nodiscard]] static PosePrior from_covariance(const Transform<D, Scalar>& mean,
                                                 const PoseMatrix<D, Scalar>& covariance) {
    return {mean, covariance.inverse()};
  }

  /// Throws invalid_argument unless the mean is rigid and the information finite and symmetric
  /// with non-negative eigenvalues.
  void validate(std::string_view where = "PosePrior") const {
    if (!is_rigid(mean, rigid_tolerance<Scalar>))
      detail::throw_invalid(where, "argument 'prior.mean' is not a rigid transform");
    if (!information.allFinite())
      detail::throw_invalid(where, "argument 'prior.information' is not finite");
    const Scalar scale = information.cwiseAbs().maxCoeff();
    if (!information.isApprox(information.transpose(),
                              Scalar(64) * std::numeric_limits<Scalar>::epsilon()) &&
        !(information - information.transpose()).isZero(scale * Scalar(1e-9)))
      detail::throw_invalid(where, "argument 'prior.information' is not symmetric");
    const Eigen::SelfAdjointEigenSolver<PoseMatrix<D, Scalar>> eig(information,
                                                                   Eigen::EigenvaluesOnly);
    if (eig.eigenvalues()(0) < -Scalar(1e-9) * scale)
      detail::throw_invalid_argument(where, "prior.information's smallest eigenvalue",
                                     eig.eigenvalues()(0), "must be >= 0");
  }
};

/// The normal equations of a least-squares objective sum_i rho(s_i), s_i = r_i^T W_i r_i, at a
/// pose, in the tangent space of the file comment: hessian = sum w_i J_i^T W_i J_i and gradient =
/// sum w_i J_i^T W_i r_i with the IRLS weights w_i = rho'(s_i) of the robust kernel.
template <int D, class Scalar = double>
struct NormalEquations {
  static constexpr int dof = pose_dof<D>;                            ///< 3 in 2D, 6 in 3D
  PoseMatrix<D, Scalar> hessian = PoseMatrix<D, Scalar>::Zero();     ///< sum w_i J_i^T W_i J_i
  PoseTangent<D, Scalar> gradient = PoseTangent<D, Scalar>::Zero();  ///< sum w_i J_i^T W_i r_i
  Scalar cost = 0;                                                   ///< sum rho(s_i)
  Scalar weighted_sq = 0;  ///< sum w_i s_i: the weighted squared residuals
  /// Scalar measurements (D per point-to-point pair, 1 per point-to-plane or GICP pair)
  std::size_t residuals = 0;
  std::size_t pairs = 0;  ///< pairs that contributed

  /// Adds another block's sums (the ordered reduction of core/parallel.hpp).
  NormalEquations& operator+=(const NormalEquations& o) {
    hessian += o.hessian;
    gradient += o.gradient;
    cost += o.cost;
    weighted_sq += o.weighted_sq;
    residuals += o.residuals;
    pairs += o.pairs;
    return *this;
  }

  /// The residual variance sigma^2 = weighted_sq / (residuals - dof) (0 when residuals <= dof).
  [[nodiscard]] Scalar residual_variance() const {
    return residuals > static_cast<std::size_t>(dof)
               ? weighted_sq / static_cast<Scalar>(residuals - static_cast<std::size_t>(dof))
               : Scalar(0);
  }
  /// hessian / sigma^2: the inverse of the covariance of the estimate under the model that the
  /// residuals are independent with a common variance (Censi 2007: this captures the noise of
  /// the points, not the errors of the pairing nor the bias of a wrong local minimum). Zero when
  /// the residuals are all zero or too few.
  [[nodiscard]] PoseMatrix<D, Scalar> information() const {
    const Scalar v = residual_variance();
    return v > Scalar(0) ? PoseMatrix<D, Scalar>(hessian / v) : PoseMatrix<D, Scalar>::Zero();
  }
};

/// What a solver is told about the iteration it serves.
template <int D, class Scalar = double>
struct SolveContext {
  Transform<D, Scalar> current = Transform<D, Scalar>::Identity();  ///< ICP's estimate
  const PosePrior<D, Scalar>* prior = nullptr;                      ///< none when null
  int num_threads = 1;  ///< threads for the reduction over the pairs
};

// clang-format off
/// A solver stage of ICP (see the file comment for the protocol).
template <class S, int D, class Scalar>
concept TransformSolver =
    requires(const S& s, std::span<const Correspondence<D, Scalar>> pairs,
             const SolveContext<D, Scalar>& ctx, const Transform<D, Scalar>& t, int threads) {
      { S::min_pairs } -> std::convertible_to<std::size_t>;
      { s.solve(pairs, ctx) } -> std::same_as<std::optional<Transform<D, Scalar>>>;
      { s.linearize(pairs, t, threads) } -> std::same_as<NormalEquations<D, Scalar>>;
    };

/// A solver that reads unit normals of the model points, indexed by Correspondence::model_index
/// (zero = no normal), from its member `model_normals`.
template <class S, int D, class Scalar>
concept ModelNormalSolver = TransformSolver<S, D, Scalar> &&
    requires(S& s, std::span<const Point<D, Scalar>> normals) { s.model_normals = normals; };

/// A solver that reads covariances of the model points (by Correspondence::model_index) and of
/// the data points (by Correspondence::data_index) from its members `model_covariances` and
/// `data_covariances`.
template <class S, int D, class Scalar>
concept CovarianceSolver = TransformSolver<S, D, Scalar> &&
    requires(S& s, std::span<const Eigen::Matrix<Scalar, D, D>> covariances) {
      s.model_covariances = covariances;
      s.data_covariances = covariances;
    };
// clang-format on

namespace detail {

/// S(p): the motion of a point p of the data per unit rotation (see the file comment).
template <class Scalar>
[[nodiscard]] Eigen::Matrix<Scalar, 2, 1> rotation_jacobian(const Point<2, Scalar>& p) {
  return {-p.y(), p.x()};
}
template <class Scalar>
[[nodiscard]] Eigen::Matrix<Scalar, 3, 3> rotation_jacobian(const Point<3, Scalar>& p) {
  Eigen::Matrix<Scalar, 3, 3> s;
  s << 0, p.z(), -p.y(), -p.z(), 0, p.x(), p.y(), -p.x(), 0;  // -[p]x
  return s;
}

/// Adds one residual block r (R rows) with Jacobian J (R x dof) and weight matrix W to eq,
/// robustly weighted by the kernel; it counts as `measurements` scalar residuals in the variance
/// estimate (R, unless W makes some rows carry no noise of their own).
template <int D, class Scalar, int Rows>
void add_residual(NormalEquations<D, Scalar>& eq, const RobustKernel<Scalar>& kernel,
                  const Eigen::Matrix<Scalar, Rows, pose_dof<D>>& j,
                  const Eigen::Matrix<Scalar, Rows, 1>& r,
                  const Eigen::Matrix<Scalar, Rows, Rows>& w,
                  std::size_t measurements = static_cast<std::size_t>(Rows)) {
  const Eigen::Matrix<Scalar, Rows, 1> wr = w * r;
  const Scalar s = r.dot(wr);
  const Scalar weight = kernel.weight(s);
  const Eigen::Matrix<Scalar, pose_dof<D>, Rows> jt_w = j.transpose() * w;
  eq.hessian.noalias() += weight * (jt_w * j);
  eq.gradient.noalias() += weight * (j.transpose() * wr);
  eq.cost += kernel.rho(s);
  eq.weighted_sq += weight * s;
  eq.residuals += measurements;
  ++eq.pairs;
}

/// add_residual for the D rows of a point residual r (data frame) whose Jacobian is
/// A(p) = [I | S(p)] (s = S(p)): the blocks of A^T W A and A^T W r written out, half the
/// products of the general form.
template <int D, class Scalar>
void add_point_residual(NormalEquations<D, Scalar>& eq, const RobustKernel<Scalar>& kernel,
                        const Eigen::Matrix<Scalar, D, pose_dof<D> - D>& s,
                        const Point<D, Scalar>& r, const Eigen::Matrix<Scalar, D, D>& w,
                        std::size_t measurements) {
  constexpr int rot = pose_dof<D> - D;
  const Point<D, Scalar> wr = w * r;
  const Scalar sq = r.dot(wr);
  const Scalar weight = kernel.weight(sq);
  const Eigen::Matrix<Scalar, D, rot> ws = w * s;
  const Eigen::Matrix<Scalar, rot, rot> sws = s.transpose() * ws;
  eq.hessian.template topLeftCorner<D, D>() += weight * w;
  eq.hessian.template topRightCorner<D, rot>() += weight * ws;
  eq.hessian.template bottomLeftCorner<rot, D>() += weight * ws.transpose();
  eq.hessian.template bottomRightCorner<rot, rot>() += weight * sws;
  eq.gradient.template head<D>() += weight * wr;
  eq.gradient.template tail<rot>() += weight * (s.transpose() * wr);
  eq.cost += kernel.rho(sq);
  eq.weighted_sq += weight * sq;
  eq.residuals += measurements;
  ++eq.pairs;
}

/// The inverse of the right Jacobian of SO(3) at w: d Log(R Exp(v)) / dv at v = 0, R = Exp(w).
template <class Scalar>
[[nodiscard]] Eigen::Matrix<Scalar, 3, 3> so3_right_jacobian_inverse(const Point<3, Scalar>& w) {
  const Scalar theta = w.norm();
  Eigen::Matrix<Scalar, 3, 3> k;
  k << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  const Eigen::Matrix<Scalar, 3, 3> i = Eigen::Matrix<Scalar, 3, 3>::Identity();
  if (theta < Scalar(1e-4)) return i + k / 2 + k * k / 12;
  const Scalar c =
      Scalar(1) / (theta * theta) - (Scalar(1) + std::cos(theta)) / (2 * theta * std::sin(theta));
  return i + k / 2 + c * k * k;
}

/// Adds the prior's term at t: residual e = local_coordinates(mean, t), Jacobian de/dd.
template <int D, class Scalar>
void add_prior(NormalEquations<D, Scalar>& eq, const PosePrior<D, Scalar>& prior,
               const Transform<D, Scalar>& t) {
  const PoseTangent<D, Scalar> e = local_coordinates(prior.mean, t);
  PoseMatrix<D, Scalar> j = PoseMatrix<D, Scalar>::Zero();
  j.template topLeftCorner<D, D>() = prior.mean.linear().transpose() * t.linear();
  if constexpr (D == 2) {
    j(2, 2) = 1;
  } else {
    j.template bottomRightCorner<3, 3>() = so3_right_jacobian_inverse<Scalar>(e.template tail<3>());
  }
  const PoseMatrix<D, Scalar> jt_l = j.transpose() * prior.information;
  eq.hessian.noalias() += jt_l * j;
  eq.gradient.noalias() += jt_l * e;
  eq.cost += e.dot(prior.information * e);
}

}  // namespace detail
}  // namespace rangenav
