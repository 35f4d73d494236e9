#pragma once
// Generalized-ICP solver (Segal, Haehnel & Thrun, "Generalized-ICP", RSS 2009): distribution-to-
// distribution matching, generic over D. Each point carries the covariance of the surface around
// it (estimate_covariances() in normals.hpp: C = V diag(eps, 1, 1) V^T, Sec. III-B of the paper),
// and a pair's residual r_i = T d_i - m_i is weighted by the inverse of the covariance of that
// difference (Eq. (2) of the paper):
//   E(T) = sum_i rho( s_i ),   s_i = 2 eps r_i^T (C_i^model + R C_i^data R^T)^-1 r_i.
// Two parallel planes give s_i ~ (n . r_i)^2: the plane-to-plane distance in metres, which the
// factor 2 eps (a constant, so the minimiser is the paper's) makes the quantity the robust kernel's
// delta and the residual variance of the information are expressed in (one measurement per pair).
//
// Minimisation: Gauss-Newton from the ICP's current transform in the tangent space of
// transform_solver.hpp, with the weight frozen at the linearisation point as in the paper's
// derivation. In the data frame, with W' = 2 eps (R^T C^model R + C^data)^-1 and
// r' = R^T r, the pair's terms are A^T W' A and A^T W' r', A = [I | S(d)].
//
// Covariances are spans indexed by Correspondence::model_index and ::data_index (the data index
// is the data cloud's, the one ICP reports); a pair whose index has no covariance is left out.
// With fewer than dof usable pairs the solver falls back to the point-to-point solution.

#include <Eigen/Core>
#include <Eigen/LU>
#include <concepts>
#include <cstddef>
#include <span>

#include "rangenav/core/robust_kernel.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/registration/correspondence.hpp"
#include "rangenav/registration/gauss_newton_solver.hpp"
#include "rangenav/registration/transform_solver.hpp"

namespace rangenav {

/// Generalized-ICP solver (see the file comment). Models CovarianceSolver; kernel, steps and the
/// rest of its settings are GaussNewtonSolver's.
template <int D, std::floating_point Scalar = double>
struct GicpSolver : GaussNewtonSolver<GicpSolver<D, Scalar>, D, Scalar, 1> {
  static_assert(D == 2 || D == 3, "GicpSolver: dimension must be 2 or 3");
  static constexpr std::size_t min_pairs = 3;  ///< fewer pairs do not determine a transform
  using covariance_type = Eigen::Matrix<Scalar, D, D>;  ///< a point's covariance

  /// Covariances of the model points, by model index; must outlive solve().
  std::span<const covariance_type> model_covariances{};
  /// Covariances of the data points, by data index (of the cloud given to ICP).
  std::span<const covariance_type> data_covariances{};
  /// The normal-direction variance eps of the regularised covariances (the value given to
  /// estimate_covariances): scales the residual into metres (see the file comment).
  Scalar epsilon = Scalar(1e-3);

 private:
  friend GaussNewtonSolver<GicpSolver, D, Scalar, 1>;
  struct Residual {
    const GicpSolver* solver;
    template <class Apply>
    bool operator()(const Correspondence<D, Scalar>& pr, const Apply& apply,
                    const Eigen::Matrix<Scalar, D, D>& rt, NormalEquations<D, Scalar>& eq) const {
      const auto& cm = solver->model_covariances;
      const auto& cd = solver->data_covariances;
      if (pr.model_index >= cm.size() || pr.data_index >= cd.size()) return false;
      const covariance_type combined = rt * cm[pr.model_index] * rt.transpose() + cd[pr.data_index];
      const covariance_type w = (2 * solver->epsilon) * combined.inverse();
      const Point<D, Scalar> r = rt * (apply(pr.data) - pr.model);
      // One measurement per pair: on a surface W' has rank ~1 (eps along it), so the squared
      // residual is the plane-to-plane distance, not a sum of D independent squares.
      detail::add_point_residual<D, Scalar>(eq, solver->kernel,
                                            detail::rotation_jacobian<Scalar>(pr.data), r, w, 1);
      return true;
    }
  };
};

}  // namespace rangenav
