#pragma once
// Indiveri's globally stable pose controller for the final approach (paper 003 §2.2.3; paper 000
// §5 uses it to reach the target pose after path tracking).
//
// With the robot at (x_G, y_G, phi) in the target-centred frame:
//     e = sqrt(x_G^2 + y_G^2),  theta = atan2(-y_G, -x_G),  alpha = theta - phi,
//     v = gamma e,   c = sin(alpha)/e + h theta/e sin(alpha)/alpha + beta alpha/e,   omega = v c,
// with gamma > 0, h > 1 and 2 < beta < h + 1. The robot only ever drives forward (v >= 0): the
// trajectory has no cusps. Speed limits scale v and omega together, which keeps the curvature c
// and therefore the path of the closed loop.

#include <algorithm>
#include <cmath>
#include <string>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// Gains and limits of Indiveri's pose controller (paper 003 §2.2.3).
struct IndiveriPoseControllerParams {
  double gamma = 0.5;                ///< v = gamma e (1/s), > 0
  double h = 2.0;                    ///< > 1
  double beta = 2.5;                 ///< 2 < beta < h + 1
  double max_speed = 0.3;            ///< |v| limit (m/s)
  double max_angular_speed = 1.5;    ///< |omega| limit (rad/s)
  double position_tolerance = 0.02;  ///< reached: e below this (m) ...
  double heading_tolerance = 0.035;  ///< ... and |phi| below this (rad, 2 degrees)

  /// Throws invalid_argument unless gamma > 0, h > 1, 2 < beta < h + 1 and the limits and
  /// tolerances are positive.
  void validate(std::string_view where) const {
    detail::require_positive(where, "params.gamma", gamma);
    detail::require_finite(where, "params.h", h);
    if (!(h > 1.0)) detail::throw_invalid_argument(where, "params.h", h, "must be > 1");
    detail::require_finite(where, "params.beta", beta);
    if (!(beta > 2.0 && beta < h + 1.0))
      detail::throw_invalid_argument(
          where, "params.beta", beta,
          "must satisfy 2 < beta < h + 1 = " + detail::format_value(h + 1));
    detail::require_positive(where, "params.max_speed", max_speed);
    detail::require_positive(where, "params.max_angular_speed", max_angular_speed);
    detail::require_non_negative(where, "params.position_tolerance", position_tolerance);
    detail::require_non_negative(where, "params.heading_tolerance", heading_tolerance);
  }
};

/// One step of the pose controller: the command and the polar coordinates it came from.
struct PoseControlCommand {
  double v{0.0};        ///< linear velocity (m/s), never negative
  double omega{0.0};    ///< angular velocity (rad/s)
  double e{0.0};        ///< distance to the target (m)
  double theta{0.0};    ///< bearing of the target seen from the robot, in the target frame (rad)
  double alpha{0.0};    ///< theta - phi: the target's bearing relative to the robot's heading
  double phi{0.0};      ///< the robot's heading in the target frame (rad)
  bool reached{false};  ///< within position_tolerance and heading_tolerance
};

/// Drives a unicycle to a target pose forward only, without cusps (paper 003 §2.2.3):
/// v = gamma e, curvature c = sin(alpha) / e + h theta / e sin(alpha) / alpha + beta alpha / e.
class IndiveriPoseController {
 public:
  /// A controller with these parameters; throws invalid_argument for invalid ones.
  explicit IndiveriPoseController(const IndiveriPoseControllerParams& params = {})
      : params_(params) {
    params_.validate("IndiveriPoseController");
  }

  /// The parameters.
  [[nodiscard]] const IndiveriPoseControllerParams& params() const { return params_; }

  /// One control step for the robot at `pose` driving to `target` (both in the map frame).
  [[nodiscard]] PoseControlCommand step(const Pose2d& pose, const Pose2d& target) const {
    constexpr std::string_view where = "IndiveriPoseController::step";
    detail::require_finite(where, "pose.x", pose.x);
    detail::require_finite(where, "pose.y", pose.y);
    detail::require_finite(where, "pose.theta", pose.theta);
    detail::require_finite(where, "target.x", target.x);
    detail::require_finite(where, "target.y", target.y);
    detail::require_finite(where, "target.theta", target.theta);
    const Pose2d g = relative(target, pose);  // (x_G, y_G, phi)
    PoseControlCommand cmd;
    cmd.e = std::hypot(g.x, g.y);
    cmd.phi = normalize_angle(g.theta);
    if (cmd.e < params_.position_tolerance && std::abs(cmd.phi) < params_.heading_tolerance) {
      cmd.reached = true;
      return cmd;
    }
    // On the target's position but turned, theta = atan2(-y_G, -x_G) is undefined (and below a
    // nanometre it is the angle of rounding errors, while v dt = gamma e dt no longer moves the
    // pose: the loop would stall wherever e c = 0). There theta = 0 is taken, the limit of
    // approaching along the target's x axis: alpha = -phi, v = 0 and
    // omega = gamma e c = -gamma (sin(phi) + beta phi), a turn on the spot toward phi = 0
    // (sin(phi) + beta phi has the sign of phi on (-pi, pi]).
    constexpr double unresolved = 1e-9;  // m
    const bool on_spot = cmd.e < unresolved;
    cmd.theta = on_spot ? 0.0 : std::atan2(-g.y, -g.x);
    cmd.alpha = normalize_angle(cmd.theta - cmd.phi);
    const double sinc = std::abs(cmd.alpha) < 1e-9 ? 1.0 : std::sin(cmd.alpha) / cmd.alpha;
    // e c = sin(alpha) + h theta sin(alpha)/alpha + beta alpha: finite as e -> 0.
    const double e_c =
        std::sin(cmd.alpha) + params_.h * cmd.theta * sinc + params_.beta * cmd.alpha;
    double v = on_spot ? 0.0 : params_.gamma * cmd.e;
    double omega = params_.gamma * e_c;  // v c = gamma e c
    // Common scaling keeps the curvature: the closed loop drives the same path, slower.
    const double scale =
        std::min({1.0, v > 0 ? params_.max_speed / v : 1.0,
                  std::abs(omega) > 0 ? params_.max_angular_speed / std::abs(omega) : 1.0});
    cmd.v = v * scale;
    cmd.omega = omega * scale;
    return cmd;
  }

 private:
  IndiveriPoseControllerParams params_;
};

}  // namespace rangenav
