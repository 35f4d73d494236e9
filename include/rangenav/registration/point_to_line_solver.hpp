#pragma once
// Point-to-line solver for 2D ICP (point-to-plane in 2D; Chen & Medioni 1992, Censi's PL-ICP
// without the closed form): the rigid transform T minimising
//   E(T) = sum_i ( n_i . (T d_i - m_i) )^2
// over the pairs whose model point has a normal n_i (the line through m_i and its neighbours).
// A data point on a wall may slide along the wall, so a sparse model (a SparsePointMap whose
// points are eps_D apart) does not pull the data towards its sample positions the way
// point-to-point does (Eq. (1) of paper 000). This is an option beyond the papers, which use
// point-to-point: it is the solver of `LaserIcp` (incremental_mapper.hpp's 2D laser setup).
//
// The model normals are a span indexed by Correspondence::model_index (SparsePointMap::normals()
// with SparsePointMapParams::normals set); a zero normal marks a point without a line (a corner,
// an isolated point) and its pair is left out. With no usable normal the solver returns the
// point-to-point solution. Minimisation: the closed-form point-to-point solution (paper 003
// Eq. (5)-(6)) is the start of at most `gauss_newton_steps` Gauss-Newton steps on E(T).

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <optional>
#include <span>

#include "rangenav/core/types.hpp"
#include "rangenav/registration/correspondence.hpp"
#include "rangenav/registration/point_to_point_solver.hpp"

namespace rangenav {

template <std::floating_point Scalar = double>
struct PointToLineSolver {
  static constexpr std::size_t min_pairs = 3;

  /// Unit model normals indexed by model index (zero = no line); must outlive solve().
  std::span<const Point<2, Scalar>> model_normals{};
  int gauss_newton_steps = 5;
  /// Steps stop when the update moves less than this (m, and rad).
  Scalar step_epsilon = Scalar(1e-7);
  /// Levenberg damping, relative to the mean diagonal of the normal equations.
  Scalar damping = Scalar(1e-6);

  [[nodiscard]] std::optional<Transform<2, Scalar>> solve(
      std::span<const Correspondence<2, Scalar>> pairs) const {
    if (pairs.size() < min_pairs) return std::nullopt;
    const std::optional<Transform<2, Scalar>> start = PointToPointSolver<2, Scalar>{}.solve(pairs);
    if (!start) return start;
    Scalar x = start->translation().x(), y = start->translation().y();
    Scalar theta = std::atan2(start->linear()(1, 0), start->linear()(0, 0));
    using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;
    using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
    for (int step = 0; step < gauss_newton_steps; ++step) {
      Matrix3 h = Matrix3::Zero();
      Vector3 b = Vector3::Zero();
      std::size_t rows = 0;
      const Scalar c = std::cos(theta), s = std::sin(theta);
      for (const auto& pr : pairs) {
        if (pr.model_index >= model_normals.size()) continue;
        const Point<2, Scalar>& n = model_normals[pr.model_index];
        if (n.x() == Scalar(0) && n.y() == Scalar(0)) continue;
        const Point<2, Scalar> rd(c * pr.data.x() - s * pr.data.y(),
                                  s * pr.data.x() + c * pr.data.y());
        const Scalar r = n.x() * (rd.x() + x - pr.model.x()) + n.y() * (rd.y() + y - pr.model.y());
        const Vector3 j(n.x(), n.y(), n.y() * rd.x() - n.x() * rd.y());
        h.noalias() += j * j.transpose();
        b.noalias() += j * r;
        ++rows;
      }
      if (rows < min_pairs) return start;  // no lines: the point-to-point solution
      // A little damping: along a direction no line constrains (a corridor's axis) the step is
      // ~0, so the point-to-point start is kept there.
      h.diagonal().array() += damping * h.trace() / Scalar(3) + std::numeric_limits<Scalar>::min();
      const Vector3 delta = -h.ldlt().solve(b);
      if (!delta.allFinite()) break;
      x += delta(0);
      y += delta(1);
      theta += delta(2);
      if (delta.norm() < step_epsilon) break;
    }
    Transform<2, Scalar> t = Transform<2, Scalar>::Identity();
    t.linear() = Eigen::Rotation2D<Scalar>(theta).toRotationMatrix();
    t.translation() = Point<2, Scalar>(x, y);
    if (!t.matrix().allFinite()) return start;
    return t;
  }
};

}  // namespace rangenav
