#pragma once
// Robust kernels (M-estimators) for least squares: the one definition shared by ICP and the pose
// graph.
//
// A kernel ρ replaces the squared residual s = eᵀ Ω e of a term by ρ(s) (Triggs et al., "Bundle
// Adjustment — A Modern Synthesis", 2000, §3.3; the same convention as Ceres' LossFunction and
// g2o's RobustKernel). Minimising Σ ρ(s_i) by iteratively re-weighted least squares gives each term
// the weight w = ρ'(s): Gauss-Newton then solves Σ w Jᵀ Ω J δ = −Σ w Jᵀ Ω e. With δ the kernel's
// scale (a residual, not a squared one):
//
//   none           ρ(s) = s                          w = 1
//   Huber          ρ(s) = s             (s ≤ δ²)     w = 1
//                       = 2δ√s − δ²     (s > δ²)     w = δ / √s
//   Cauchy         ρ(s) = δ² log(1 + s/δ²)           w = 1 / (1 + s/δ²)
//   Geman-McClure  ρ(s) = δ² s / (δ² + s)            w = δ⁴ / (δ² + s)²
//
// Huber is convex (a unique minimum, outliers pull linearly); Cauchy and Geman-McClure are not
// (outliers lose their pull entirely, at the price of local minima): use them from a good
// initial guess.

#include <cmath>
#include <concepts>
#include <string_view>

#include "rangenav/core/error.hpp"

namespace rangenav {

/// Which M-estimator a RobustKernel applies.
enum class RobustKernelType {
  none,          ///< plain least squares
  huber,         ///< quadratic inside δ, linear outside (convex)
  cauchy,        ///< logarithmic growth; outliers' weight falls as 1/s
  geman_mcclure  ///< bounded cost; outliers' weight falls as 1/s²
};

/// The kernel's name: "none", "huber", "cauchy" or "geman_mcclure".
[[nodiscard]] constexpr std::string_view to_string(RobustKernelType type) {
  switch (type) {
    case RobustKernelType::none:
      return "none";
    case RobustKernelType::huber:
      return "huber";
    case RobustKernelType::cauchy:
      return "cauchy";
    case RobustKernelType::geman_mcclure:
      return "geman_mcclure";
  }
  return "unknown";
}

/// A robust kernel ρ of a squared residual s and its IRLS weight ρ'(s) (formulas above).
template <std::floating_point Scalar = double>
struct RobustKernel {
  /// Which M-estimator this is.
  RobustKernelType type = RobustKernelType::none;
  /// The scale δ: the residual (in the units of √s) where the kernel departs from least squares.
  Scalar delta = Scalar(1);

  /// A Huber kernel of scale `d`.
  [[nodiscard]] static constexpr RobustKernel huber(Scalar d) {
    return {RobustKernelType::huber, d};
  }
  /// A Cauchy kernel of scale `d`.
  [[nodiscard]] static constexpr RobustKernel cauchy(Scalar d) {
    return {RobustKernelType::cauchy, d};
  }
  /// A Geman-McClure kernel of scale `d`.
  [[nodiscard]] static constexpr RobustKernel geman_mcclure(Scalar d) {
    return {RobustKernelType::geman_mcclure, d};
  }

  /// Throws invalid_argument unless δ is finite and > 0 (checked only for a kernel other than
  /// none).
  void validate(std::string_view where = "RobustKernel") const {
    if (type != RobustKernelType::none) detail::require_positive(where, "delta", delta);
  }

  /// ρ(s) for a squared residual s ≥ 0.
  [[nodiscard]] Scalar rho(Scalar s) const {
    const Scalar d2 = delta * delta;
    switch (type) {
      case RobustKernelType::none:
        return s;
      case RobustKernelType::huber:
        return s <= d2 ? s : Scalar(2) * delta * std::sqrt(s) - d2;
      case RobustKernelType::cauchy:
        return d2 * std::log1p(s / d2);
      case RobustKernelType::geman_mcclure:
        return d2 * s / (d2 + s);
    }
    return s;
  }

  /// The IRLS weight ρ'(s) in (0, 1] for a squared residual s ≥ 0.
  [[nodiscard]] Scalar weight(Scalar s) const {
    const Scalar d2 = delta * delta;
    switch (type) {
      case RobustKernelType::none:
        return Scalar(1);
      case RobustKernelType::huber:
        return s <= d2 ? Scalar(1) : delta / std::sqrt(s);
      case RobustKernelType::cauchy:
        return Scalar(1) / (Scalar(1) + s / d2);
      case RobustKernelType::geman_mcclure: {
        const Scalar t = d2 / (d2 + s);
        return t * t;
      }
    }
    return Scalar(1);
  }
};

}  // namespace rangenav
