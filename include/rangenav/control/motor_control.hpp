#pragma once
// Wheel speed control of paper 003 §2.1: a feed-forward term through the inverse of a measured
// speed -> PWM lookup table T plus a constant load offset ("the no-load measurement and the one on
// carpet differ only by a constant offset") moves the motor signal near the working point, and a
// PI term corrects the remaining small disturbances (battery state, load); no D term. The motors
// receive band-limited signals: the output is clamped to the PWM band and its change per cycle is
// limited.
//
// "A given speed and steering angle are scaled by two feed forward terms F_v and F_omega and
// mapped to a PWM value according to T. F_v is set to 1 [...]. An additional feed forward term is
// needed for the angular velocity (F_omega = pi^-1 cm) according to the significant friction
// during turning." Read here as: the wheel's set speed v enters as F_v v, and the robot's turn
// rate omega adds side F_omega omega, with F_omega a length (m per rad/s, so F_omega omega is a
// speed) and side = +1 for the right wheel, -1 for the left one (omega > 0 turns left, so the
// right wheel has to drive forward harder and the left one backward harder against the skid
// friction).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"

namespace rangenav {

/// The measured no-load characteristic T: wheel speed as a function of PWM (paper 003 Fig. 2,
/// right), for non-negative PWM; negative PWM mirrors it.
class SpeedPwmTable {
 public:
  /// `pwm` strictly increasing, `speed` non-decreasing, same size >= 2, all finite. Throws
  /// invalid_argument otherwise.
  SpeedPwmTable(std::vector<double> pwm, std::vector<double> speed)
      : pwm_(std::move(pwm)), speed_(std::move(speed)) {
    constexpr std::string_view where = "SpeedPwmTable";
    if (pwm_.size() < 2)
      detail::throw_invalid_argument(where, "pwm.size()", pwm_.size(), "must be >= 2");
    if (speed_.size() != pwm_.size())
      detail::throw_invalid_argument(where, "speed.size()", speed_.size(),
                                     "must equal pwm.size() = " + std::to_string(pwm_.size()));
    for (std::size_t i = 0; i < pwm_.size(); ++i) {
      detail::require_finite(where, "pwm[" + std::to_string(i) + "]", pwm_[i]);
      detail::require_finite(where, "speed[" + std::to_string(i) + "]", speed_[i]);
      if (i > 0 && !(pwm_[i] > pwm_[i - 1]))
        detail::throw_invalid_argument(where, "pwm[" + std::to_string(i) + "]", pwm_[i],
                                       "must exceed the previous entry");
      if (i > 0 && speed_[i] < speed_[i - 1])
        detail::throw_invalid_argument(where, "speed[" + std::to_string(i) + "]", speed_[i],
                                       "must not fall below the previous entry");
    }
  }

  /// T(pwm): linear interpolation, clamped to the table's ends; odd in pwm.
  [[nodiscard]] double speed(double pwm) const {
    const double a = std::abs(pwm);
    return std::copysign(interpolate(pwm_, speed_, a), pwm);
  }

  /// T^-1(speed): the smallest PWM that reaches `speed` (the lowest point of a flat stretch),
  /// clamped to the table's ends; odd in speed.
  [[nodiscard]] double pwm(double speed) const {
    const double a = std::abs(speed);
    if (a <= speed_.front()) return std::copysign(pwm_.front(), speed);
    if (a >= speed_.back()) return std::copysign(pwm_.back(), speed);
    const auto it = std::lower_bound(speed_.begin(), speed_.end(), a);  // first speed >= a
    const auto i = static_cast<std::size_t>(it - speed_.begin());
    const double t = (a - speed_[i - 1]) / (speed_[i] - speed_[i - 1]);
    return std::copysign(pwm_[i - 1] + t * (pwm_[i] - pwm_[i - 1]), speed);
  }

  /// The largest speed in the table (m/s).
  [[nodiscard]] double max_speed() const { return speed_.back(); }
  /// The largest PWM in the table.
  [[nodiscard]] double max_pwm() const { return pwm_.back(); }

 private:
  static double interpolate(const std::vector<double>& x, const std::vector<double>& y, double a) {
    if (a <= x.front()) return y.front();
    if (a >= x.back()) return y.back();
    const auto it = std::upper_bound(x.begin(), x.end(), a);
    const auto i = static_cast<std::size_t>(it - x.begin());
    const double t = (a - x[i - 1]) / (x[i] - x[i - 1]);
    return y[i - 1] + t * (y[i] - y[i - 1]);
  }

  std::vector<double> pwm_;
  std::vector<double> speed_;
};

/// Parameters of MotorController (paper 003 §2.1).
struct MotorControllerParams {
  double dt = 0.01;           ///< control period (s); Kurt3D's loop runs at 100 Hz
  double feed_forward = 1.0;  ///< F_v, 1 "according to the design of the lookup table"
  /// F_omega (m per rad/s): extra wheel speed per unit turn rate against the turning friction;
  /// paper 003's pi^-1 cm.
  double feed_forward_omega = 0.01 / std::numbers::pi;
  double side = 1.0;          ///< +1: right wheel, -1: left wheel (sign of the F_omega term)
  double load_offset = 0.0;   ///< speed lost to the load, e.g. carpet vs no-load (m/s)
  double kp = 100.0;          ///< proportional gain (PWM per m/s)
  double ki = 200.0;          ///< integral gain (PWM per m)
  double pwm_limit = 1023.0;  ///< output band: |pwm| <= pwm_limit (10-bit PWM on Kurt3D)
  double max_pwm_step = std::numeric_limits<double>::infinity();  ///< |change| per cycle

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where) const {
    detail::require_positive(where, "params.dt", dt);
    detail::require_positive(where, "params.feed_forward", feed_forward);
    detail::require_non_negative(where, "params.feed_forward_omega", feed_forward_omega);
    if (side != 1.0 && side != -1.0)
      detail::throw_invalid_argument(where, "params.side", side, "must be +1 or -1");
    detail::require_non_negative(where, "params.load_offset", load_offset);
    detail::require_non_negative(where, "params.kp", kp);
    detail::require_non_negative(where, "params.ki", ki);
    detail::require_positive(where, "params.pwm_limit", pwm_limit);
    if (!(max_pwm_step > 0.0))
      detail::throw_invalid_argument(where, "params.max_pwm_step", max_pwm_step, "must be > 0");
  }
};

/// Feed-forward + lookup table + PI controller of one wheel (paper 003 Fig. 1, right).
class MotorController {
 public:
  /// A controller of the wheel with this speed -> PWM table; throws invalid_argument for invalid
  /// parameters.
  explicit MotorController(SpeedPwmTable table, const MotorControllerParams& params = {})
      : table_(std::move(table)), params_(params) {
    params_.validate("MotorController");
  }

  /// The parameters.
  [[nodiscard]] const MotorControllerParams& params() const { return params_; }
  /// The wheel's speed -> PWM table.
  [[nodiscard]] const SpeedPwmTable& table() const { return table_; }

  /// The open-loop part: with s = F_v v + side F_omega omega, T^-1(s + offset) signed like s;
  /// 0 for s = 0.
  [[nodiscard]] double feed_forward(double v_set, double omega_set = 0.0) const {
    const double s =
        params_.feed_forward * v_set + params_.side * params_.feed_forward_omega * omega_set;
    if (s == 0.0) return 0.0;
    return table_.pwm(std::copysign(std::abs(s) + params_.load_offset, s));
  }

  /// One control cycle: the PWM for the wheel's set speed `v_set` given its measured speed
  /// `v_measured`, while the robot turns at `omega_set` (rad/s; feeds the F_omega term). Non-finite
  /// input yields the previous output (never throws: it runs in the control loop).
  [[nodiscard]] double step(double v_set, double v_measured, double omega_set = 0.0) {
    if (!std::isfinite(v_set) || !std::isfinite(v_measured) || !std::isfinite(omega_set))
      return output_;
    const double error = v_set - v_measured;
    const double ff = feed_forward(v_set, omega_set);
    const double integral = integral_ + error * params_.dt;
    double u = ff + params_.kp * error + params_.ki * integral;
    const double band = std::clamp(u, -params_.pwm_limit, params_.pwm_limit);
    // Conditional integration: the integrator only runs while the output is not saturated.
    if (band == u) integral_ = integral;
    u = std::clamp(band, output_ - params_.max_pwm_step, output_ + params_.max_pwm_step);
    output_ = u;
    return u;
  }

  /// Clears the integral term and the output (e.g. after an emergency stop).
  void reset() {
    integral_ = 0.0;
    output_ = 0.0;
  }
  /// The last PWM output.
  [[nodiscard]] double output() const { return output_; }

 private:
  SpeedPwmTable table_;
  MotorControllerParams params_;
  double integral_{0.0};
  double output_{0.0};
};

}  // namespace rangenav
