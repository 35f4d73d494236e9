#pragma once
// Uncertainty of the SLAM front end, one code path for SE(2) (3 DOF: x, y, θ) and SE(3) (6 DOF:
// translation, rotation vector). Every covariance and information matrix here is of a pose's
// body-frame perturbation T ∘ exp(δ) (δ = [translation; rotation]), the convention of the pose
// graph's edges.
//
//   - OdometryNoise: the covariance of an odometry increment, growing with the distance driven
//     and the angle turned (the odometry motion model of Thrun, Burgard, Fox, "Probabilistic
//     Robotics", §5.4, with the increment's components treated as independent);
//   - registration_information(): the information of an ICP result from its final pairs,
//     Ω = JᵀJ / σ² with point-to-plane rows J_i = [n_iᵀ R, n_iᵀ R [−p_i]×] (the Gauss-Newton
//     Hessian of the point-to-line / point-to-plane cost at the solution; Censi 2007 "An
//     accurate closed-form estimate of ICP's covariance" names it the dominant term) and σ² the
//     mean squared point-to-plane residual, floored by the sensor noise. A direction no surface
//     constrains (a corridor's axis) gets no information;
//   - fuse(): the information-weighted fusion of two estimates of one pose (the ICP result and
//     the odometry prediction): one Gauss-Newton step of the sum of both quadratic costs,
//     δ = (Ω_a + Ω_b)⁻¹ Ω_b log(a⁻¹ b), the exact minimum of their linearisation at a.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <numbers>
#include <span>
#include <string_view>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/lie.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/registration/correspondence.hpp"
#include "rangenav/search/nearest_neighbor_search.hpp"

namespace rangenav {

/// Covariance of an odometry increment (see the file comment). The defaults describe ordinary
/// wheel odometry on indoor floors: a few percent of the distance (wheel radius, slip), a few
/// percent of the turn plus a heading error per metre (wheel base), and a floor per increment for
/// quantisation and for reports that freeze for a few cycles and then jump.
template <std::floating_point Scalar = double>
struct OdometryNoise {
  Scalar translation_per_meter = Scalar(0.05);  ///< σ_t / |t|
  Scalar translation_floor = Scalar(0.02);      ///< m, σ_t of any increment
  Scalar rotation_per_radian = Scalar(0.05);    ///< σ_θ / |θ|
  Scalar rotation_per_meter = Scalar(std::numbers::pi_v<Scalar> / 180);  ///< rad / m (1°/m)
  Scalar rotation_floor = Scalar(std::numbers::pi_v<Scalar> / 180);      ///< rad (1°)

  /// Throws invalid_argument naming the first parameter out of range.
  void validate() const {
    constexpr std::string_view where = "OdometryNoise";
    detail::require_non_negative(where, "translation_per_meter", translation_per_meter);
    detail::require_positive(where, "translation_floor", translation_floor);
    detail::require_non_negative(where, "rotation_per_radian", rotation_per_radian);
    detail::require_non_negative(where, "rotation_per_meter", rotation_per_meter);
    detail::require_positive(where, "rotation_floor", rotation_floor);
  }

  /// The covariance of `increment` in its end frame (diagonal: σ_t² per axis, σ_θ² per axis).
  template <int D>
  [[nodiscard]] lie::PoseMatrix<D, Scalar> covariance(const Transform<D, Scalar>& increment) const {
    const Scalar d = increment.translation().norm();
    const Scalar a = std::abs(rotation_angle(increment));
    const Scalar st = translation_per_meter * d + translation_floor;
    const Scalar sr = rotation_per_radian * a + rotation_per_meter * d + rotation_floor;
    lie::PoseTangent<D, Scalar> v;
    v.template head<D>().setConstant(st * st);
    v.template tail<lie::pose_dof<D> - D>().setConstant(sr * sr);
    return v.asDiagonal();
  }
};

/// The information of an alignment's result `transform` (data -> model) from its final pairs
/// (see the file comment). `normal_of(pair)` gives the unit model normal of a pair, zero when
/// it has none (the pair is then left out); `sensor_sigma` floors the residual's σ.
template <int D, class Scalar, class NormalOf>
[[nodiscard]] lie::PoseMatrix<D, Scalar> registration_information(
    std::span<const Correspondence<D, Scalar>> pairs, const Transform<D, Scalar>& transform,
    NormalOf&& normal_of, Scalar sensor_sigma) {
  constexpr int dof = lie::pose_dof<D>;
  lie::PoseMatrix<D, Scalar> h = lie::PoseMatrix<D, Scalar>::Zero();
  Scalar sum_sq = 0;
  std::size_t rows = 0;
  const Eigen::Matrix<Scalar, D, D> rt = transform.linear().transpose();
  for (const auto& pr : pairs) {
    const Point<D, Scalar> n = normal_of(pr);
    if (n.isZero()) continue;
    const Point<D, Scalar> nb = rt * n;  // the normal in the data (body) frame
    Eigen::Matrix<Scalar, dof, 1> j;
    j.template head<D>() = nb;
    if constexpr (D == 2)
      j(2) = pr.data.x() * nb.y() - pr.data.y() * nb.x();
    else
      j.template tail<3>() = pr.data.cross(nb);
    h.noalias() += j * j.transpose();
    const Scalar r = n.dot(transform * pr.data - pr.model);
    sum_sq += r * r;
    ++rows;
  }
  if (rows <= static_cast<std::size_t>(dof)) return lie::PoseMatrix<D, Scalar>::Zero();
  const Scalar variance =
      std::max(sum_sq / static_cast<Scalar>(rows - dof), sensor_sigma * sensor_sigma);
  return h / variance;
}

/// The PCA normal of a model point from its k nearest model points (zero when they do not
/// span a line / plane); for maps that keep no normals.
template <int D, class Scalar, class Model>
[[nodiscard]] Point<D, Scalar> pca_normal(const Model& model, const Point<D, Scalar>& q,
                                          std::size_t k, std::vector<Neighbor<Scalar>>& scratch) {
  if (model.knn(q, k, scratch) < static_cast<std::size_t>(D)) return Point<D, Scalar>::Zero();
  Point<D, Scalar> mean = Point<D, Scalar>::Zero();
  for (const auto& nb : scratch)
    mean += model.point(nb.index);
  mean /= static_cast<Scalar>(scratch.size());
  Eigen::Matrix<Scalar, D, D> cov = Eigen::Matrix<Scalar, D, D>::Zero();
  for (const auto& nb : scratch) {
    const Point<D, Scalar> d = model.point(nb.index) - mean;
    cov.noalias() += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<Scalar, D, D>> eig;
  eig.computeDirect(cov);
  const auto& values = eig.eigenvalues();
  if (!(values(D - 1) > Scalar(0)) || values(0) > Scalar(0.1) * values(D - 1))
    return Point<D, Scalar>::Zero();
  const Point<D, Scalar> n = eig.eigenvectors().col(0).normalized();
  return n.allFinite() ? n : Point<D, Scalar>::Zero();
}

/// Two estimates of one pose fused by their information (see the file comment).
template <int D, class Scalar>
struct FusedPose {
  Transform<D, Scalar> pose;               ///< the fused pose
  lie::PoseMatrix<D, Scalar> information;  ///< its information (the sum of both)
  /// Squared Mahalanobis distance between the two estimates under their summed covariance
  /// (χ² with lie::pose_dof<D> degrees of freedom when both are right); +inf when undetermined.
  Scalar chi2 = 0;
};

/// Fuses estimate `a` (information `info_a`, e.g. a registration that may be degenerate) with
/// `b` (information `info_b`, positive definite, e.g. the odometry prediction).
template <int D, class Scalar>
[[nodiscard]] FusedPose<D, Scalar> fuse(const Transform<D, Scalar>& a,
                                        const lie::PoseMatrix<D, Scalar>& info_a,
                                        const Transform<D, Scalar>& b,
                                        const lie::PoseMatrix<D, Scalar>& info_b) {
  FusedPose<D, Scalar> out;
  out.information = info_a + info_b;
  const lie::PoseTangent<D, Scalar> e = lie::se_log<D, Scalar>(a.inverse(Eigen::Isometry) * b);
  const Eigen::LDLT<lie::PoseMatrix<D, Scalar>> ldlt(out.information);
  const lie::PoseTangent<D, Scalar> delta = ldlt.solve(info_b * e);
  // χ² of the disagreement: eᵀ (Σ_a + Σ_b)⁻¹ e = eᵀ Ω_b (Ω_a + Ω_b)⁻¹ Ω_a e.
  out.chi2 = e.dot(info_b * ldlt.solve(info_a * e));
  if (!delta.allFinite() || !std::isfinite(out.chi2)) {
    out.pose = b;
    out.information = info_b;
    out.chi2 = std::numeric_limits<Scalar>::infinity();
    return out;
  }
  out.pose = a * lie::se_exp<D>(delta);
  return out;
}

/// Estimate `a` (information `info_a`, a registration) completed by `b` (information `info_b`,
/// positive definite, the odometry prediction) along the directions where `a` knows less than
/// `b`: with Ω_b = LLᵀ and the eigenvectors u_i (eigenvalues λ_i) of L⁻¹ Ω_a L⁻ᵀ, the pose takes
/// b's value along every u_i with λ_i < 1 and keeps a's along the others. Unlike fuse(), a
/// well-constrained registration is left exactly as it is (odometry errors that the noise model
/// underrates, such as a report that froze, never leak into it); along a corridor's axis the
/// odometry carries the pose. The information is Ω_a + Ω_b either way.
template <int D, class Scalar>
[[nodiscard]] FusedPose<D, Scalar> complete(const Transform<D, Scalar>& a,
                                            const lie::PoseMatrix<D, Scalar>& info_a,
                                            const Transform<D, Scalar>& b,
                                            const lie::PoseMatrix<D, Scalar>& info_b) {
  using Matrix = lie::PoseMatrix<D, Scalar>;
  FusedPose<D, Scalar> out;
  out.pose = a;
  out.information = info_a + info_b;
  const lie::PoseTangent<D, Scalar> e = lie::se_log<D, Scalar>(a.inverse(Eigen::Isometry) * b);
  const Eigen::LLT<Matrix> llt(info_b);
  if (llt.info() != Eigen::Success || !e.allFinite()) {
    out.chi2 = std::numeric_limits<Scalar>::infinity();
    return out;
  }
  const Matrix l = llt.matrixL();
  const Matrix l_inv = l.inverse();
  const Eigen::SelfAdjointEigenSolver<Matrix> eig(l_inv * info_a * l_inv.transpose());
  // In b's whitened coordinates z = Lᵀe: χ² = Σ z_i² λ_i / (1 + λ_i), and the completion moves
  // along the weak eigenvectors only.
  const lie::PoseTangent<D, Scalar> z = eig.eigenvectors().transpose() * (l.transpose() * e);
  lie::PoseTangent<D, Scalar> kept = lie::PoseTangent<D, Scalar>::Zero();
  out.chi2 = 0;
  for (int i = 0; i < lie::pose_dof<D>; ++i) {
    const Scalar lambda = std::max(Scalar(0), eig.eigenvalues()(i));
    out.chi2 += z(i) * z(i) * lambda / (1 + lambda);
    if (lambda < 1) kept(i) = z(i);
  }
  const lie::PoseTangent<D, Scalar> delta = l_inv.transpose() * (eig.eigenvectors() * kept);
  if (delta.allFinite()) out.pose = a * lie::se_exp<D>(delta);
  return out;
}

}  // namespace rangenav
