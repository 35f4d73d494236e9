#pragma once
// Angles in radians, normalised to (-pi, pi].

#include <cmath>
#include <concepts>
#include <numbers>

namespace rangenav {

/// Wraps an angle to (-pi, pi]. Non-finite input is returned unchanged.
template <std::floating_point Scalar>
[[nodiscard]] Scalar normalize_angle(Scalar angle) {
  constexpr Scalar pi = std::numbers::pi_v<Scalar>;
  constexpr Scalar two_pi = 2 * std::numbers::pi_v<Scalar>;
  if (!std::isfinite(angle)) return angle;
  if (angle > -pi && angle <= pi) return angle;
  Scalar wrapped = std::fmod(angle + pi, two_pi);  // in (-2pi, 2pi)
  if (wrapped <= Scalar(0)) wrapped += two_pi;     // in (0, 2pi]
  return wrapped - pi;
}

/// Signed smallest difference a - b, in (-pi, pi].
template <std::floating_point Scalar>
[[nodiscard]] Scalar angle_difference(Scalar a, Scalar b) {
  return normalize_angle(a - b);
}

template <std::floating_point Scalar>
/// Degrees to radians.
[[nodiscard]] constexpr Scalar deg_to_rad(Scalar degrees) {
  return degrees * std::numbers::pi_v<Scalar> / Scalar(180);
}

template <std::floating_point Scalar>
/// Radians to degrees.
[[nodiscard]] constexpr Scalar rad_to_deg(Scalar radians) {
  return radians * Scalar(180) / std::numbers::pi_v<Scalar>;
}

}  // namespace rangenav
