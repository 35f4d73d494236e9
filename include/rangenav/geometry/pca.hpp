#pragma once
// Principal component analysis of a point set: the mean, the covariance and its eigen
// decomposition. The one PCA fit of rangenav: surface and line normals (the eigenvector of the
// smallest eigenvalue), line directions (the largest), the planes of the plane extraction and the
// GICP covariances of registration/normals.hpp all come from it.
//
// With the mean m = (1/n) sum p_i and the covariance C = (1/n) sum (p_i - m)(p_i - m)^T,
// C = V diag(l) V^T with eigenvalues l ascending. Eigen's closed-form solver for symmetric 2x2 /
// 3x3 matrices (SelfAdjointEigenSolver::computeDirect) decomposes C.

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <span>

#include "rangenav/core/types.hpp"

namespace rangenav {

/// The PCA of a point set (see the file comment).
template <int D, class Scalar = double>
struct PcaFit {
  static_assert(D == 2 || D == 3, "PcaFit: dimension must be 2 or 3");
  using point_type = Point<D, Scalar>;              ///< a point, a direction
  using matrix_type = Eigen::Matrix<Scalar, D, D>;  ///< the covariance, the eigenvectors

  std::size_t count = 0;                               ///< points fitted
  point_type mean = point_type::Zero();                ///< their centroid
  matrix_type covariance = matrix_type::Zero();        ///< (1/n) sum (p - mean)(p - mean)^T
  point_type eigenvalues = point_type::Zero();         ///< of the covariance, ascending
  matrix_type eigenvectors = matrix_type::Identity();  ///< unit columns, in eigenvalue order

  /// The direction of least spread: a surface's normal in 3D, a line's normal in 2D.
  [[nodiscard]] point_type normal() const { return eigenvectors.col(0); }
  /// The direction of most spread: a line's direction.
  [[nodiscard]] point_type principal_direction() const { return eigenvectors.col(D - 1); }
  /// RMS distance of the points from the hyperplane through the mean with normal normal().
  [[nodiscard]] Scalar normal_rms() const { return std::sqrt(std::max(Scalar(0), eigenvalues(0))); }
};

/// The eigen decomposition of a given covariance (e.g. one accumulated from weighted moments).
template <int D, class Scalar>
[[nodiscard]] PcaFit<D, Scalar> pca_of_covariance(const Point<D, Scalar>& mean,
                                                  const Eigen::Matrix<Scalar, D, D>& covariance,
                                                  std::size_t count) {
  PcaFit<D, Scalar> fit;
  fit.count = count;
  fit.mean = mean;
  fit.covariance = covariance;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<Scalar, D, D>> eig;
  eig.computeDirect(covariance);
  fit.eigenvalues = eig.eigenvalues();
  fit.eigenvectors = eig.eigenvectors();
  return fit;
}

/// The unit eigenvector of the smallest eigenvalue of a symmetric positive semi-definite D x D
/// matrix (a covariance): the normal of a PCA fit without the other eigenvectors. The eigenvalues
/// come from Eigen's closed form; the eigenvector is the longest cross product of two rows of
/// C - l_min I (in 2D, the longer row turned by 90 degrees), the kernel of that matrix. When the
/// smallest eigenvalue is not simple (no unique normal: all points at one spot, or on a line in
/// 3D) it falls back to the full decomposition's vector. About half the work of
/// pca_of_covariance.
template <int D, class Scalar>
[[nodiscard]] Point<D, Scalar> smallest_eigenvector(const Eigen::Matrix<Scalar, D, D>& c) {
  using Matrix = Eigen::Matrix<Scalar, D, D>;
  const Scalar scale = c.cwiseAbs().maxCoeff();
  if (!(scale > Scalar(0))) return Point<D, Scalar>::UnitX();
  const Matrix a = c / scale;  // entries in [-1, 1]: no overflow, a relative tolerance below
  Eigen::SelfAdjointEigenSolver<Matrix> eig;
  eig.computeDirect(a, Eigen::EigenvaluesOnly);
  Matrix b = a;
  b.diagonal().array() -= eig.eigenvalues()(0);
  Point<D, Scalar> best = Point<D, Scalar>::Zero();
  Scalar best_sq = 0;
  if constexpr (D == 2) {
    for (int r = 0; r < 2; ++r) {
      const Point<2, Scalar> v(-b(r, 1), b(r, 0));
      if (v.squaredNorm() > best_sq) {
        best_sq = v.squaredNorm();
        best = v;
      }
    }
  } else {
    for (int r = 0; r < 3; ++r) {
      const Point<3, Scalar> v = b.row(r).transpose().cross(b.row((r + 1) % 3).transpose());
      if (v.squaredNorm() > best_sq) {
        best_sq = v.squaredNorm();
        best = v;
      }
    }
  }
  // The kernel is one-dimensional when the gap to the next eigenvalue is a fair fraction of the
  // spread; otherwise the rows are nearly parallel and their cross products mostly rounding.
  const Scalar gap = eig.eigenvalues()(1) - eig.eigenvalues()(0);
  if (gap > Scalar(1e-3) && best_sq > Scalar(0)) return best / std::sqrt(best_sq);
  eig.computeDirect(a);
  return eig.eigenvectors().col(0);
}

/// The mean and covariance of the n points get(0) ... get(n - 1) (`get` returns a
/// Point<D, Scalar> or a reference to one; n >= 1), without the decomposition (`eigenvalues` and
/// `eigenvectors` left as constructed). One pass over the points, taken relative to the first of
/// them: with d_i = p_i - p_0, C = (1/n) sum d_i d_i^T - m m^T, m = (1/n) sum d_i, which does not
/// cancel as long as the points lie close together compared with their distance from the origin
/// of the frame (a neighbourhood, a segment).
template <int D, class Scalar, class Get>
requires std::invocable<const Get&, std::size_t>
[[nodiscard]] PcaFit<D, Scalar> fit_moments(std::size_t n, const Get& get) {
  using point_type = Point<D, Scalar>;
  const point_type origin = get(0);
  point_type sum = point_type::Zero();
  Eigen::Matrix<Scalar, D, D> outer = Eigen::Matrix<Scalar, D, D>::Zero();
  for (std::size_t i = 1; i < n; ++i) {
    const point_type d = get(i) - origin;
    sum += d;
    outer.noalias() += d * d.transpose();
  }
  const Scalar inv = Scalar(1) / static_cast<Scalar>(n);
  const point_type m = sum * inv;
  PcaFit<D, Scalar> fit;
  fit.count = n;
  fit.mean = origin + m;
  fit.covariance = outer * inv - m * m.transpose();
  return fit;
}

/// The PCA of the n points get(0) ... get(n - 1): fit_moments and the eigen decomposition.
template <int D, class Scalar, class Get>
requires std::invocable<const Get&, std::size_t>
[[nodiscard]] PcaFit<D, Scalar> fit_pca(std::size_t n, const Get& get) {
  const PcaFit<D, Scalar> moments = fit_moments<D, Scalar>(n, get);
  return pca_of_covariance<D, Scalar>(moments.mean, moments.covariance, n);
}

/// The PCA of a contiguous run of points (at least one).
template <int D, class Scalar>
[[nodiscard]] PcaFit<D, Scalar> fit_pca(std::span<const Point<D, Scalar>> points) {
  return fit_pca<D, Scalar>(points.size(),
                            [&](std::size_t i) -> const Point<D, Scalar>& { return points[i]; });
}

}  // namespace rangenav
