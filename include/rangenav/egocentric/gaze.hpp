#pragma once
// Gaze control for a camera on a pan-tilt unit (3D-perception paper 002 §7.4, Eq. 16): the look-at
// point g in the robot frame follows the robot's motion (v_x, v_y, ω) so that a narrow-field
// time-of-flight camera sees the obstacles in the movement direction:
//   g = α R_z(β ω) (d_min / ||v||) (v_x, v_y, 0)^T + γ (v_x, v_y, 0)^T.              Eq. (16)
// The first term is the point at the smallest perceivable distance d_min along the direction of
// travel, turned into the turn by β ω; the second pushes the gaze farther ahead the faster the
// robot drives (γ >= 1 prefers obstacles farther away, as in the paper). The equation's middle
// vector is garbled in the available text; this is its reading as a direction of travel scaled to
// d_min. When the robot does not translate (||v|| = 0) the direction of travel is taken as the
// robot's heading, so turning on the spot still looks into the turn.

#include <cmath>
#include <concepts>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// Parameters of the look-at point of Eq. (16) of paper 002.
template <std::floating_point Scalar = double>
struct GazeParams {
  Scalar alpha{1};    ///< α, scale of the d_min term (the paper does not scale: 1)
  Scalar beta{1};     ///< β, s: how far ahead in time the turn is anticipated
  Scalar gamma{1};    ///< γ, s: offset along the velocity (>= 1 in the paper)
  Scalar d_min{0.5};  ///< m, smallest distance the camera can see (its lowest tilt)

  /// Throws invalid_argument for a non-finite parameter or a negative d_min.
  void validate(std::string_view where = "GazeParams") const {
    detail::require_finite(where, "alpha", alpha);
    detail::require_finite(where, "beta", beta);
    detail::require_finite(where, "gamma", gamma);
    detail::require_non_negative(where, "d_min", d_min);
  }
};

/// The look-at point of Eq. (16) in the robot frame (g_z = 0: the floor).
template <std::floating_point Scalar>
[[nodiscard]] Point<3, Scalar> gaze_target(Scalar v_x, Scalar v_y, Scalar omega,
                                           const GazeParams<Scalar>& params = {}) {
  detail::require_finite("gaze_target", "v_x", v_x);
  detail::require_finite("gaze_target", "v_y", v_y);
  detail::require_finite("gaze_target", "omega", omega);
  params.validate("gaze_target");
  const Scalar speed = std::hypot(v_x, v_y);
  const Point<2, Scalar> dir =
      speed > Scalar(0) ? Point<2, Scalar>(v_x / speed, v_y / speed) : Point<2, Scalar>(1, 0);
  const Scalar a = params.beta * omega;
  const Scalar c = std::cos(a), s = std::sin(a);
  const Point<2, Scalar> near =
      params.alpha * params.d_min *
      Point<2, Scalar>(c * dir.x() - s * dir.y(), s * dir.x() + c * dir.y());
  return {near.x() + params.gamma * v_x, near.y() + params.gamma * v_y, Scalar(0)};
}

/// Pan (about z) and tilt (positive looks down) angles that point a camera at `camera` (robot
/// frame) towards `target`.
template <std::floating_point Scalar>
struct PanTilt {
  Scalar pan{0};   ///< rad about the camera mount's z axis, positive turns left
  Scalar tilt{0};  ///< rad, positive looks down
};

/// The pan and tilt that point a camera at `camera` (robot frame) towards `target`.
template <std::floating_point Scalar>
[[nodiscard]] PanTilt<Scalar> look_at(const Point<3, Scalar>& camera,
                                      const Point<3, Scalar>& target) {
  const Point<3, Scalar> d = target - camera;
  return {std::atan2(d.y(), d.x()), std::atan2(-d.z(), std::hypot(d.x(), d.y()))};
}

}  // namespace rangenav
