#pragma once
// Reactive collision avoidance on any scan or obstacle map (paper 002 §5, paper 003 §2.2.2):
//
//  1. Virtual roadway: the distance dto to the nearest obstacle on a roadway of the robot's width
//     ahead scales the speed, v_set = dto / dto_max * v_max (paper 003 §2.2.2);
//  2. below dto_min the robot stops and turns on the spot (or backs off) until the roadway is
//     free again;
//  3. free-space orientation: every reading votes for its bearing with the fuzzy weight
//     f_theta(theta) f_d(d) and
//        alpha_free = atan2(sum sin(theta_i) w_i, sum cos(theta_i) w_i)          (Eq. 5, paper 002)
//     with f_theta(theta) = cos(theta / 1.2) and f_d(d) = 1 / (1 + exp(-(d - dto_max) / dto_min))
//     (Eq. 6); the rotational velocity is bent toward alpha_free with a small, settable influence.
//
// Obstacles are 2D points in the robot frame (x forward, y left): a LaserScan's valid points, an
// egocentric obstacle map, or any PointCloud of dimension 2.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <string>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/scan/laser_scan.hpp"

namespace rangenav {

/// The virtual roadway and stop behaviour; defaults are Kurt3D's (paper 003 §2.2.2): dto_min =
/// 50 cm, dto_max = 600 cm, v_max = 4 m/s, roadway as wide as the robot (33 cm).
struct VirtualRoadwayParams {
  double half_width = 0.165;   ///< half the roadway's width (m)
  double front_offset = 0.0;   ///< distance from the robot's origin to its front (m)
  double dto_min = 0.5;        ///< stop below this distance (m)
  double dto_max = 6.0;        ///< full speed beyond this distance (m)
  double v_max = 4.0;          ///< speed with a free roadway (m/s)
  double turn_rate = 0.8;      ///< |omega| while stopped and turning on the spot (rad/s)
  double backoff_speed = 0.0;  ///< > 0: back off at this speed instead of turning (m/s)

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where) const {
    detail::require_non_negative(where, "roadway.half_width", half_width);
    detail::require_non_negative(where, "roadway.front_offset", front_offset);
    detail::require_non_negative(where, "roadway.dto_min", dto_min);
    detail::require_positive(where, "roadway.dto_max", dto_max);
    if (!(dto_max > dto_min))
      detail::throw_invalid_argument(where, "roadway.dto_max", dto_max,
                                     "must exceed dto_min = " + detail::format_value(dto_min));
    detail::require_positive(where, "roadway.v_max", v_max);
    detail::require_non_negative(where, "roadway.turn_rate", turn_rate);
    detail::require_non_negative(where, "roadway.backoff_speed", backoff_speed);
  }
};

/// The free-space orientation behaviour (paper 002 §5.1).
struct FreeSpaceParams {
  double angle_scale = 1.2;  ///< f_theta(theta) = cos(theta / angle_scale) (Eq. 6)
  double dto_min = 0.5;      ///< slope of f_d (m), the roadway's dto_min in the paper
  double dto_max = 6.0;      ///< inflection point of f_d (m), the roadway's dto_max in the paper
  double influence = 0.3;    ///< omega += influence * alpha_free (1/s); "kept rather small"

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where) const {
    detail::require_positive(where, "free_space.angle_scale", angle_scale);
    detail::require_positive(where, "free_space.dto_min", dto_min);
    detail::require_finite(where, "free_space.dto_max", dto_max);
    detail::require_non_negative(where, "free_space.influence", influence);
  }
};

/// f_theta of Eq. (6), paper 002: "angle is in driving direction". Clamped at 0 beyond
/// |theta| = angle_scale pi / 2 (a fuzzy membership is never negative).
[[nodiscard]] inline double free_space_angle_weight(double theta, double angle_scale = 1.2) {
  return std::max(0.0, std::cos(theta / angle_scale));
}

/// f_d of Eq. (6), paper 002: "distance is large", a logistic with inflection dto_max and slope
/// set by dto_min.
[[nodiscard]] inline double free_space_distance_weight(double d, double dto_min = 0.5,
                                                       double dto_max = 6.0) {
  return 1.0 / (1.0 + std::exp(-((d - dto_max) / dto_min)));
}

/// Accumulates Eq. (5) of paper 002 reading by reading.
class FreeSpaceOrientation {
 public:
  /// An accumulator with these parameters; throws invalid_argument for invalid ones.
  explicit FreeSpaceOrientation(const FreeSpaceParams& params = {}) : params_(params) {
    params_.validate("FreeSpaceOrientation");
  }
  /// Adds one reading at bearing theta (rad, robot frame) and distance d (m).
  void add(double theta, double d) {
    const double w = free_space_angle_weight(theta, params_.angle_scale) *
                     free_space_distance_weight(d, params_.dto_min, params_.dto_max);
    sin_sum_ += std::sin(theta) * w;
    cos_sum_ += std::cos(theta) * w;
  }
  /// alpha_free (rad), or nothing when no reading carried weight.
  [[nodiscard]] std::optional<double> orientation() const {
    if (sin_sum_ == 0.0 && cos_sum_ == 0.0) return std::nullopt;
    return std::atan2(sin_sum_, cos_sum_);
  }

 private:
  FreeSpaceParams params_;
  double sin_sum_{0.0};
  double cos_sum_{0.0};
};

/// alpha_free (Eq. 5, paper 002) of obstacle points in the robot frame (an obstacle map).
template <PointCloudOf<2> C>
[[nodiscard]] std::optional<double> free_space_orientation(const C& obstacles,
                                                           const FreeSpaceParams& params = {}) {
  FreeSpaceOrientation acc(params);
  const std::size_t n = traits::size(obstacles);
  for (std::size_t i = 0; i < n; ++i) {
    const Point2d p = traits::point(obstacles, i).template cast<double>();
    if (p.allFinite()) acc.add(std::atan2(p.y(), p.x()), p.norm());
  }
  return acc.orientation();
}

/// alpha_free of a laser scan, one rule per beam as in paper 003 Eq. (2): a beam that saw nothing
/// (at or beyond range_max, or +inf) votes with distance range_max; NaN, 0 and readings below
/// range_min are skipped.
template <class Scalar>
[[nodiscard]] std::optional<double> free_space_orientation(const LaserScan<Scalar>& scan,
                                                           const FreeSpaceParams& params = {}) {
  FreeSpaceOrientation acc(params);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const double r = static_cast<double>(scan.range(i));
    const double theta = static_cast<double>(scan.angle(i));
    if (scan.is_valid(i))
      acc.add(theta, r);
    else if (r >= static_cast<double>(scan.range_max()))  // includes +inf, not NaN
      acc.add(theta, static_cast<double>(scan.range_max()));
  }
  return acc.orientation();
}

/// Distance from the robot's front to the nearest obstacle point on the virtual roadway ahead
/// (|y| <= half_width, x > front_offset); +inf when the roadway is free.
template <PointCloudOf<2> C>
[[nodiscard]] double roadway_distance(const C& obstacles, const VirtualRoadwayParams& params = {}) {
  double best = std::numeric_limits<double>::infinity();
  const std::size_t n = traits::size(obstacles);
  for (std::size_t i = 0; i < n; ++i) {
    const Point2d p = traits::point(obstacles, i).template cast<double>();
    if (p.x() > params.front_offset && std::abs(p.y()) <= params.half_width)
      best = std::min(best, p.x() - params.front_offset);
  }
  return best;
}

/// The speed law of the virtual roadway (paper 003 §2.2.2): v_max beyond dto_max,
/// dto / dto_max * v_max between dto_min and dto_max, 0 below dto_min.
[[nodiscard]] inline double roadway_speed(double dto, const VirtualRoadwayParams& params = {}) {
  if (!(dto >= params.dto_min)) return 0.0;  // NaN stops too
  if (dto >= params.dto_max) return params.v_max;
  return dto / params.dto_max * params.v_max;
}

/// Which way a robot stopped by the roadway turns on the spot.
enum class StopTurn {
  toward_free_space,  ///< toward alpha_free (paper 002 §5), else in the commanded sense
  commanded,          ///< in the sense of the commanded omega, else toward alpha_free: for a
                      ///< goal-directed controller (path tracker, pose controller) that knows
                      ///< where it wants to turn; turning away and back would livelock with it
};

/// Parameters of the three reactive behaviours of paper 002 §5.
struct ReactiveParams {
  VirtualRoadwayParams roadway{};  ///< virtual roadway: speed scaling and stop (paper 003 §2.2.2)
  FreeSpaceParams free_space{};    ///< free-space orientation (Eq. 5-6 of paper 002)
  bool use_free_space = true;      ///< apply the third behaviour
  StopTurn stop_turn = StopTurn::toward_free_space;  ///< which way a stopped robot turns
};

/// The command after the reactive behaviours, and what they saw.
struct ReactiveCommand {
  double v{0.0};                                        ///< linear velocity (m/s)
  double omega{0.0};                                    ///< angular velocity (rad/s)
  double dto{std::numeric_limits<double>::infinity()};  ///< roadway distance (m)
  std::optional<double> alpha_free;                     ///< free-space orientation (rad)
  bool stopped{false};  ///< below dto_min: turning on the spot or backing off
};

/// The three reactive behaviours of paper 002 §5 applied to a desired (v, omega), e.g. from a
/// path tracker or a constant "drive forward". A stopped robot keeps the sense of turn it chose
/// until the roadway is free again ("turns on the spot until ..."): re-deciding every cycle from a
/// free-space vote or a commanded omega near zero makes it twitch left and right on the spot. So
/// apply() updates that one bit of state; reset() forgets it.
class ReactiveBehaviours {
 public:
  /// Behaviours with these parameters; throws invalid_argument for invalid ones.
  explicit ReactiveBehaviours(const ReactiveParams& params = {}) : params_(params) {
    params_.roadway.validate("ReactiveBehaviours");
    params_.free_space.validate("ReactiveBehaviours");
  }
  /// The parameters.
  [[nodiscard]] const ReactiveParams& params() const { return params_; }
  /// Forgets the sense of turn of a stop (e.g. after a new goal).
  void reset() { turn_sense_ = 0; }

  /// Adapts (v, omega) to `obstacles` (robot frame). The speed is scaled like v_set:
  /// v * min(1, dto / dto_max), and 0 below dto_min; a stopped robot turns on the spot toward
  /// free space (or backs off when backoff_speed > 0).
  template <PointCloudOf<2> C>
  [[nodiscard]] ReactiveCommand apply(double v, double omega, const C& obstacles) {
    ReactiveCommand cmd;
    cmd.dto = roadway_distance(obstacles, params_.roadway);
    if (params_.use_free_space)
      cmd.alpha_free = free_space_orientation(obstacles, params_.free_space);
    return finish(v, omega, cmd);
  }

  /// As apply() for a laser scan (free-space votes of empty beams included, see
  /// free_space_orientation(LaserScan)).
  template <class Scalar>
  [[nodiscard]] ReactiveCommand apply(double v, double omega, const LaserScan<Scalar>& scan) {
    ReactiveCommand cmd;
    cmd.dto = roadway_distance(scan, params_.roadway);
    if (params_.use_free_space) cmd.alpha_free = free_space_orientation(scan, params_.free_space);
    return finish(v, omega, cmd);
  }

 private:
  ReactiveCommand finish(double v, double omega, ReactiveCommand cmd) {
    const VirtualRoadwayParams& r = params_.roadway;
    if (v > 0.0 && cmd.dto < r.dto_min) {
      cmd.stopped = true;
      if (r.backoff_speed > 0.0) {
        cmd.v = -r.backoff_speed;
        cmd.omega = 0.0;
      } else {
        if (turn_sense_ == 0) {
          // Turn toward free space; without a free-space vote keep the commanded sense of turn
          // (or the other way round with StopTurn::commanded).
          const bool commanded =
              !cmd.alpha_free || (params_.stop_turn == StopTurn::commanded && omega != 0.0);
          const double side = commanded ? omega : *cmd.alpha_free;
          turn_sense_ = side < 0.0 ? -1 : 1;
        }
        cmd.v = 0.0;
        cmd.omega = turn_sense_ * r.turn_rate;
      }
      return cmd;
    }
    turn_sense_ = 0;
    cmd.v = v > 0.0 ? v * std::min(1.0, roadway_speed(cmd.dto, r) / r.v_max) : v;
    cmd.omega = omega;
    if (cmd.alpha_free) cmd.omega += params_.free_space.influence * *cmd.alpha_free;
    return cmd;
  }

  ReactiveParams params_;
  int turn_sense_{0};  ///< +1 / -1 while stopped and turning, 0 otherwise
};

}  // namespace rangenav
