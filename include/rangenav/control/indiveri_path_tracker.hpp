#pragma once
// Path following with Indiveri's steering law on a chain of local frames (paper 000 §5).
//
// In the frame of the tracked segment (x along the segment) the robot's cross-track offset y and
// heading error theta feed
//     omega = -h v y sin(theta) / theta - gamma theta,   h, gamma > 0        (Eq. 7 of paper 000)
// which, for the unicycle y' = v sin(theta), theta' = omega and any v > 0, makes
// V = h y^2 / 2 + theta^2 / 2 non-increasing (V' = -gamma theta^2): the robot converges to the
// segment's line. The gains depend on the situation, "whether the robot is regaining or
// maintaining the currently tracked path segment". The linear velocity "can be freely chosen and
// adapted": here it is the set speed, reduced while the robot faces away from the segment.
//
// The latest scan, transformed into the frames of the segments ahead, tells whether the path ahead
// is free; if it is not, the command asks for re-planning and names the graph edge to mark blocked.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>

#include "rangenav/control/local_frame_path.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// The gains of Eq. (7).
struct IndiveriGains {
  double h;      ///< cross-track gain (1/m^2), > 0
  double gamma;  ///< heading gain (1/s), > 0
};

/// Parameters of IndiveriPathTracker. Near the line Eq. (7) linearises to
/// theta'' + gamma theta' + h v^2 theta = 0; the defaults damp it critically when maintaining and
/// over-damp it when regaining, for v = 0.3 m/s (paper 002 §5.2's speed).
struct IndiveriPathTrackerParams {
  double speed = 0.3;                   ///< set linear velocity v (m/s)
  IndiveriGains regain{2.0, 1.2};       ///< used while far from the segment
  IndiveriGains maintain{10.0, 1.9};    ///< used once close to it
  double maintain_offset = 0.10;        ///< |y| below this (m) ...
  double maintain_heading = 0.25;       ///< ... and |theta| below this (rad): maintaining
  double switch_distance = 0.15;        ///< move on when this close to a segment's end (m)
  double goal_distance = 0.30;          ///< finished this close to the path's end (m)
  double max_angular_speed = 2.0;       ///< |omega| limit (rad/s)
  double min_speed_fraction = 0.2;      ///< v = speed * max(this, cos theta)
  double corridor_half_width = 0.215;   ///< blocked check: half robot width + margin (m)
  double lookahead = 1.5;               ///< blocked check: how far ahead along the path (m)
  std::size_t min_blocking_points = 2;  ///< blocked check: points needed to call it blocked

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where) const {
    detail::require_positive(where, "params.speed", speed);
    detail::require_positive(where, "params.regain.h", regain.h);
    detail::require_positive(where, "params.regain.gamma", regain.gamma);
    detail::require_positive(where, "params.maintain.h", maintain.h);
    detail::require_positive(where, "params.maintain.gamma", maintain.gamma);
    detail::require_non_negative(where, "params.maintain_offset", maintain_offset);
    detail::require_non_negative(where, "params.maintain_heading", maintain_heading);
    detail::require_non_negative(where, "params.switch_distance", switch_distance);
    detail::require_non_negative(where, "params.goal_distance", goal_distance);
    detail::require_positive(where, "params.max_angular_speed", max_angular_speed);
    if (!(min_speed_fraction > 0.0 && min_speed_fraction <= 1.0))
      detail::throw_invalid_argument(where, "params.min_speed_fraction", min_speed_fraction,
                                     "must be in (0, 1]");
    detail::require_non_negative(where, "params.corridor_half_width", corridor_half_width);
    detail::require_non_negative(where, "params.lookahead", lookahead);
  }
};

/// What the tracker asks the robot to do.
struct TrackerCommand {
  double v{0.0};            ///< linear velocity (m/s)
  double omega{0.0};        ///< angular velocity (rad/s)
  std::size_t segment{0};   ///< the tracked segment
  double y{0.0};            ///< cross-track offset in the segment frame (m)
  double theta{0.0};        ///< heading error in the segment frame (rad)
  bool maintaining{false};  ///< maintaining (true) or regaining (false) gains were used
  bool finished{false};     ///< the path's end is within goal_distance: hand over to pose control
  bool replan{false};       ///< the segment ahead is blocked: stop, mark blocked_edge, re-plan
  std::uint32_t blocked_edge{LocalFramePath::no_edge};  ///< graph edge of the blocked segment
};

/// Follows a LocalFramePath with Indiveri's law (Eq. 7 of paper 000) segment by segment, and
/// checks the path ahead against a scan (see step()).
class IndiveriPathTracker {
 public:
  /// A tracker with these parameters and no path; throws invalid_argument for invalid ones.
  explicit IndiveriPathTracker(const IndiveriPathTrackerParams& params = {}) : params_(params) {
    params_.validate("IndiveriPathTracker");
  }

  /// The parameters.
  [[nodiscard]] const IndiveriPathTrackerParams& params() const { return params_; }

  /// Starts tracking `path` from its first segment.
  void set_path(LocalFramePath path) {
    path_ = std::move(path);
    segment_ = 0;
  }
  /// The path being tracked.
  [[nodiscard]] const LocalFramePath& path() const { return path_; }
  /// The index of the segment being tracked.
  [[nodiscard]] std::size_t current_segment() const { return segment_; }

  /// One control step for the robot at `pose` (map frame). Throws invalid_argument without a
  /// path or for a non-finite pose.
  [[nodiscard]] TrackerCommand step(const Pose2d& pose) {
    check("IndiveriPathTracker::step", pose);
    TrackerCommand cmd;
    advance(pose);
    cmd.segment = segment_;
    const PathSegment& seg = path_.segment(segment_);
    const Pose2d local = seg.to_local(pose);
    cmd.y = local.y;
    cmd.theta = local.theta;
    const bool last = segment_ + 1 == path_.size();
    if (last &&
        ((pose.position() - seg.end).norm() < params_.goal_distance || local.x >= seg.length)) {
      cmd.finished = true;
      return cmd;
    }
    cmd.maintaining = std::abs(local.y) < params_.maintain_offset &&
                      std::abs(local.theta) < params_.maintain_heading;
    const IndiveriGains& g = cmd.maintaining ? params_.maintain : params_.regain;
    cmd.v = params_.speed * std::max(params_.min_speed_fraction, std::cos(local.theta));
    cmd.omega = indiveri_omega(cmd.v, local.y, local.theta, g);
    cmd.omega = std::clamp(cmd.omega, -params_.max_angular_speed, params_.max_angular_speed);
    return cmd;
  }

  /// As step(pose), after checking the path ahead against `scan` (points in the robot frame, e.g.
  /// a LaserScan or an obstacle map): if at least min_blocking_points lie on one segment within
  /// lookahead of the robot along the path (within corridor_half_width of the segment), the
  /// command stops the robot and asks for re-planning, naming that segment's graph edge.
  template <PointCloudOf<2> C>
  [[nodiscard]] TrackerCommand step(const Pose2d& pose, const C& scan) {
    TrackerCommand cmd = step(pose);
    if (cmd.finished) return cmd;
    if (const auto blocked = blocked_segment(pose, scan)) {
      cmd.v = 0.0;
      cmd.omega = 0.0;
      cmd.replan = true;
      cmd.blocked_edge = path_.segment(*blocked).edge;
    }
    return cmd;
  }

  /// The first segment of the path ahead of the robot at `pose` (from the current one on, up to
  /// lookahead along the path) on which at least min_blocking_points of `scan` (robot frame) lie
  /// within corridor_half_width; nothing when the way is free. A path of many short segments
  /// (a Voronoi graph's chain along a corridor) is checked as far ahead as a single long one.
  template <PointCloudOf<2> C>
  [[nodiscard]] std::optional<std::size_t> blocked_segment(const Pose2d& pose,
                                                           const C& scan) const {
    check("IndiveriPathTracker::blocked_segment", pose);
    const std::size_t n = traits::size(scan);
    double from = path_.segment(segment_).to_local(pose.position()).x();
    double remaining = params_.lookahead;
    if (from < 0.0) {  // segment switching moved on before the robot reached the segment's start
      remaining += from;
      from = 0.0;
    }
    for (std::size_t k = segment_; k < path_.size() && remaining > 0.0; ++k) {
      const PathSegment& seg = path_.segment(k);
      const Pose2d robot = seg.to_local(pose);  // the robot in the segment frame
      const double to = std::min(seg.length, from + remaining);
      const double c = std::cos(robot.theta), s = std::sin(robot.theta);
      std::size_t hits = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const Point2d p = traits::point(scan, i).template cast<double>();
        const double x = robot.x + c * p.x() - s * p.y();
        const double y = robot.y + s * p.x() + c * p.y();
        if (x >= from && x <= to && std::abs(y) <= params_.corridor_half_width)
          if (++hits >= params_.min_blocking_points) return k;
      }
      remaining -= std::max(0.0, to - from);
      from = 0.0;
    }
    return std::nullopt;
  }

  /// Whether the path ahead of the robot at `pose` is blocked by points of `scan` (robot frame).
  template <PointCloudOf<2> C>
  [[nodiscard]] bool segment_blocked(const Pose2d& pose, const C& scan) const {
    return blocked_segment(pose, scan).has_value();
  }

  /// Eq. (7) of paper 000, with sin(theta)/theta -> 1 at theta = 0.
  [[nodiscard]] static double indiveri_omega(double v, double y, double theta,
                                             const IndiveriGains& g) {
    const double sinc = std::abs(theta) < 1e-9 ? 1.0 : std::sin(theta) / theta;
    return -g.h * v * y * sinc - g.gamma * theta;
  }

 private:
  void check(std::string_view where, const Pose2d& pose) const {
    if (path_.empty()) detail::throw_invalid(where, "no path set");
    detail::require_finite(where, "pose.x", pose.x);
    detail::require_finite(where, "pose.y", pose.y);
    detail::require_finite(where, "pose.theta", pose.theta);
  }

  // Segment switching: move on to the next frame once the robot is within switch_distance of
  // the current segment's end, or past it.
  void advance(const Pose2d& pose) {
    while (segment_ + 1 < path_.size()) {
      const PathSegment& seg = path_.segment(segment_);
      if (seg.to_local(pose.position()).x() < seg.length - params_.switch_distance) break;
      ++segment_;
    }
  }

  IndiveriPathTrackerParams params_;
  LocalFramePath path_;
  std::size_t segment_{0};
};

}  // namespace rangenav
