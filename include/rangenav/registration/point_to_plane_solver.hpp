#pragma once
// Point-to-plane solver for 3D ICP (Chen & Medioni 1992; the linearised least squares of
// K.-L. Low, "Linear Least-Squares Optimization for Point-to-Plane ICP Surface Registration",
// TR04-004, UNC Chapel Hill 2004): the rigid transform T minimising
//   E(T) = sum_i ( n_i . (T d_i - m_i) )^2
// over the pairs whose model point has a normal n_i (a unit normal of the model surface at m_i).
// A data point on a plane may slide within the plane, so a sparse model (a SparsePointMap whose
// points are eps_D apart) does not pull the data towards its sample positions, and a large
// planar surface (a kitchen front filling the view) does not drag the alignment along itself the
// way point-to-point pairs do (Eq. (1) of paper 000). An option beyond paper 004, which uses
// point-to-point ICP; it is the solver of GeometricMapper's registration.
//
// Minimisation (Low 2004, Eq. 6-8): with s_i = T d_i about the centroid c of the s_i and the
// rotation linearised for small angles w (R ~ I + [w]x),
//   n_i . (c + R (s_i - c) + t - m_i) ~ n_i . (s_i - m_i) + ((s_i - c) x n_i) . w + n_i . t,
// so each pair gives the row a_i = [(s_i - c) x n_i, n_i] and the 6x6 normal equations
// (sum a_i a_i^T) x = -sum a_i r_i are solved in closed form (LDLT); the exact rotation of w is
// applied and the step repeated (Gauss-Newton) at most `gauss_newton_steps` times. Directions
// that no plane constrains (the axis of a corridor; x, y and yaw over a lone floor) stay where
// they started: the step is solved only in the eigenvectors of the normal equations whose
// eigenvalue is at least `degeneracy_ratio` of the largest (rotations scaled by the points' RMS
// radius, so the ratio is unit-free), so the noise of the normals does not steer them.
//
// The model normals are a span indexed by Correspondence::model_index (SparsePointMap::normals()
// with SparsePointMapParams::normals set); a zero normal marks a point without a plane and its
// pair is left out. The start is the current ICP transform when the ICP passes it (the two-
// argument solve(), which BasicIcp calls when the solver has it), else the closed-form
// point-to-point solution. With fewer than 6 usable pairs the solver returns the point-to-point
// solution.

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
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
struct PointToPlaneSolver {
  static constexpr std::size_t min_pairs = 3;
  /// Pairs with a normal needed for the 6-DOF step.
  static constexpr std::size_t min_plane_pairs = 6;

  /// Unit model normals indexed by model index (zero = no plane); must outlive solve().
  std::span<const Point<3, Scalar>> model_normals{};
  int gauss_newton_steps = 3;
  /// Steps stop when the update moves less than this (m, and rad).
  Scalar step_epsilon = Scalar(1e-7);
  /// Directions of the normal equations whose eigenvalue is below this fraction of the
  /// largest are left unchanged (see refine()).
  Scalar degeneracy_ratio = Scalar(0.01);

  /// Starts from the closed-form point-to-point solution.
  [[nodiscard]] std::optional<Transform<3, Scalar>> solve(
      std::span<const Correspondence<3, Scalar>> pairs) const {
    if (pairs.size() < min_pairs) return std::nullopt;
    const std::optional<Transform<3, Scalar>> start = PointToPointSolver<3, Scalar>{}.solve(pairs);
    if (!start) return start;
    return refine(pairs, *start).value_or(*start);
  }

  /// Starts from `current` (the ICP's transform of this iteration); falls back to the
  /// point-to-point solution when too few pairs have a normal.
  [[nodiscard]] std::optional<Transform<3, Scalar>> solve(
      std::span<const Correspondence<3, Scalar>> pairs, const Transform<3, Scalar>& current) const {
    if (pairs.size() < min_pairs) return std::nullopt;
    if (auto t = refine(pairs, current)) return t;
    return PointToPointSolver<3, Scalar>{}.solve(pairs);
  }

 private:
  using Matrix6 = Eigen::Matrix<Scalar, 6, 6>;
  using Vector6 = Eigen::Matrix<Scalar, 6, 1>;
  using Vector3 = Point<3, Scalar>;

  [[nodiscard]] bool has_normal(const Correspondence<3, Scalar>& pr) const {
    return pr.model_index < model_normals.size() && !model_normals[pr.model_index].isZero(0);
  }

  // Gauss-Newton on E(T) from `t`; nothing when fewer than min_plane_pairs pairs have a normal.
  [[nodiscard]] std::optional<Transform<3, Scalar>> refine(
      std::span<const Correspondence<3, Scalar>> pairs, Transform<3, Scalar> t) const {
    for (int step = 0; step < gauss_newton_steps; ++step) {
      // One pass over the pairs: with u_i = s_i x n_i, the row of Low's Eq. (6-8),
      //   a_i = [(s_i - c) x n_i / L, n_i] = M g_i,  g_i = [u_i, n_i],
      //   M = [[I / L, -[c]x / L], [0, I]],
      // is linear in g_i, so sum a_i a_i^T = M (sum g_i g_i^T) M^T and sum a_i r_i =
      // M sum g_i r_i; the centroid c and the RMS radius L come from the sums of s_i and |s_i|^2
      // of the same pass. The s_i are taken relative to the first one (o) to keep those sums
      // well conditioned far from the origin.
      Matrix6 g_g = Matrix6::Zero();
      Vector6 g_r = Vector6::Zero();
      Vector3 sum = Vector3::Zero();
      Scalar sum_sq = 0;
      std::size_t rows = 0;
      Vector3 o = Vector3::Zero();
      const detail::AffineApply<3, Scalar> apply(t);
      for (const auto& pr : pairs) {
        if (!has_normal(pr)) continue;
        const Vector3& n = model_normals[pr.model_index];
        const Vector3 s_world = apply(pr.data);
        if (rows == 0) o = s_world;
        const Vector3 s = s_world - o;
        Vector6 g;
        g.template head<3>() = s.cross(n);
        g.template tail<3>() = n;
        g_g.noalias() += g * g.transpose();
        g_r.noalias() += g * n.dot(s_world - pr.model);
        sum += s;
        sum_sq += s.squaredNorm();
        ++rows;
      }
      if (rows < min_plane_pairs) return step == 0 ? std::nullopt : std::optional(t);
      const Vector3 c_rel = sum / static_cast<Scalar>(rows);
      const Vector3 c = c_rel + o;
      // Rotations scaled by the RMS radius L of the points about c, so that the eigenvalues of
      // the normal equations are unit-free (as in BasicIcp's degeneracy check).
      const Scalar radius =
          std::sqrt(std::max(Scalar(0), sum_sq / static_cast<Scalar>(rows) - c_rel.squaredNorm()));
      if (!(radius > Scalar(0))) break;
      Matrix6 m = Matrix6::Identity();
      m.template topLeftCorner<3, 3>() /= radius;
      Eigen::Matrix<Scalar, 3, 3> c_cross;
      c_cross << 0, -c_rel.z(), c_rel.y(), c_rel.z(), 0, -c_rel.x(), -c_rel.y(), c_rel.x(), 0;
      m.template topRightCorner<3, 3>() = -c_cross / radius;
      const Matrix6 h = m * g_g * m.transpose();
      const Vector6 b = m * g_r;
      // Truncated solution: only along eigenvectors whose eigenvalue is at least
      // `degeneracy_ratio` times the largest; a direction no plane constrains (the axis of a
      // corridor, the in-plane motions over a lone floor) keeps the start's value instead of
      // following the noise of the normals (Zhang, Kaess & Singh, ICRA 2016).
      Eigen::SelfAdjointEigenSolver<Matrix6> eig(h);
      const Vector6& values = eig.eigenvalues();
      if (!(values(5) > Scalar(0))) break;
      Vector6 x = Vector6::Zero();
      for (int k = 0; k < 6; ++k)
        if (values(k) >= degeneracy_ratio * values(5)) {
          const Vector6 v = eig.eigenvectors().col(k);
          x -= v * (v.dot(b) / values(k));
        }
      if (!x.allFinite()) break;
      x.template head<3>() /= radius;
      const Vector3 w = x.template head<3>();
      const Scalar angle = w.norm();
      const Eigen::Matrix<Scalar, 3, 3> r =
          angle > Scalar(0) ? Eigen::AngleAxis<Scalar>(angle, w / angle).toRotationMatrix()
                            : Eigen::Matrix<Scalar, 3, 3>::Identity();
      // s' = c + R (s - c) + dt
      Transform<3, Scalar> delta = Transform<3, Scalar>::Identity();
      delta.linear() = r;
      delta.translation() = c - r * c + x.template tail<3>();
      t = delta * t;
      if (x.norm() < step_epsilon) break;
    }
    if (!t.matrix().allFinite()) return std::nullopt;
    return t;
  }
};

}  // namespace rangenav
