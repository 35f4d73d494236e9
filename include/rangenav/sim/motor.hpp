#pragma once
// A first-order (PT1) model of a DC wheel motor driven by PWM, to test motor controllers in
// simulation (paper 003 §2.1, Fig. 2 left: the step response of a wheel is a first-order lag).
//
//   tau v'(t) = v_ss(u) - v(t),   v_ss(u) = sign(u) max(0, K |T(u)| - offset - sign(u) load)
//
// T is the motor's no-load PWM -> speed characteristic (paper 003 Fig. 2 right, e.g. a
// SpeedPwmTable's speed()), K the fraction of it the motor delivers (1 with a full battery,
// less with a weak one), `offset` the constant speed lost to the floor (the carpet: "the no-load
// measurement and the one on carpet differ only by a constant offset"), and `load` an extra signed
// speed loss (e.g. the skid friction of one wheel while turning, counted along +v). Friction
// slows a wheel but cannot drive it: like the offset, a load never reverses the driven wheel's
// direction nor moves an undriven one (v_ss = 0 for u = 0). With u held for dt the model is
// integrated exactly:
//
//   v(t + dt) = v_ss + (v(t) - v_ss) exp(-dt / tau).

#include <algorithm>
#include <cmath>
#include <functional>
#include <string_view>
#include <utility>

#include "rangenav/core/error.hpp"

namespace rangenav::sim {

/// Parameters of Pt1Motor.
struct Pt1MotorParams {
  double time_constant = 0.15;  ///< tau (s), > 0
  double gain = 1.0;            ///< K: fraction of the no-load characteristic delivered, >= 0
  double load_offset = 0.2;     ///< constant speed lost to the floor (m/s), >= 0

  /// Throws invalid_argument for a non-positive time constant or a negative gain or offset.
  void validate() const {
    constexpr std::string_view where = "Pt1MotorParams";
    detail::require_positive(where, "time_constant", time_constant);
    detail::require_non_negative(where, "gain", gain);
    detail::require_non_negative(where, "load_offset", load_offset);
  }
};

/// One wheel's motor as a PT1 lag behind the steady-state speed of its PWM input.
class Pt1Motor {
 public:
  /// `no_load_speed`: T(u), the wheel speed (m/s) at PWM u without load, odd in u. Throws
  /// invalid_argument for an empty characteristic, invalid parameters or a non-finite speed.
  explicit Pt1Motor(std::function<double(double)> no_load_speed, Pt1MotorParams params = {},
                    double initial_speed = 0.0)
      : characteristic_(std::move(no_load_speed)), params_(params), v_(initial_speed) {
    params_.validate();
    if (!characteristic_) detail::throw_invalid("Pt1Motor", "argument 'no_load_speed' is empty");
    detail::require_finite("Pt1Motor", "initial_speed", initial_speed);
  }

  /// v_ss(u): the speed the motor settles at with PWM u held and the extra signed `load` (a
  /// speed loss along +v; it can stop the wheel but neither reverse nor drive it).
  [[nodiscard]] double steady_state_speed(double pwm, double load = 0.0) const {
    if (pwm == 0.0 || !std::isfinite(pwm)) return 0.0;
    const double driven = params_.gain * std::abs(characteristic_(pwm)) - params_.load_offset -
                          std::copysign(1.0, pwm) * load;
    return std::copysign(std::max(0.0, driven), pwm);
  }

  /// Holds PWM `pwm` for `dt` seconds (exact solution of the PT1 equation) and returns the new
  /// speed. A non-finite pwm counts as 0; dt <= 0 or non-finite leaves the speed unchanged.
  double step(double pwm, double dt, double load = 0.0) {
    if (!(dt > 0.0) || !std::isfinite(dt)) return v_;
    const double target = steady_state_speed(pwm, load);
    v_ = target + (v_ - target) * std::exp(-dt / params_.time_constant);
    return v_;
  }

  /// The wheel's speed (m/s).
  [[nodiscard]] double speed() const { return v_; }
  /// Sets the wheel's speed (m/s).
  void reset(double speed = 0.0) { v_ = speed; }
  /// The parameters.
  [[nodiscard]] const Pt1MotorParams& params() const { return params_; }

 private:
  std::function<double(double)> characteristic_;
  Pt1MotorParams params_;
  double v_;
};

}  // namespace rangenav::sim
