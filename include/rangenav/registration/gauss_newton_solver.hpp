#pragma once
// What the Gauss-Newton solvers of ICP (point-to-plane, GICP) share: their settings, solve() and
// linearize(). A solver derives from GaussNewtonSolver<Self, D, Scalar, steps>, has a
// `static constexpr std::size_t min_pairs`, and defines how one pair adds its terms to the
// normal equations:
//   struct Residual {
//     const Self* solver;
//     template <class Apply>
//     bool operator()(const Correspondence<D, Scalar>& pair, const Apply& apply,
//                     const Eigen::Matrix<Scalar, D, D>& rt, NormalEquations<D, Scalar>& eq) const;
//   };
// apply(p) is T p at the linearisation point T, rt its rotation transposed; the operator adds the
// pair's J^T W J, J^T W r, cost and counts to eq in the tangent space of transform_solver.hpp
// (a point's Jacobian is built from A(p) = [I | S(p)]), and returns false to leave the pair out.
// A private Residual needs `friend GaussNewtonSolver<Self, D, Scalar, steps>;`.
// solve() runs the Gauss-Newton steps from the ICP's current transform, with the pose prior and
// the degeneracy handling of gauss_newton.hpp; where they cannot start (fewer usable pairs than
// degrees of freedom, or an undetermined first step) it falls back to the point-to-point solution
// of the same pairs.

#include <concepts>
#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include "rangenav/core/robust_kernel.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/registration/correspondence.hpp"
#include "rangenav/registration/gauss_newton.hpp"
#include "rangenav/registration/point_to_point_solver.hpp"
#include "rangenav/registration/transform_solver.hpp"

namespace rangenav {

/// Settings, solve() and linearize() of the Gauss-Newton solver `Self` (see the file comment);
/// `DefaultSteps` is its default number of steps per ICP iteration.
template <class Self, int D, std::floating_point Scalar, int DefaultSteps>
struct GaussNewtonSolver {
  /// Robust kernel on a pair's squared residual (m^2: the squared point-to-plane distance, GICP's
  /// s_i): its delta is a distance.
  RobustKernel<Scalar> kernel{};
  /// Gauss-Newton steps per ICP iteration (on the same pairs).
  int gauss_newton_steps = DefaultSteps;
  /// Steps stop when the update moves less than this (m, and rad).
  Scalar step_epsilon = Scalar(1e-7);
  /// Directions of the normal equations whose eigenvalue is below this fraction of the
  /// largest are left to the prior or unchanged (transform_solver.hpp, gauss_newton.hpp).
  Scalar degeneracy_ratio = static_cast<Scalar>(default_degeneracy_ratio);

  /// The next transform of an ICP iteration, from ctx.current (see the file comment).
  [[nodiscard]] std::optional<Transform<D, Scalar>> solve(
      std::span<const Correspondence<D, Scalar>> pairs, const SolveContext<D, Scalar>& ctx) const {
    if (pairs.size() < Self::min_pairs) return std::nullopt;
    if (auto t =
            detail::gauss_newton<D, Scalar>(pairs, ctx.current, ctx, gauss_newton_steps,
                                            step_epsilon, degeneracy_ratio, scratch_, residual()))
      return t;
    PointToPointSolver<D, Scalar> fallback;
    fallback.kernel = kernel;
    return fallback.solve(pairs, ctx);
  }

  /// The normal equations of the solver's cost at t.
  [[nodiscard]] NormalEquations<D, Scalar> linearize(
      std::span<const Correspondence<D, Scalar>> pairs, const Transform<D, Scalar>& t,
      int num_threads) const {
    return detail::linearize_at<D, Scalar>(pairs, t, num_threads, scratch_, residual());
  }

 private:
  // Self is incomplete where this class is instantiated: the type is deduced in the body.
  [[nodiscard]] auto residual() const {
    return typename Self::Residual{static_cast<const Self*>(this)};
  }

  mutable std::vector<detail::Linearization<D, Scalar>> scratch_;
};

}  // namespace rangenav
