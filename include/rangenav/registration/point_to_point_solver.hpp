#pragma once
// Closed-form point-to-point solvers: the rigid transform T minimising
//   E(R, t) = sum_i |m_i - (R d_i + t)|^2      (Eq. (1) of paper 000)
// over a set of pairs, in 2D (the atan2 form, Eq. (5)-(6) of paper 003) and 3D (SVD of the
// cross-covariance, Arun / Umeyama, with the reflection case corrected).
//
// A TransformSolver<S, D> is any type with `std::optional<Transform<D, Scalar>>
// solve(std::span<const Correspondence<D, Scalar>>) const` and `min_pairs`; it returns nullopt
// when the pairs do not determine a transform (too few, all data points identical, collinear
// in 3D).

#include <Eigen/Core>
#include <Eigen/SVD>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <optional>
#include <span>

#include "rangenav/core/types.hpp"
#include "rangenav/registration/correspondence.hpp"

namespace rangenav {

template <class S, int D, class Scalar>
concept TransformSolver = requires(const S& s, std::span<const Correspondence<D, Scalar>> pairs) {
  { s.solve(pairs) } -> std::same_as<std::optional<Transform<D, Scalar>>>;
  { S::min_pairs } -> std::convertible_to<std::size_t>;
};

template <int D, std::floating_point Scalar = double>
struct PointToPointSolver;

/// 2D: with centroids c_m, c_d and centred points m', d',
///   theta = atan2(sum(m'_y d'_x - m'_x d'_y), sum(m'_x d'_x + m'_y d'_y))   (Eq. (5), paper 003)
///   t = c_m - R(theta) c_d                                                   (Eq. (6), paper 003)
/// (paper 003 writes the inverse rotation; this is the same law for T mapping data onto model).
template <std::floating_point Scalar>
struct PointToPointSolver<2, Scalar> {
  static constexpr std::size_t min_pairs = 2;

  [[nodiscard]] std::optional<Transform<2, Scalar>> solve(
      std::span<const Correspondence<2, Scalar>> pairs) const {
    if (pairs.size() < min_pairs) return std::nullopt;
    const Scalar n = static_cast<Scalar>(pairs.size());
    Point<2, Scalar> cm = Point<2, Scalar>::Zero(), cd = Point<2, Scalar>::Zero();
    for (const auto& c : pairs) {
      cm += c.model;
      cd += c.data;
    }
    cm /= n;
    cd /= n;
    Scalar sin_sum = 0, cos_sum = 0, spread_sq = 0;
    for (const auto& c : pairs) {
      const Point<2, Scalar> m = c.model - cm, d = c.data - cd;
      sin_sum += m.y() * d.x() - m.x() * d.y();
      cos_sum += m.x() * d.x() + m.y() * d.y();
      spread_sq += d.squaredNorm();
    }
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
};

/// 3D: R = V diag(1, 1, det(V U^T)) U^T from the SVD H = U S V^T of the cross-covariance
/// H = sum d' m'^T (the diagonal term corrects a reflection); t = c_m - R c_d.
template <std::floating_point Scalar>
struct PointToPointSolver<3, Scalar> {
  static constexpr std::size_t min_pairs = 3;

  [[nodiscard]] std::optional<Transform<3, Scalar>> solve(
      std::span<const Correspondence<3, Scalar>> pairs) const {
    if (pairs.size() < min_pairs) return std::nullopt;
    const Scalar n = static_cast<Scalar>(pairs.size());
    Point<3, Scalar> cm = Point<3, Scalar>::Zero(), cd = Point<3, Scalar>::Zero();
    for (const auto& c : pairs) {
      cm += c.model;
      cd += c.data;
    }
    cm /= n;
    cd /= n;
    Eigen::Matrix<Scalar, 3, 3> h = Eigen::Matrix<Scalar, 3, 3>::Zero();
    Eigen::Matrix<Scalar, 3, 3> data_cov = Eigen::Matrix<Scalar, 3, 3>::Zero();
    for (const auto& c : pairs) {
      const Point<3, Scalar> d = c.data - cd;
      h.noalias() += d * (c.model - cm).transpose();
      data_cov.noalias() += d * d.transpose();
    }
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
};

}  // namespace rangenav
