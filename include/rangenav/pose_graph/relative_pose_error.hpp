#pragma once
// The error of a relative-pose measurement, as g2o defines it (Kümmerle et al., "g2o: A General
// Framework for Graph Optimization", ICRA 2011; its types EdgeSE2 and EdgeSE3), and how an edge's
// information relates to a covariance.
//
// An edge from node a to node b measures the pose Z of b in a's frame. With the residual
// transform E = Z⁻¹·(Xa⁻¹·Xb), the error e(E) ∈ R^K (K = 3 in 2D, 6 in 3D) is
//
//   2D: e = (t_E, θ_E)            t_E the translation of E, θ_E its angle in (−π, π]
//   3D: e = (t_E, q_E.vec)        q_E the unit quaternion of E's rotation with q_E.w ≥ 0
//
// and the edge's χ² is eᵀΩe with Ω the information matrix in those coordinates. In 3D the
// quaternion's vector part is sin(|φ|/2)·φ/|φ| ≈ φ/2 for the rotation vector φ of E, so an
// information over (x, y, z, qx, qy, qz) weighs rotation errors four times more than the same
// matrix over a rotation vector: information_from_covariance() does that conversion.
//
// Jacobians (analytic; derivation in docs/pose_graph.md). Poses are updated on the right,
// X ← X·[[Exp(φ), ρ], [0, 1]] (lie::retract_right), so with A = Xa⁻¹·Xb:
//   ∂e/∂δb = J_E,   ∂e/∂δa = −J_E·Ad(A⁻¹),
// where J_E = ∂e(E·Exp(δ))/∂δ at δ = 0 is [[R_E, 0], [0, 1]] in 2D and
// [[R_E, 0], [0, ½(w·I + [v]×)]] in 3D for q_E = (w, v).

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <concepts>
#include <string>
#include <string_view>

#include "rangenav/core/error.hpp"
#include "rangenav/core/lie.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// g2o's error e(E) of the residual transform E = Z⁻¹·(Xa⁻¹·Xb) (see the file comment).
template <int D, std::floating_point Scalar>
[[nodiscard]] lie::PoseTangent<D, Scalar> relative_pose_error(const Transform<D, Scalar>& e) {
  lie::PoseTangent<D, Scalar> r;
  r.template head<D>() = e.translation();
  if constexpr (D == 2) {
    r(2) = std::atan2(e.linear()(1, 0), e.linear()(0, 0));
  } else {
    Eigen::Quaternion<Scalar> q(Eigen::Matrix<Scalar, 3, 3>(e.linear()));
    r.template tail<3>() = q.w() < Scalar(0) ? Eigen::Matrix<Scalar, 3, 1>(-q.vec()) : q.vec();
  }
  return r;
}

/// The error e(E) and its Jacobian J_E = ∂e(E·Exp(δ))/∂δ at δ = 0 (see the file comment).
template <int D, std::floating_point Scalar>
void relative_pose_error(const Transform<D, Scalar>& e, lie::PoseTangent<D, Scalar>& error,
                         lie::PoseMatrix<D, Scalar>& jacobian) {
  error.template head<D>() = e.translation();
  jacobian.setZero();
  jacobian.template topLeftCorner<D, D>() = e.linear();
  if constexpr (D == 2) {
    error(2) = std::atan2(e.linear()(1, 0), e.linear()(0, 0));
    jacobian(2, 2) = Scalar(1);
  } else {
    Eigen::Quaternion<Scalar> q(Eigen::Matrix<Scalar, 3, 3>(e.linear()));
    if (q.w() < Scalar(0)) q.coeffs() = -q.coeffs();
    error.template tail<3>() = q.vec();
    // q ⊗ (1, δφ/2) = (w − v·δφ/2, v + (w·δφ + v × δφ)/2) to first order.
    jacobian.template bottomRightCorner<3, 3>() =
        Scalar(0.5) * (q.w() * Eigen::Matrix<Scalar, 3, 3>::Identity() + lie::skew(q.vec()));
  }
}

namespace detail {

// The Cholesky factor of m; throws invalid_argument naming `name` unless m is finite, symmetric
// and positive definite.
template <int K, std::floating_point Scalar>
Eigen::LLT<Eigen::Matrix<Scalar, K, K>> require_symmetric_positive_definite(
    std::string_view where, std::string_view name, const Eigen::Matrix<Scalar, K, K>& m) {
  if (!m.allFinite()) throw_invalid(where, std::string(name) + " has a non-finite entry");
  const Scalar scale = m.cwiseAbs().maxCoeff();
  if (!((m - m.transpose()).cwiseAbs().maxCoeff() <= Scalar(1e-9) * scale))
    throw_invalid(where, std::string(name) + " is not symmetric");
  Eigen::LLT<Eigen::Matrix<Scalar, K, K>> llt(m);
  if (llt.info() != Eigen::Success)
    throw_invalid(where, std::string(name) + " is not positive definite");
  return llt;
}

// The scaling s of the rotation coordinates between a rotation vector and g2o's error: 1 in 2D,
// 1/2 in 3D (e_q ≈ φ/2).
template <int D, std::floating_point Scalar>
Eigen::Matrix<Scalar, lie::pose_dof<D>, 1> g2o_rotation_scale() {
  Eigen::Matrix<Scalar, lie::pose_dof<D>, 1> s = Eigen::Matrix<Scalar, lie::pose_dof<D>, 1>::Ones();
  if constexpr (D == 3) s.template tail<3>().setConstant(Scalar(0.5));
  return s;
}

}  // namespace detail

/// The information matrix of an edge, in g2o's error coordinates (2D: x, y, θ; 3D: x, y, z, qx,
/// qy, qz), of a measurement whose covariance is `covariance` over (translation, rotation
/// vector), both in the frame of the edge's first node. In 2D the two coordinates agree; in 3D
/// e_q ≈ φ/2, so the rotation rows and columns of the covariance are halved before inversion.
/// Throws invalid_argument unless `covariance` is finite, symmetric and positive definite.
template <int D, std::floating_point Scalar>
[[nodiscard]] lie::PoseMatrix<D, Scalar> information_from_covariance(
    const lie::PoseMatrix<D, Scalar>& covariance) {
  detail::require_symmetric_positive_definite("information_from_covariance", "covariance",
                                              covariance);
  const auto s = detail::g2o_rotation_scale<D, Scalar>();
  const lie::PoseMatrix<D, Scalar> g2o_covariance = s.asDiagonal() * covariance * s.asDiagonal();
  const lie::PoseMatrix<D, Scalar> information =
      g2o_covariance.llt().solve(lie::PoseMatrix<D, Scalar>::Identity());
  return Scalar(0.5) * (information + information.transpose());
}

/// The covariance over (translation, rotation vector) that information_from_covariance() turns
/// into `information`. Throws invalid_argument unless `information` is finite, symmetric and
/// positive definite.
template <int D, std::floating_point Scalar>
[[nodiscard]] lie::PoseMatrix<D, Scalar> covariance_from_information(
    const lie::PoseMatrix<D, Scalar>& information) {
  const auto llt = detail::require_symmetric_positive_definite("covariance_from_information",
                                                               "information", information);
  const auto s = detail::g2o_rotation_scale<D, Scalar>().cwiseInverse().eval();
  const lie::PoseMatrix<D, Scalar> g2o_covariance =
      llt.solve(lie::PoseMatrix<D, Scalar>::Identity());
  const lie::PoseMatrix<D, Scalar> covariance = s.asDiagonal() * g2o_covariance * s.asDiagonal();
  return Scalar(0.5) * (covariance + covariance.transpose());
}

}  // namespace rangenav
