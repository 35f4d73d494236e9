#pragma once
// The odometry motion model of Probabilistic Robotics (§5.4, sample_motion_model_odometry, Table
// 5.6): the odometry increment between two readings is split into a first rotation, a
// translation and a second rotation, each perturbed by zero-mean noise whose variance grows with
// the motion:
//   rot1'  = rot1  - N(alpha1 rot1^2 + alpha2 trans^2)
//   trans' = trans - N(alpha3 trans^2 + alpha4 rot1^2 + alpha4 rot2^2)
//   rot2'  = rot2  - N(alpha1 rot2^2 + alpha2 trans^2)
// A backward move would read as a half turn, a translation and another half turn; as in AMCL,
// the rotation noise then uses the smaller of |rot| and |pi - |rot||.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <string_view>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// Two successive odometry readings (the control u_t = (x̄_{t-1}, x̄_t) of Table 5.6).
struct OdometryReading {
  Pose2d previous{};  ///< odometry pose at the previous update
  Pose2d current{};   ///< odometry pose now
};

/// Noise parameters of the odometry motion model (Probabilistic Robotics Table 5.6).
struct OdometryMotionParams {
  double alpha1{0.2};  ///< rotation noise from rotation (rad^2 / rad^2)
  double alpha2{0.2};  ///< rotation noise from translation (rad^2 / m^2)
  double alpha3{0.2};  ///< translation noise from translation (m^2 / m^2)
  double alpha4{0.2};  ///< translation noise from rotation (m^2 / rad^2)

  /// Throws invalid_argument for a negative alpha.
  void validate(std::string_view where) const {
    detail::require_non_negative(where, "alpha1", alpha1);
    detail::require_non_negative(where, "alpha2", alpha2);
    detail::require_non_negative(where, "alpha3", alpha3);
    detail::require_non_negative(where, "alpha4", alpha4);
  }
};

/// The odometry motion model (Probabilistic Robotics Table 5.6): rotation, translation,
/// rotation, each with noise; models MotionModel for Pose2d and OdometryReading.
class OdometryMotionModel {
 public:
  /// A model with these noise parameters; throws invalid_argument for invalid ones.
  explicit OdometryMotionModel(const OdometryMotionParams& params = {}) : params_(params) {
    params_.validate("OdometryMotionModel");
  }
  /// The parameters.
  [[nodiscard]] const OdometryMotionParams& params() const { return params_; }

  /// Throws invalid_argument naming `where` unless both odometry poses are finite and so is the
  /// increment between them. The filters call it once per update, before sample() runs in the
  /// particle loop (which never throws): a NaN reading would otherwise turn every particle NaN.
  static void validate(const OdometryReading& u, std::string_view where) {
    const auto finite = [&](std::string_view name, double v) {
      detail::require_finite(where, name, v);
    };
    finite("u.previous.x", u.previous.x);
    finite("u.previous.y", u.previous.y);
    finite("u.previous.theta", u.previous.theta);
    finite("u.current.x", u.current.x);
    finite("u.current.y", u.current.y);
    finite("u.current.theta", u.current.theta);
    if (!std::isfinite(std::hypot(u.current.x - u.previous.x, u.current.y - u.previous.y)))
      detail::throw_invalid(where, "the odometry increment u.current - u.previous overflows");
  }

  /// A pose drawn from p(x_t | u_t, x_{t-1}) (Table 5.6).
  template <class Engine>
  [[nodiscard]] Pose2d sample(const Pose2d& x, const OdometryReading& u, Engine& rng) const {
    const double dx = u.current.x - u.previous.x, dy = u.current.y - u.previous.y;
    const double trans = std::hypot(dx, dy);
    // Below 1 cm (AMCL's threshold) the direction of the translation is noise: count the
    // increment as a pure rotation. Otherwise a 2 mm creep at an odd angle reads as rot1 = -rot2
    // of up to pi/2, whose alpha1 noise turned the particles' headings by up to 0.45 rad in one
    // step on FR079 (scan 3723, robot stopping) and the filter lost the robot.
    const double rot1 = trans < 1e-2 ? 0.0 : normalize_angle(std::atan2(dy, dx) - u.previous.theta);
    const double rot2 = normalize_angle(u.current.theta - u.previous.theta - rot1);
    const auto folded = [](double a) {
      return std::min(std::abs(a), std::numbers::pi - std::abs(a));
    };
    const double r1 = folded(rot1), r2 = folded(rot2);
    const auto draw = [&](double variance) {
      return variance > 0 ? std::normal_distribution<double>(0.0, std::sqrt(variance))(rng) : 0.0;
    };
    const auto& a = params_;
    const double rot1_hat = rot1 - draw(a.alpha1 * r1 * r1 + a.alpha2 * trans * trans);
    const double trans_hat =
        trans - draw(a.alpha3 * trans * trans + a.alpha4 * (r1 * r1 + r2 * r2));
    const double rot2_hat = rot2 - draw(a.alpha1 * r2 * r2 + a.alpha2 * trans * trans);
    return {x.x + trans_hat * std::cos(x.theta + rot1_hat),
            x.y + trans_hat * std::sin(x.theta + rot1_hat),
            normalize_angle(x.theta + rot1_hat + rot2_hat)};
  }

 private:
  OdometryMotionParams params_;
};

}  // namespace rangenav
