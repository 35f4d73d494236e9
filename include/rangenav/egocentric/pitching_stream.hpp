#pragma once
// The continuous data stream of a pitching 2D scanner (3D-perception paper 002 §3.3, §4, §6.1).
//
//  - area_of_interest(): the range of pitch angles [θ_pitch,min, θ_pitch,max] to nod over,
//    adapted to the robot's speed between the full aperture Θ_pitch (standing still: complete 3D
//    scans with walls and ceiling) and the virtual corridor (driving fast: exactly the robot's
//    height band from d_min on), §3.3.
//  - PitchingObstacleExtractor: turns the stream of PitchedScans into obstacle points for an
//    ObstacleMap, scan by scan, with the neighbourhood-based floor classification of §4.2 (which
//    needs the neighbouring scans of the sweep, so each scan's obstacles come out delay() scans
//    later) and artificial obstacles for readings below floor level.
//  - SweepAssembler: segments the stream into one 3D point cloud per pitch sweep, referenced to
//    the base pose P_b of its first scan, every 2D scan motion-compensated by the pose shift
//    since P_b (§6.1); a sweep is dropped when the pose shifts say the robot turns fast, and the
//    next one starts after the turn.
//  - structure_scan(): a sweep's structure map (§4.3) as a virtual 2D scan for 3-DOF SLAM (§6.1).
//  The per-scan reduction steps of §6.1 are in egocentric/sweep_reduction.hpp.

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <numbers>
#include <span>
#include <vector>

#include "rangenav/core/cloud.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/egocentric/floor.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/scan/laser_scan.hpp"
#include "rangenav/scan/pitching.hpp"

namespace rangenav {

// ---- area of interest ------------------------------------------------------------------------

/// A range of pitch angles (rad; positive looks down, Eq. 3): min is the most upward.
template <std::floating_point Scalar = double>
struct PitchInterval {
  Scalar min{0};  ///< rad, the most upward pitch
  Scalar max{0};  ///< rad, the most downward pitch
};

/// Parameters of the area of interest adapted to velocity (paper 002 §3.3).
template <std::floating_point Scalar = double>
struct AreaOfInterestParams {
  /// The virtual corridor: the robot's height band (m above the floor).
  Scalar corridor_z_min{0.0};
  Scalar corridor_z_max{1.0};  ///< upper bound of the virtual corridor (m)
  /// d_min (m, horizontally from the scanner): from here on one pitch movement covers the whole
  /// corridor (§3.3: small in cluttered rooms, 1 m is ample along an empty corridor).
  Scalar d_min{1.0};
  /// The scanner's full vertical aperture Θ_pitch = 120 deg, as pitch limits.
  Scalar pitch_up_limit{-std::numbers::pi_v<Scalar> / 3};
  Scalar pitch_down_limit{std::numbers::pi_v<Scalar> / 3};  ///< the aperture's downward limit (rad)
  /// Speed (m/s) from which only the virtual corridor is scanned; below it the AOI widens
  /// linearly towards the full aperture at standstill.
  Scalar fast_speed{0.5};

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where = "AreaOfInterestParams") const {
    detail::require_finite(where, "corridor_z_min", corridor_z_min);
    detail::require_finite(where, "corridor_z_max", corridor_z_max);
    if (!(corridor_z_max > corridor_z_min))
      detail::throw_invalid_argument(
          where, "corridor_z_max", corridor_z_max,
          "must exceed corridor_z_min = " + detail::format_value(corridor_z_min));
    detail::require_positive(where, "d_min", d_min);
    detail::require_finite(where, "pitch_up_limit", pitch_up_limit);
    detail::require_finite(where, "pitch_down_limit", pitch_down_limit);
    if (!(pitch_down_limit > pitch_up_limit))
      detail::throw_invalid_argument(
          where, "pitch_down_limit", pitch_down_limit,
          "must exceed pitch_up_limit = " + detail::format_value(pitch_up_limit));
    detail::require_positive(where, "fast_speed", fast_speed);
  }
};

/// The smallest AOI: the pitch range in which a scanner whose pitch axis is `sensor_height` above
/// the floor sees the whole corridor from d_min on (§3.3, Fig. 4), clamped to the limits.
template <std::floating_point Scalar>
[[nodiscard]] PitchInterval<Scalar> virtual_corridor_aoi(Scalar sensor_height,
                                                         const AreaOfInterestParams<Scalar>& p) {
  p.validate("virtual_corridor_aoi");
  detail::require_finite("virtual_corridor_aoi", "sensor_height", sensor_height);
  // A beam at pitch a reaches height z at horizontal distance d when tan a = (h - z) / d; every
  // d >= d_min is covered when the interval holds both bounds at d_min and the horizontal.
  Scalar up = std::atan2(sensor_height - p.corridor_z_max, p.d_min);
  Scalar down = std::atan2(sensor_height - p.corridor_z_min, p.d_min);
  up = std::clamp(std::min(up, Scalar(0)), p.pitch_up_limit, p.pitch_down_limit);
  down = std::clamp(std::max(down, Scalar(0)), p.pitch_up_limit, p.pitch_down_limit);
  return {up, down};
}

/// The AOI for the robot's current speed (m/s): the full aperture at standstill, narrowing
/// linearly to the virtual corridor at fast_speed and above (§3.3).
template <std::floating_point Scalar>
[[nodiscard]] PitchInterval<Scalar> area_of_interest(Scalar speed, Scalar sensor_height,
                                                     const AreaOfInterestParams<Scalar>& p = {}) {
  detail::require_finite("area_of_interest", "speed", speed);
  const PitchInterval<Scalar> corridor = virtual_corridor_aoi(sensor_height, p);
  const Scalar f = std::clamp(std::abs(speed) / p.fast_speed, Scalar(0), Scalar(1));
  return {p.pitch_up_limit + f * (corridor.min - p.pitch_up_limit),
          p.pitch_down_limit + f * (corridor.max - p.pitch_down_limit)};
}

/// The blind zone of a pitching scanner whose pitch axis sits at `sensor_offset` (robot frame,
/// z = height above the floor) and that pitches down to at most `pitch_max` (rad, positive looks
/// down): a beam at pitch a reaches height z at the horizontal distance (h - z) / tan a in front of
/// the axis whatever its bearing (Eq. 3), so nothing lower than `height` is seen nearer than
/// sensor_offset.x + (h - height) / tan(pitch_max) ahead of the robot's origin. Use it as
/// VirtualMapParams::blind_range. Throws invalid_argument unless 0 < pitch_max < pi / 2 and
/// height < h.
template <std::floating_point Scalar>
[[nodiscard]] Scalar pitching_blind_range(const Point<3, Scalar>& sensor_offset, Scalar pitch_max,
                                          Scalar height = Scalar(0)) {
  constexpr std::string_view where = "pitching_blind_range";
  if (!sensor_offset.allFinite()) detail::throw_invalid(where, "sensor_offset must be finite");
  if (!(pitch_max > Scalar(0) && pitch_max < std::numbers::pi_v<Scalar> / 2))
    detail::throw_invalid_argument(where, "pitch_max", pitch_max, "must be in (0, pi / 2)");
  if (!(height < sensor_offset.z()))
    detail::throw_invalid_argument(
        where, "height", height,
        "must be below the sensor height " + detail::format_value(sensor_offset.z()));
  return std::max(Scalar(0),
                  sensor_offset.x() + (sensor_offset.z() - height) / std::tan(pitch_max));
}

// ---- stream helpers --------------------------------------------------------------------------

namespace detail {

/// All beams of a pitched scan as 3D points (Eq. 3) in the frame given by `pose` (planar); invalid
/// beams become NaN points so that columns stay aligned.
template <std::floating_point Scalar>
void pitched_row(const PitchedScan<Scalar>& ps, const Point<3, Scalar>& sensor_offset,
                 const Pose2<Scalar>& pose, Point<3, Scalar>* out) {
  const LaserScan<Scalar>& scan = ps.scan;
  const Scalar c = std::cos(ps.pitch), s = std::sin(ps.pitch);
  const Scalar cy = std::cos(pose.theta), sy = std::sin(pose.theta);
  constexpr Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (!scan.is_valid(i)) {
      out[i] = Point<3, Scalar>::Constant(nan);
      continue;
    }
    const Point<2, Scalar>& q = scan.point(i);
    // Eq. (3): R_y(pitch) (x, y, 0)^T + t_s, then the planar pose.
    const Scalar x = c * q.x() + sensor_offset.x(), y = q.y() + sensor_offset.y();
    out[i] = Point<3, Scalar>(pose.x + cy * x - sy * y, pose.y + sy * x + cy * y,
                              -s * q.x() + sensor_offset.z());
  }
}

template <std::floating_point Scalar>
Point<3, Scalar> to_frame(const Pose2<Scalar>& pose, const Point<3, Scalar>& p) {
  const Scalar c = std::cos(pose.theta), s = std::sin(pose.theta);
  const Scalar dx = p.x() - pose.x, dy = p.y() - pose.y;
  return {c * dx + s * dy, -s * dx + c * dy, p.z()};
}

}  // namespace detail

// ---- obstacle points from the stream ---------------------------------------------------------

/// Obstacle points for an ObstacleMap from the pitching scanner's stream, one 2D scan at a time
/// (§4.2). Each scan is turned into 3D points (Eq. 3) and kept in the odometry frame so that the
/// neighbourhood of the floor classification is consistent while the robot moves; a scan is
/// classified once window_steps newer scans have arrived. push() returns that scan's obstacle
/// and artificial (stair) points in the robot frame of the newest pose. Allocation-free after
/// the first scans.
template <std::floating_point Scalar = double>
class PitchingObstacleExtractor {
 public:
  /// An extractor for a scanner whose pitch axis sits at `sensor_offset` on the robot (t_s of
  /// Eq. 3), with these floor-classification parameters; throws invalid_argument for invalid ones.
  explicit PitchingObstacleExtractor(const Point<3, Scalar>& sensor_offset,
                                     const FloorClassifierParams<Scalar>& floor = {})
      : sensor_offset_(sensor_offset), floor_(floor) {
    floor_.validate("PitchingObstacleExtractor");
    if (!sensor_offset_.allFinite())
      detail::throw_invalid("PitchingObstacleExtractor", "sensor_offset must be finite");
    window_ = 2 * floor_.window_steps + 1;
  }

  /// Scans between a scan's arrival and the output of its obstacles.
  [[nodiscard]] std::size_t delay() const { return floor_.window_steps; }
  /// The floor-classification parameters.
  [[nodiscard]] const FloorClassifierParams<Scalar>& floor_params() const { return floor_; }

  /// Forgets the stream (e.g. after a jump of the odometry).
  void reset() { rows_ = 0; }

  /// Adds the next scan, taken at odometry pose `pose`; returns the obstacle points of the scan
  /// delay() scans back, in the robot frame at `pose` (empty during the first delay() scans).
  std::span<const Point<3, Scalar>> push(const PitchedScan<Scalar>& scan,
                                         const Pose2<Scalar>& pose) {
    const std::size_t w = scan.scan.size();
    if (w != width_) {
      width_ = w;
      rows_ = 0;
      buffer_.resize(2 * window_ * w);
      origins_.resize(2 * window_);
    }
    if (rows_ == 2 * window_) {  // slide: keep the newest window_ - 1 rows
      const std::size_t keep = window_ - 1;
      std::copy(buffer_.begin() + static_cast<std::ptrdiff_t>((rows_ - keep) * w), buffer_.end(),
                buffer_.begin());
      std::copy(origins_.begin() + static_cast<std::ptrdiff_t>(rows_ - keep), origins_.end(),
                origins_.begin());
      rows_ = keep;
    }
    detail::pitched_row(scan, sensor_offset_, pose, &buffer_[rows_ * w]);
    const Scalar c = std::cos(pose.theta), s = std::sin(pose.theta);
    origins_[rows_] = Point<3, Scalar>(pose.x + c * sensor_offset_.x() - s * sensor_offset_.y(),
                                       pose.y + s * sensor_offset_.x() + c * sensor_offset_.y(),
                                       sensor_offset_.z());
    ++rows_;
    out_.clear();
    if (rows_ <= floor_.window_steps) return out_;
    const std::size_t m = rows_ - 1 - floor_.window_steps;
    const std::span<const Point<3, Scalar>> grid(buffer_.data(), rows_ * w);
    for (std::size_t col = 0; col < w; ++col) {
      const Point<3, Scalar>& p = grid[m * w + col];
      switch (classify_point(grid, w, rows_, m, col, floor_, &origins_[m])) {
        case PointClass::obstacle:
        case PointClass::wall:
        case PointClass::ceiling:
          out_.push_back(detail::to_frame(pose, p));
          break;
        case PointClass::below_floor:
          if (const auto q = floor_intersection(origins_[m], p))
            out_.push_back(detail::to_frame(pose, *q));
          break;
        default:
          break;
      }
    }
    return out_;
  }

 private:
  Point<3, Scalar> sensor_offset_;
  FloorClassifierParams<Scalar> floor_;
  std::size_t window_{1};
  std::size_t width_{0};
  std::size_t rows_{0};
  std::vector<Point<3, Scalar>> buffer_;   // rows of points in the odometry frame
  std::vector<Point<3, Scalar>> origins_;  // the scanner's position for each row
  std::vector<Point<3, Scalar>> out_;
};

// ---- sweeps (§6.1) ---------------------------------------------------------------------------

/// One pitch sweep as a locally consistent 3D cloud: organised with one row per 2D scan (in
/// acquisition order) and one column per beam, invalid beams NaN, every point in the robot frame
/// at the base pose P_b (the pose of the sweep's first scan).
template <std::floating_point Scalar = double>
struct Sweep {
  Pose2<Scalar> base_pose{};  ///< the robot's odometry pose at the sweep's first scan
  /// the sweep's readings in the base frame, one row per scan (organised)
  Cloud<3, Scalar> cloud{};
  std::vector<Scalar> pitches;       ///< pitch of each row
  std::vector<Pose2<Scalar>> poses;  ///< odometry pose of each row
  /// The scanner's pitch axis (Eq. 3's t_s) for each row, in the base frame: the origin of the
  /// row's beams, from which the floor classification judges each reading's height noise.
  std::vector<Point<3, Scalar>> origins;
  bool starts_after_interruption{false};  ///< began mid-movement after a fast turn

  /// Number of scans (rows) in the sweep.
  [[nodiscard]] std::size_t scan_count() const { return pitches.size(); }
};

/// Parameters of SweepAssembler.
template <std::floating_point Scalar = double>
struct SweepParams {
  /// t_s of Eq. (3).
  Point<3, Scalar> sensor_offset{0, 0, 0};
  /// rad/s: a sweep during which the odometry turns faster than this is dropped (§6.1). The
  /// paper gives no value.
  Scalar max_turn_rate{std::numbers::pi_v<Scalar> / 6};
  /// Sweeps with fewer scans are dropped.
  std::size_t min_scans{5};
};

/// Segments the pitching scanner's stream into sweeps at the reversals of the pitch movement
/// (§6.1) and motion-compensates each 2D scan into the sweep's base pose.
template <std::floating_point Scalar = double>
class SweepAssembler {
 public:
  /// An assembler with these parameters; throws invalid_argument for invalid ones.
  explicit SweepAssembler(const SweepParams<Scalar>& params = {}) : params_(params) {
    detail::require_positive("SweepAssembler", "max_turn_rate", params_.max_turn_rate);
    if (!params_.sensor_offset.allFinite())
      detail::throw_invalid("SweepAssembler", "sensor_offset must be finite");
  }

  /// Adds the next scan (its timestamp is the scan's) with the odometry pose at which it was
  /// taken. Returns true when this scan completed a sweep, which sweep() then holds until the
  /// next call.
  bool push(const PitchedScan<Scalar>& scan, const Pose2<Scalar>& pose) {
    bool completed = false;
    const double t = scan.scan.timestamp();
    if (has_last_) {
      const double dt = t - last_time_;
      const Scalar turn = std::abs(angle_difference(pose.theta, last_pose_.theta));
      if (dt > 0 && turn / static_cast<Scalar>(dt) > params_.max_turn_rate) {
        // Turning fast: the pose shifts are not trusted, the current sweep is dropped (§6.1).
        if (!current_.pitches.empty()) ++interruptions_;
        current_.pitches.clear();
        interrupted_ = true;
        remember(scan, pose, t);
        direction_ = 0;
        return false;
      }
      const Scalar dp = scan.pitch - last_pitch_;
      const int dir = dp > 0 ? 1 : (dp < 0 ? -1 : direction_);
      if (direction_ != 0 && dir != direction_) completed = finish();  // a reversal
      direction_ = dir;
    }
    append(scan, pose);
    remember(scan, pose, t);
    return completed;
  }

  /// The last completed sweep.
  [[nodiscard]] const Sweep<Scalar>& sweep() const { return done_; }
  /// How many sweeps were dropped because the robot turned fast.
  [[nodiscard]] std::size_t interruptions() const { return interruptions_; }
  /// Scans in the sweep being built.
  [[nodiscard]] std::size_t pending_scans() const { return current_.pitches.size(); }

 private:
  void remember(const PitchedScan<Scalar>& scan, const Pose2<Scalar>& pose, double t) {
    last_pitch_ = scan.pitch;
    last_pose_ = pose;
    last_time_ = t;
    has_last_ = true;
  }

  void append(const PitchedScan<Scalar>& scan, const Pose2<Scalar>& pose) {
    const std::size_t w = scan.scan.size();
    if (current_.pitches.empty() || current_.cloud.width != w) {
      current_.pitches.clear();
      current_.poses.clear();
      current_.origins.clear();
      current_.cloud.points.clear();
      current_.cloud.width = w;
      current_.cloud.height = 0;
      current_.base_pose = pose;
      current_.starts_after_interruption = interrupted_;
      interrupted_ = false;
    }
    // The pose shift since P_b strips the robot's movement from this scan (§6.1).
    const Pose2<Scalar> shift = relative(current_.base_pose, pose);
    const std::size_t off = current_.cloud.points.size();
    current_.cloud.points.resize(off + w);
    detail::pitched_row(scan, params_.sensor_offset, shift, &current_.cloud.points[off]);
    ++current_.cloud.height;
    current_.pitches.push_back(scan.pitch);
    current_.poses.push_back(pose);
    const Point<2, Scalar> axis = shift.transform_point(params_.sensor_offset.template head<2>());
    current_.origins.emplace_back(axis.x(), axis.y(), params_.sensor_offset.z());
  }

  bool finish() {
    const bool ok = current_.pitches.size() >= params_.min_scans;
    if (ok) std::swap(done_, current_);
    current_.pitches.clear();
    return ok;
  }

  SweepParams<Scalar> params_;
  Sweep<Scalar> current_{}, done_{};
  Scalar last_pitch_{0};
  Pose2<Scalar> last_pose_{};
  double last_time_{0};
  bool has_last_{false};
  int direction_{0};
  bool interrupted_{false};
  std::size_t interruptions_{0};
};

/// The structure map (§4.3) of one sweep, as a virtual 2D laser scan in the sweep's base frame:
/// per bearing the farthest reading of the whole sweep, max-range readings ignored (§6.1: these
/// locally consistent virtual scans feed any 2D SLAM).
template <std::floating_point Scalar>
[[nodiscard]] LaserScan<Scalar> structure_scan(const Sweep<Scalar>& sweep,
                                               const VirtualMapParams<Scalar>& params = {}) {
  StructureMap<Scalar> map(params);
  map.insert(sweep.cloud.points);
  return map.to_laser_scan();
}

}  // namespace rangenav
