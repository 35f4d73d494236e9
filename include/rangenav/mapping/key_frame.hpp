#pragma once
// Key-frame selection (paper 000 §3.2, paper 002 §6.3, paper 004 §3.2): a new scan becomes a key
// frame when the robot moved more than 50 cm or turned more than 25° since the last key frame.

#include <cmath>
#include <concepts>
#include <numbers>
#include <optional>
#include <string_view>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// When a pose becomes a key frame: after moving min_distance or turning min_angle (the papers'
/// 50 cm and 25°).
template <std::floating_point Scalar = double>
struct KeyFrameParams {
  Scalar min_distance = Scalar(0.5);                                 ///< m
  Scalar min_angle = Scalar(25) * std::numbers::pi_v<Scalar> / 180;  ///< rad

  /// Throws invalid_argument for a negative (or NaN) min_distance or min_angle.
  void validate() const {
    detail::require_non_negative("KeyFrameParams", "min_distance", min_distance);
    detail::require_non_negative("KeyFrameParams", "min_angle", min_angle);
  }
};

/// Remembers the last key frame's pose and tells whether a pose is far enough from it.
template <int D, std::floating_point Scalar = double>
class KeyFrameSelector {
 public:
  /// No key frame yet; throws invalid_argument for bad params (KeyFrameParams::validate()).
  explicit KeyFrameSelector(KeyFrameParams<Scalar> params = {}) : params_(params) {
    params_.validate();
  }

  /// True when `pose` moved more than min_distance or turned more than min_angle from the last
  /// key frame (or there is none yet). Does not record it: call accept().
  [[nodiscard]] bool is_key_frame(const Transform<D, Scalar>& pose) const {
    if (!last_) return true;
    const Transform<D, Scalar> delta = last_->inverse(Eigen::Isometry) * pose;
    return delta.translation().norm() > params_.min_distance ||
           std::abs(rotation_angle(delta)) > params_.min_angle;
  }
  /// Records `pose` as the last key frame.
  void accept(const Transform<D, Scalar>& pose) { last_ = pose; }
  /// is_key_frame() followed by accept() when true.
  bool update(const Transform<D, Scalar>& pose) {
    if (!is_key_frame(pose)) return false;
    accept(pose);
    return true;
  }
  /// The last key frame's pose; empty before the first.
  [[nodiscard]] const std::optional<Transform<D, Scalar>>& last() const { return last_; }
  /// The thresholds the selector was built with.
  [[nodiscard]] const KeyFrameParams<Scalar>& params() const { return params_; }

 private:
  KeyFrameParams<Scalar> params_;
  std::optional<Transform<D, Scalar>> last_;
};

}  // namespace rangenav
