#pragma once
// The rigid-motion groups SO(D) and SE(D), D ∈ {2, 3}: exponential and logarithm maps, the
// adjoint, and the right retraction used by the pose graph (and reusable by ICP).
//
// A tangent vector ξ of SE(D) is ordered translation first, rotation last, as g2o and Ceres order
// pose errors: ξ = (ρ, φ) with ρ ∈ R^D and φ ∈ R (D = 2) or R³ (D = 3). Its hat ξ^ is the
// (D+1)×(D+1) matrix [[φ^, ρ], [0, 0]], with φ^ = φ·[[0, −1], [1, 0]] in 2D and the
// cross-product matrix [φ]× in 3D. Formulas: Barfoot, "State Estimation for Robotics" (2017),
// §7.1 (SO(3): Eq. 7.7 Rodrigues, 7.18 logarithm; SE(3): Eq. 7.83 V matrix, 7.46 adjoint) and
// Solà, Deray, Atchuthan, "A micro Lie theory for state estimation in robotics" (2018), App. A
// (SE(2)) and App. D (SE(3)).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>
#include <concepts>

#include "rangenav/core/types.hpp"

namespace rangenav::lie {

/// The dimension of the rotation group SO(D): 1 in 2D, 3 in 3D.
template <int D>
inline constexpr int rotation_dof = D == 2 ? 1 : 3;

/// The dimension of SE(D): 3 in 2D (x, y, θ), 6 in 3D (x, y, z and a rotation vector).
template <int D>
inline constexpr int pose_dof = D + rotation_dof<D>;

/// A tangent vector of SO(D).
template <int D, class Scalar = double>
using RotationTangent = Eigen::Matrix<Scalar, rotation_dof<D>, 1>;

/// A tangent vector ξ = (ρ, φ) of SE(D), translation first.
template <int D, class Scalar = double>
using PoseTangent = Eigen::Matrix<Scalar, pose_dof<D>, 1>;

/// A square matrix over SE(D)'s tangent space (an adjoint, a Jacobian, an information matrix).
template <int D, class Scalar = double>
using PoseMatrix = Eigen::Matrix<Scalar, pose_dof<D>, pose_dof<D>>;

/// The cross-product matrix [v]×, so that [v]× w = v × w.
template <class Derived>
[[nodiscard]] Eigen::Matrix<typename Derived::Scalar, 3, 3> skew(
    const Eigen::MatrixBase<Derived>& v) {
  using Scalar = typename Derived::Scalar;
  Eigen::Matrix<Scalar, 3, 3> m;
  m << Scalar(0), -v(2), v(1), v(2), Scalar(0), -v(0), -v(1), v(0), Scalar(0);
  return m;
}

/// SO(D) exponential: the rotation matrix of the angle φ (2D) or of the rotation vector φ (3D,
/// Rodrigues' formula, Barfoot Eq. 7.7).
template <int D, class Derived>
[[nodiscard]] Eigen::Matrix<typename Derived::Scalar, D, D> so_exp(
    const Eigen::MatrixBase<Derived>& phi) {
  using Scalar = typename Derived::Scalar;
  static_assert(Derived::SizeAtCompileTime == rotation_dof<D>, "so_exp: φ has the wrong size");
  if constexpr (D == 2) {
    return Eigen::Rotation2D<Scalar>(phi(0)).toRotationMatrix();
  } else {
    const Scalar angle = phi.norm();
    if (angle < Scalar(1e-8)) {
      // Second-order Taylor expansion: exact to rounding at this angle.
      const Eigen::Matrix<Scalar, 3, 3> w = skew(phi);
      return Eigen::Matrix<Scalar, 3, 3>::Identity() + w + Scalar(0.5) * w * w;
    }
    return Eigen::AngleAxis<Scalar>(angle, (phi / angle).eval()).toRotationMatrix();
  }
}

/// SO(D) logarithm: the angle in (−π, π] (2D) or the rotation vector of norm ≤ π (3D, Barfoot
/// Eq. 7.18) of a rotation matrix.
template <int D, std::floating_point Scalar>
[[nodiscard]] RotationTangent<D, Scalar> so_log(const Eigen::Matrix<Scalar, D, D>& r) {
  if constexpr (D == 2) {
    return RotationTangent<2, Scalar>(std::atan2(r(1, 0), r(0, 0)));
  } else {
    // Through the unit quaternion: accurate near 0 and near π, where acos of the trace is not.
    Eigen::Quaternion<Scalar> q(r);
    if (q.w() < Scalar(0)) q.coeffs() = -q.coeffs();
    const Scalar sin_half = q.vec().norm();
    if (sin_half < Scalar(1e-10)) return Scalar(2) * q.vec();  // 2·sin(θ/2) → θ
    const Scalar angle = Scalar(2) * std::atan2(sin_half, q.w());
    return (angle / sin_half) * q.vec();
  }
}

/// The left Jacobian V of SO(D) that maps ρ to the translation of Exp(ξ): t = V(φ)·ρ (Barfoot
/// Eq. 7.83 in 3D; Solà Eq. 165 in 2D).
template <int D, class Derived>
[[nodiscard]] Eigen::Matrix<typename Derived::Scalar, D, D> so_left_jacobian(
    const Eigen::MatrixBase<Derived>& phi) {
  using Scalar = typename Derived::Scalar;
  using Matrix = Eigen::Matrix<Scalar, D, D>;
  static_assert(Derived::SizeAtCompileTime == rotation_dof<D>,
                "so_left_jacobian: φ has the wrong size");
  if constexpr (D == 2) {
    const Scalar t = phi(0);
    Scalar a, b;  // sin(t)/t and (1 − cos(t))/t
    if (std::abs(t) < Scalar(1e-6)) {
      a = Scalar(1) - t * t / Scalar(6);
      b = t / Scalar(2) - t * t * t / Scalar(24);
    } else {
      a = std::sin(t) / t;
      b = (Scalar(1) - std::cos(t)) / t;
    }
    Matrix v;
    v << a, -b, b, a;
    return v;
  } else {
    const Scalar angle = phi.norm();
    const Matrix w = skew(phi);
    if (angle < Scalar(1e-6)) return Matrix::Identity() + Scalar(0.5) * w + w * w / Scalar(6);
    const Scalar a2 = angle * angle;
    return Matrix::Identity() + (Scalar(1) - std::cos(angle)) / a2 * w +
           (angle - std::sin(angle)) / (a2 * angle) * w * w;
  }
}

/// SE(D) exponential Exp(ξ) = exp(ξ^): rotation so_exp(φ), translation so_left_jacobian(φ)·ρ.
template <int D, class Derived>
[[nodiscard]] Transform<D, typename Derived::Scalar> se_exp(const Eigen::MatrixBase<Derived>& xi) {
  using Scalar = typename Derived::Scalar;
  static_assert(Derived::SizeAtCompileTime == pose_dof<D>, "se_exp: ξ has the wrong size");
  const RotationTangent<D, Scalar> phi = xi.template tail<rotation_dof<D>>();
  Transform<D, Scalar> t = Transform<D, Scalar>::Identity();
  t.linear() = so_exp<D>(phi);
  t.translation() = so_left_jacobian<D>(phi) * xi.template head<D>();
  return t;
}

/// SE(D) logarithm Log(T), the inverse of se_exp for rotations of angle < π.
template <int D, std::floating_point Scalar>
[[nodiscard]] PoseTangent<D, Scalar> se_log(const Transform<D, Scalar>& t) {
  const Eigen::Matrix<Scalar, D, D> r = t.linear();
  const RotationTangent<D, Scalar> phi = so_log<D>(r);
  PoseTangent<D, Scalar> xi;
  xi.template head<D>() = so_left_jacobian<D>(phi).lu().solve(t.translation());
  xi.template tail<rotation_dof<D>>() = phi;
  return xi;
}

/// The adjoint Ad(T), so that T·Exp(ξ)·T⁻¹ = Exp(Ad(T)·ξ): [[R, [t]×R], [0, R]] in 3D (Barfoot
/// Eq. 7.46), [[R, (t_y, −t_x)ᵀ], [0, 1]] in 2D (Solà Eq. 159).
template <int D, std::floating_point Scalar>
[[nodiscard]] PoseMatrix<D, Scalar> se_adjoint(const Transform<D, Scalar>& t) {
  PoseMatrix<D, Scalar> ad = PoseMatrix<D, Scalar>::Zero();
  const auto r = t.linear();
  const auto p = t.translation();
  ad.template topLeftCorner<D, D>() = r;
  if constexpr (D == 2) {
    ad(0, 2) = p.y();
    ad(1, 2) = -p.x();
    ad(2, 2) = Scalar(1);
  } else {
    ad.template topRightCorner<3, 3>() = skew(p) * r;
    ad.template bottomRightCorner<3, 3>() = r;
  }
  return ad;
}

/// The right retraction T ⊞ ξ = T · [[Exp(φ), ρ], [0, 1]]: the rotation is perturbed in the
/// body frame and the translation by R·ρ. It agrees with T·Exp(ξ) to first order (so Jacobians
/// derived for one hold for the other) and is cheaper; the pose graph updates its poses with it.
template <int D, class Derived>
[[nodiscard]] Transform<D, typename Derived::Scalar> retract_right(
    const Transform<D, typename Derived::Scalar>& t, const Eigen::MatrixBase<Derived>& xi) {
  static_assert(Derived::SizeAtCompileTime == pose_dof<D>, "retract_right: ξ has the wrong size");
  Transform<D, typename Derived::Scalar> out;
  out.translation() = t.translation() + t.linear() * xi.template head<D>();
  out.linear() = t.linear() * so_exp<D>(xi.template tail<rotation_dof<D>>());
  out.makeAffine();
  return out;
}

/// The nearest rotation matrix to a square matrix m in the Frobenius norm (its polar factor with
/// a determinant of +1: U·diag(1, …, det(UVᵀ))·Vᵀ from the SVD m = U·S·Vᵀ).
template <int D, std::floating_point Scalar>
[[nodiscard]] Eigen::Matrix<Scalar, D, D> nearest_rotation(const Eigen::Matrix<Scalar, D, D>& m) {
  if constexpr (D == 2) {
    // In 2D the projection is the rotation by the angle of the (c, s) part of m.
    const Scalar c = m(0, 0) + m(1, 1), s = m(1, 0) - m(0, 1);
    if (c == Scalar(0) && s == Scalar(0)) return Eigen::Matrix<Scalar, 2, 2>::Identity();
    return Eigen::Rotation2D<Scalar>(std::atan2(s, c)).toRotationMatrix();
  } else {
    Eigen::JacobiSVD<Eigen::Matrix<Scalar, 3, 3>> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix<Scalar, 3, 3> u = svd.matrixU();
    const Eigen::Matrix<Scalar, 3, 3>& v = svd.matrixV();
    if ((u * v.transpose()).determinant() < Scalar(0)) u.col(2) = -u.col(2);
    return u * v.transpose();
  }
}

}  // namespace rangenav::lie
