#pragma once
// Simulated range sensors looking into a World from a planar robot pose:
//   LaserScanner2D   a 2D laser (default SICK S300: 270 deg at 0.5 deg, 541 beams), any mounting;
//   PitchingScanner  a 2D laser continuously pitched about its y axis in a nodding motion over an
//                    area of interest [pitch_min, pitch_max] (paper 002 §3.3): one 2D scan every
//                    13.32 ms at the current pitch, returned as a PitchedScan (Eq. 3 of paper
//                    002 turns it into 3D points with pitched_points());
//   TofCamera        a time-of-flight camera (default SwissRanger SR4000: 176 x 144 pixels,
//                    43 x 34 deg), on a pan-tilt mount, with distance-dependent noise, an amplitude
//                    channel falling with the squared distance, and jump-edge ("mixed pixel")
//                    artefacts at depth discontinuities (paper 002 §7.1).
// Randomness comes from the engine passed in: the same engine state gives the same readings.
// The robot frame is x forward, y left, z up with z = 0 on the floor.

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/scan/depth_image.hpp"
#include "rangenav/scan/laser_scan.hpp"
#include "rangenav/scan/pitching.hpp"
#include "rangenav/sim/world.hpp"

namespace rangenav::sim {

/// The 3D transform of a planar robot pose (robot frame -> world frame).
[[nodiscard]] inline Transform3d robot_transform(const Pose2d& pose) {
  Transform3d t = Transform3d::Identity();
  t.linear() = Eigen::AngleAxisd(pose.theta, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  t.translation() = Point3d(pose.x, pose.y, 0);
  return t;
}

/// A mounting transform: translation (x, y, z) and yaw / pitch / roll (applied as
/// Rz(yaw) Ry(pitch) Rx(roll); positive pitch tilts the sensor's x axis downwards as in Eq. 3 of
/// paper 002).
[[nodiscard]] inline Transform3d mounting(double x, double y, double z, double yaw = 0,
                                          double pitch = 0, double roll = 0) {
  Transform3d t = Transform3d::Identity();
  t.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  t.translation() = Point3d(x, y, z);
  return t;
}

/// Range noise and dropouts shared by the laser scanners.
struct RangeNoise {
  double sigma{0.01};               ///< Gaussian range noise (m)
  double dropout_probability{0.0};  ///< chance that a beam returns a max-range reading

  /// Throws invalid_argument for a negative sigma or a dropout probability outside [0, 1].
  void validate(std::string_view where) const {
    detail::require_non_negative(where, "noise.sigma", sigma);
    if (!(dropout_probability >= 0 && dropout_probability <= 1))
      detail::throw_invalid_argument(where, "noise.dropout_probability", dropout_probability,
                                     "must be in [0, 1]");
  }

  /// The reading for a true range (inf = no return): max-range readings for misses and
  /// dropouts, otherwise the range plus noise (never negative).
  template <class Engine>
  double apply(double range, double range_max, Engine& rng) const {
    if (dropout_probability > 0 &&
        std::uniform_real_distribution<double>(0.0, 1.0)(rng) < dropout_probability)
      return range_max;
    if (!(range < range_max)) return range_max;
    if (sigma > 0) range += std::normal_distribution<double>(0.0, sigma)(rng);
    return std::max(range, 0.0);
  }
};

// ---- 2D laser scanner ---------------------------------------------------------------------

/// Parameters of the simulated 2D laser scanner.
struct LaserScannerParams {
  /// SICK S300: 270 deg at 0.5 deg (541 beams), readings from 0.05 m to 30 m.
  ScanGeometry<double> geometry =
      ScanGeometry<double>::from_fov(deg_to_rad(270.0), deg_to_rad(0.5), 0.05, 30.0);
  /// Sensor frame in the robot frame; the default sits level at 0.30 m on the robot's centre.
  Transform3d mount = mounting(0, 0, 0.30);
  RangeNoise noise{};  ///< range noise and dropouts
};

/// A simulated 2D laser scanner (a SICK S300 by default).
class LaserScanner2D {
 public:
  /// A scanner with these parameters; throws invalid_argument for invalid ones.
  explicit LaserScanner2D(const LaserScannerParams& params = {}) : params_(params) {
    params_.geometry.validate("LaserScanner2D");
    params_.noise.validate("LaserScanner2D");
    if (!is_rigid(params_.mount))
      detail::throw_invalid("LaserScanner2D", "mount must be a finite rigid transform");
    const auto& r = params_.mount.linear();
    level_ = std::abs(r(2, 2) - 1.0) < 1e-12;
    directions_.resize(params_.geometry.beam_count);
    for (std::size_t i = 0; i < directions_.size(); ++i) {
      const double a = params_.geometry.angle(i);
      directions_[i] = r * Point3d(std::cos(a), std::sin(a), 0);
    }
  }

  /// The parameters.
  [[nodiscard]] const LaserScannerParams& params() const { return params_; }

  /// The true hit of every beam from the robot pose (no noise).
  [[nodiscard]] std::vector<RayHit> cast(const World& world, const Pose2d& robot) const {
    std::vector<RayHit> hits(directions_.size());
    for_each_hit(world, robot, [&](std::size_t i, const RayHit& h) { hits[i] = h; });
    return hits;
  }

  /// Ranges with noise and dropouts into `ranges` (resized to the beam count).
  template <class Engine>
  void ranges_into(const World& world, const Pose2d& robot, Engine& rng,
                   std::vector<double>& ranges) const {
    ranges.resize(directions_.size());
    for_each_hit(world, robot, [&](std::size_t i, const RayHit& h) {
      ranges[i] = params_.noise.apply(h.range, params_.geometry.range_max, rng);
    });
  }

  /// One scan from the robot pose.
  template <class Engine>
  [[nodiscard]] LaserScan<double> scan(const World& world, const Pose2d& robot, Engine& rng,
                                       double timestamp = 0.0) const {
    std::vector<double> ranges;
    ranges_into(world, robot, rng, ranges);
    return LaserScan<double>(params_.geometry, std::move(ranges), {}, timestamp);
  }

 private:
  template <class F>
  void for_each_hit(const World& world, const Pose2d& robot, F&& f) const {
    const Transform3d t = robot_transform(robot) * params_.mount;
    const Point3d o = t.translation();
    const double range_max = params_.geometry.range_max;
    if (level_) {
      const double c = std::cos(robot.theta), s = std::sin(robot.theta);
      for (std::size_t i = 0; i < directions_.size(); ++i) {
        const Point3d& d = directions_[i];
        f(i, world.cast_ray_2d({o.x(), o.y()}, {c * d.x() - s * d.y(), s * d.x() + c * d.y()},
                               o.z(), range_max));
      }
    } else {
      const Eigen::Matrix3d robot_rotation = robot_transform(robot).linear();
      for (std::size_t i = 0; i < directions_.size(); ++i)
        f(i, world.cast_ray(o, robot_rotation * directions_[i], range_max));
    }
  }

  LaserScannerParams params_;
  bool level_{true};
  std::vector<Point3d> directions_;  ///< beam directions in the robot frame
};

// ---- continuously pitching scanner --------------------------------------------------------

/// Parameters of the simulated continuously pitching scanner (paper 002 §3.3).
struct PitchingScannerParams {
  /// SICK LMS 2xx in the mode of paper 002 §3.3: 180 deg at 1 deg (181 beams) in 13.32 ms.
  ScanGeometry<double> geometry =
      ScanGeometry<double>::from_fov(std::numbers::pi, deg_to_rad(1.0), 0.05, 30.0);
  double scan_period{0.01332};  ///< s per 2D scan
  /// Area of interest [pitch_min, pitch_max] (rad, positive looks down, Eq. 3).
  double pitch_min{deg_to_rad(-10.0)};
  double pitch_max{deg_to_rad(40.0)};  ///< the most downward pitch (rad)
  /// Pitch rate (rad/s); the default turns 1 deg per 2D scan.
  double pitch_rate{deg_to_rad(1.0) / 0.01332};
  /// t_s of Eq. 3: the scanner's pitch axis in the robot frame.
  Point3d sensor_offset{0.15, 0.0, 0.55};
  RangeNoise noise{};  ///< range noise and dropouts
};

/// A simulated continuously pitching 2D scanner: one PitchedScan per scan period, nodding
/// between pitch_min and pitch_max.
class PitchingScanner {
 public:
  /// A scanner with these parameters; throws invalid_argument for invalid ones.
  explicit PitchingScanner(const PitchingScannerParams& params = {}) : params_(params) {
    constexpr std::string_view where = "PitchingScanner";
    params_.geometry.validate(where);
    params_.noise.validate(where);
    detail::require_positive(where, "scan_period", params_.scan_period);
    detail::require_positive(where, "pitch_rate", params_.pitch_rate);
    detail::require_finite(where, "pitch_min", params_.pitch_min);
    detail::require_finite(where, "pitch_max", params_.pitch_max);
    if (!(params_.pitch_max > params_.pitch_min))
      detail::throw_invalid_argument(
          where, "pitch_max", params_.pitch_max,
          "must exceed pitch_min = " + detail::format_value(params_.pitch_min));
    if (!params_.sensor_offset.allFinite())
      detail::throw_invalid(where, "sensor_offset must be finite");
  }

  /// The parameters.
  [[nodiscard]] const PitchingScannerParams& params() const { return params_; }

  /// Time of the k-th 2D scan (k * scan_period).
  [[nodiscard]] double scan_time(std::size_t k) const {
    return static_cast<double>(k) * params_.scan_period;
  }

  /// Time of one full nod (pitch_min -> pitch_max -> pitch_min).
  [[nodiscard]] double nod_period() const {
    return 2 * (params_.pitch_max - params_.pitch_min) / params_.pitch_rate;
  }

  /// The pitch at time t: a triangle wave starting at pitch_min at t = 0 and rising first.
  [[nodiscard]] double pitch_at(double t) const {
    const double span = params_.pitch_max - params_.pitch_min;
    double phase = std::fmod(t * params_.pitch_rate, 2 * span);
    if (phase < 0) phase += 2 * span;
    return params_.pitch_min + (phase <= span ? phase : 2 * span - phase);
  }

  /// The true hits of the scan at `pitch` from the robot pose (no noise).
  [[nodiscard]] std::vector<RayHit> cast(const World& world, const Pose2d& robot,
                                         double pitch) const {
    std::vector<RayHit> hits(params_.geometry.beam_count);
    for_each_hit(world, robot, pitch, [&](std::size_t i, const RayHit& h) { hits[i] = h; });
    return hits;
  }

  /// The 2D scan taken at time t (at pitch_at(t)), tagged with its pitch and time.
  template <class Engine>
  [[nodiscard]] PitchedScan<double> scan(const World& world, const Pose2d& robot, double t,
                                         Engine& rng) const {
    const double pitch = pitch_at(t);
    std::vector<double> ranges(params_.geometry.beam_count);
    for_each_hit(world, robot, pitch, [&](std::size_t i, const RayHit& h) {
      ranges[i] = params_.noise.apply(h.range, params_.geometry.range_max, rng);
    });
    return {LaserScan<double>(params_.geometry, std::move(ranges), {}, t), pitch};
  }

 private:
  template <class F>
  void for_each_hit(const World& world, const Pose2d& robot, double pitch, F&& f) const {
    const Transform3d t = robot_transform(robot);
    const Point3d o = t * params_.sensor_offset;
    const Point3d zero = Point3d::Zero();
    for (std::size_t i = 0; i < params_.geometry.beam_count; ++i) {
      // Eq. (3) of paper 002 with d = 1 and t_s = 0: the beam's unit direction in the robot frame.
      const Point3d dir = pitched_point(1.0, params_.geometry.angle(i), pitch, zero);
      f(i, world.cast_ray(o, t.linear() * dir, params_.geometry.range_max));
    }
  }

  PitchingScannerParams params_;
};

// ---- time-of-flight camera ----------------------------------------------------------------

/// Parameters of the simulated time-of-flight camera.
struct TofCameraParams {
  /// SwissRanger SR4000: 176 x 144 pixels, 43 x 34 deg.
  PinholeIntrinsics<double> intrinsics =
      PinholeIntrinsics<double>::from_fov(176, 144, deg_to_rad(43.0), deg_to_rad(34.0));
  /// The pan-tilt unit's base in the robot frame (camera looking along its x axis).
  Transform3d mount = mounting(0.1, 0, 1.1);
  double pan{0};                   ///< rad about the mount's z axis, positive turns left
  double tilt{0};                  ///< rad about the panned y axis, positive looks down (as Eq. 3)
  double range_max{5.0};           ///< no return beyond (the SR4000's non-ambiguity range)
  double noise_sigma_0{0.005};     ///< depth noise sigma(d) = noise_sigma_0 + noise_sigma_2 d^2
  double noise_sigma_2{0.002};     ///< (m / m^2)
  double amplitude_at_1m{1000.0};  ///< amplitude = amplitude_at_1m / d^2
  bool jump_edges{true};           ///< mix depths on pixels that straddle a discontinuity
  double jump_threshold{0.05};     ///< depth step (m) that counts as a discontinuity
  std::size_t edge_subsamples{4};  ///< k x k rays per straddling pixel
};

/// A simulated time-of-flight camera on a pan-tilt head: radial depth with noise, amplitude,
/// and mixed pixels at jump edges (paper 002 §7.1).
class TofCamera {
 public:
  /// A camera with these parameters; throws invalid_argument for invalid ones.
  explicit TofCamera(const TofCameraParams& params = {}) : params_(params) {
    constexpr std::string_view where = "TofCamera";
    params_.intrinsics.validate(where);
    if (!is_rigid(params_.mount))
      detail::throw_invalid(where, "mount must be a finite rigid transform");
    detail::require_finite(where, "pan", params_.pan);
    detail::require_finite(where, "tilt", params_.tilt);
    detail::require_positive(where, "range_max", params_.range_max);
    detail::require_non_negative(where, "noise_sigma_0", params_.noise_sigma_0);
    detail::require_non_negative(where, "noise_sigma_2", params_.noise_sigma_2);
    detail::require_positive(where, "amplitude_at_1m", params_.amplitude_at_1m);
    detail::require_positive(where, "jump_threshold", params_.jump_threshold);
    if (params_.edge_subsamples == 0 || params_.edge_subsamples > 16)
      detail::throw_invalid_argument(where, "edge_subsamples", params_.edge_subsamples,
                                     "must be in [1, 16]");
  }

  /// The parameters (pan and tilt as last set).
  [[nodiscard]] const TofCameraParams& params() const { return params_; }

  /// Points the camera: pan and tilt in rad (see TofCameraParams); throws for non-finite values.
  void set_pan_tilt(double pan, double tilt) {
    detail::require_finite("TofCamera::set_pan_tilt", "pan", pan);
    detail::require_finite("TofCamera::set_pan_tilt", "tilt", tilt);
    params_.pan = pan;
    params_.tilt = tilt;
  }

  /// Camera body frame (x along the optical axis, y left, z up) in the robot frame.
  [[nodiscard]] Transform3d camera_to_robot() const {
    return params_.mount * mounting(0, 0, 0, params_.pan, params_.tilt);
  }

  /// Unit ray (camera body frame) through image position (u, v) = (column, row), continuous.
  [[nodiscard]] Point3d ray(double u, double v) const {
    const auto& k = params_.intrinsics;
    return Point3d(1.0, -(u - k.cx) / k.fx, -(v - k.cy) / k.fy).normalized();
  }

  /// The true radial distance of every pixel centre (inf = no return within range_max).
  [[nodiscard]] std::vector<double> true_depth(const World& world, const Pose2d& robot) const {
    const Transform3d t = robot_transform(robot) * camera_to_robot();
    const auto& k = params_.intrinsics;
    std::vector<double> depth(k.width * k.height);
    for (std::size_t r = 0; r < k.height; ++r)
      for (std::size_t c = 0; c < k.width; ++c)
        depth[r * k.width + c] = cast(world, t, static_cast<double>(c), static_cast<double>(r));
    return depth;
  }

  /// One frame: radial depth (NaN = no return) and amplitude, with noise and jump edges.
  template <class Engine>
  [[nodiscard]] DepthImage<double> capture(const World& world, const Pose2d& robot, Engine& rng,
                                           double timestamp = 0.0) const {
    const Transform3d t = robot_transform(robot) * camera_to_robot();
    const auto& k = params_.intrinsics;
    const std::size_t w = k.width, h = k.height;
    const std::vector<double> centre = true_depth(world, robot);
    DepthImage<double> image;
    image.intrinsics = k;
    image.kind = DepthKind::radial;
    image.timestamp = timestamp;
    image.depth.assign(w * h, std::numeric_limits<double>::quiet_NaN());
    image.amplitude.assign(w * h, 0.0);
    const double thr = params_.jump_threshold;
    const auto jump = [thr](double a, double b) {
      if (std::isinf(a) || std::isinf(b)) return std::isinf(a) != std::isinf(b);
      return std::abs(a - b) > thr;
    };
    const std::size_t n = params_.edge_subsamples;
    for (std::size_t r = 0; r < h; ++r)
      for (std::size_t c = 0; c < w; ++c) {
        const std::size_t i = r * w + c;
        double d = centre[i];
        double weight = std::isinf(d) ? 0.0 : 1.0 / (d * d);  // returned power ~ 1 / d^2
        bool straddles = false;
        if (params_.jump_edges)
          straddles = (c > 0 && jump(d, centre[i - 1])) || (c + 1 < w && jump(d, centre[i + 1])) ||
                      (r > 0 && jump(d, centre[i - w])) || (r + 1 < h && jump(d, centre[i + w]));
        if (straddles) {
          // Mixed pixel (paper 002 §7.1): the pixel's footprint sees both surfaces and the
          // camera reports the power-weighted mean of their distances.
          double sum_w = 0, sum_wd = 0, lo = std::numeric_limits<double>::infinity(), hi = 0;
          for (std::size_t a = 0; a < n; ++a)
            for (std::size_t b = 0; b < n; ++b) {
              const double du = (static_cast<double>(b) + 0.5) / static_cast<double>(n) - 0.5;
              const double dv = (static_cast<double>(a) + 0.5) / static_cast<double>(n) - 0.5;
              const double s =
                  cast(world, t, static_cast<double>(c) + du, static_cast<double>(r) + dv);
              lo = std::min(lo, s);
              hi = std::max(hi, s);
              if (std::isinf(s)) continue;
              sum_w += 1.0 / (s * s);
              sum_wd += 1.0 / s;
            }
          if (jump(lo, hi)) {
            const double samples = static_cast<double>(n * n);
            d = sum_w > 0 ? sum_wd / sum_w : std::numeric_limits<double>::infinity();
            weight = sum_w / samples;
          }
        }
        if (std::isinf(d)) continue;
        const double sigma = params_.noise_sigma_0 + params_.noise_sigma_2 * d * d;
        const double noisy = sigma > 0 ? d + std::normal_distribution<double>(0.0, sigma)(rng) : d;
        image.depth[i] = std::max(noisy, 1e-6);
        image.amplitude[i] = params_.amplitude_at_1m * weight;
      }
    return image;
  }

  /// How a jump-edge filter did on this camera's frame, judged by the truth (`true_depth()`):
  /// on the filter's input `before` (the median may carry a mixed value into a neighbour), a
  /// mixed pixel reads farther than max(10 cm, 5 sigma(d)) from the true depth of its centre; a
  /// real edge pixel reads its true depth and has a 4-neighbour at least `edge_step` deeper (or
  /// without a return). `after` is the filter's output; border pixels are not judged.
  struct JumpEdgeScore {
    std::size_t mixed = 0;          ///< mixed pixels in the filter's input
    std::size_t mixed_removed = 0;  ///< of them, removed by the filter
    std::size_t edges = 0;          ///< real edge pixels in the filter's input
    std::size_t edges_kept = 0;     ///< of them, kept by the filter
  };
  /// Scores a jump-edge filter (see JumpEdgeScore); `edge_step` (m) defines a real edge.
  [[nodiscard]] JumpEdgeScore score_jump_edges(const std::vector<double>& truth,
                                               const DepthImage<double>& before,
                                               const DepthImage<double>& after,
                                               double edge_step = 0.3) const {
    constexpr std::string_view where = "TofCamera::score_jump_edges";
    const std::size_t w = before.width(), h = before.height();
    if (w * h == 0 || before.depth.size() != w * h || truth.size() != w * h ||
        after.depth.size() != w * h)
      detail::throw_invalid(where, "truth, before and after must be frames of the same size");
    JumpEdgeScore s;
    const auto valid = [](double d) { return DepthImage<double>::is_valid_depth(d); };
    for (std::size_t r = 1; r + 1 < h; ++r)
      for (std::size_t c = 1; c + 1 < w; ++c) {
        const std::size_t i = r * w + c;
        const double d = before.depth[i], t = truth[i];
        if (!valid(d) || !std::isfinite(t)) continue;
        const bool removed = !valid(after.depth[i]);
        const double sigma = params_.noise_sigma_0 + params_.noise_sigma_2 * t * t;
        if (std::abs(d - t) > std::max(0.1, 5 * sigma)) {
          ++s.mixed;
          s.mixed_removed += removed ? 1 : 0;
          continue;
        }
        bool edge = false;
        for (const std::size_t j : {i - 1, i + 1, i - w, i + w})
          edge = edge || !(truth[j] < t + edge_step);
        if (edge) {
          ++s.edges;
          s.edges_kept += removed ? 0 : 1;
        }
      }
    return s;
  }

 private:
  /// Distance along the ray through (u, v), or inf.
  [[nodiscard]] double cast(const World& world, const Transform3d& t, double u, double v) const {
    return world.cast_ray(t.translation(), t.linear() * ray(u, v), params_.range_max).range;
  }

  TofCameraParams params_;
};

}  // namespace rangenav::sim
