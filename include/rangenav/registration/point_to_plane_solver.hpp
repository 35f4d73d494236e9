#pragma once
// Point-to-plane solver, one code path for 2D (a line is the plane of dimension 1) and 3D (Chen &
// Medioni 1992; the linearised least squares of K.-L. Low, "Linear Least-Squares Optimization for
// Point-to-Plane ICP Surface Registration", TR04-004, UNC Chapel Hill 2004): the rigid transform
// T minimising
//   E(T) = sum_i rho( (n_i . (T d_i - m_i))^2 )
// over the pairs whose model point has a unit normal n_i, with rho a robust kernel (none: plain
// least squares). A data point on a wall may slide along it, so a sparse model (a SparsePointMap
// whose points are eps_D apart) does not pull the data towards its sample positions, and a
// large planar surface filling the view does not drag the alignment along itself the way
// point-to-point pairs do (Eq. (1) of paper 000). An option beyond the papers, which use
// point-to-point: the solver of the 2D laser setup (LaserIcp) and of GeometricMapper.
//
// Minimisation: Gauss-Newton from the ICP's current transform (Low 2004, Eq. 6-8, in the tangent
// space of transform_solver.hpp). With n' = R^T n the normal in the data frame, the pair's row is
// J = [n'^T, n'^T S(d)] (in 3D, n'^T S(d) = (d x n')^T), its residual n . (T d - m). Directions
// that no plane constrains (the axis of a corridor; x, y and yaw over a lone floor) keep their
// start (the truncated step of gauss_newton.hpp) unless a pose prior constrains them.
//
// The model normals are a span indexed by Correspondence::model_index (estimate_normals() of the
// model's search structure, or SparsePointMap::normals()); a zero normal marks a point without a
// plane and its pair is left out. With fewer than dof usable pairs the solver falls back to the
// point-to-point solution.

#include <Eigen/Core>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <span>

#include "rangenav/core/robust_kernel.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/registration/correspondence.hpp"
#include "rangenav/registration/gauss_newton_solver.hpp"
#include "rangenav/registration/transform_solver.hpp"

namespace rangenav {

namespace detail {

/// Adds the point-to-plane term of one pair with model normal n (model frame) at the transform
/// whose point map is `apply` and inverse rotation `rt`: residual n . (T d - m), row
/// [n'^T, n'^T S(d)] with n' = R^T n.
template <int D, class Scalar, class Apply>
void add_point_to_plane(NormalEquations<D, Scalar>& eq, const RobustKernel<Scalar>& kernel,
                        const Point<D, Scalar>& n, const Correspondence<D, Scalar>& pr,
                        const Apply& apply, const Eigen::Matrix<Scalar, D, D>& rt) {
  const Point<D, Scalar> n_data = rt * n;
  Eigen::Matrix<Scalar, 1, pose_dof<D>> j;
  j.template leftCols<D>() = n_data.transpose();
  j.template rightCols<pose_dof<D> - D>() = n_data.transpose() * rotation_jacobian<Scalar>(pr.data);
  const Eigen::Matrix<Scalar, 1, 1> r(n.dot(apply(pr.data) - pr.model));
  add_residual<D, Scalar, 1>(eq, kernel, j, r, Eigen::Matrix<Scalar, 1, 1>::Identity());
}

}  // namespace detail

/// Point-to-plane (2D: point-to-line) solver (see the file comment). Models ModelNormalSolver;
/// kernel, steps and the rest of its settings are GaussNewtonSolver's.
template <int D, std::floating_point Scalar = double>
struct PointToPlaneSolver : GaussNewtonSolver<PointToPlaneSolver<D, Scalar>, D, Scalar, 3> {
  static_assert(D == 2 || D == 3, "PointToPlaneSolver: dimension must be 2 or 3");
  static constexpr std::size_t min_pairs = 3;  ///< fewer pairs do not determine a transform

  /// Unit model normals indexed by model index (zero = no plane); must outlive solve().
  std::span<const Point<D, Scalar>> model_normals{};

 private:
  friend GaussNewtonSolver<PointToPlaneSolver, D, Scalar, 3>;
  struct Residual {
    const PointToPlaneSolver* solver;
    template <class Apply>
    bool operator()(const Correspondence<D, Scalar>& pr, const Apply& apply,
                    const Eigen::Matrix<Scalar, D, D>& rt, NormalEquations<D, Scalar>& eq) const {
      const auto& normals = solver->model_normals;
      if (pr.model_index >= normals.size()) return false;
      const Point<D, Scalar>& n = normals[pr.model_index];
      if (n.isZero(0)) return false;
      detail::add_point_to_plane<D, Scalar>(eq, solver->kernel, n, pr, apply, rt);
      return true;
    }
  };
};

}  // namespace rangenav
