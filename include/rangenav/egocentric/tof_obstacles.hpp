#pragma once
// Obstacle detection in time-of-flight depth images and their virtual scan (3D-perception paper
// 002 §7.2). The (filtered, see scan/tof_filters.hpp) depth image is transformed into the robot
// frame by the camera's extrinsics; the z coordinates form the height image, and a pixel is an
// obstacle when the heights of its neighbourhood W span more than ε_H (Eq. 15), so flat floor is
// never an obstacle whatever its height noise below ε_H. Two refinements over the literal
// Eq. (15) with a 3x3 window: W is the Moore neighbourhood extended along the image column while
// the points stay within window_radius horizontally (a vertical face seen head-on rises only a
// few millimetres per pixel row, so a 3x3 window on it spans far less than ε_H), and only the
// high side of a step is marked, z - W_min > ε_H (which implies W_max - W_min > ε_H), so the
// obstacle's boundary is not moved onto the floor in front of it. Points below floor level become
// artificial obstacles where their ray meets the floor (§4.2), and only obstacles inside the
// virtual corridor count. The virtual scan has one reading per image column (176 for the SR4000)
// over the camera's horizontal aperture: per column the obstacle point nearest to the robot in
// the xy-plane, or max range when the column has none. Fuse it, or the obstacle points
// themselves, with laser scans in one ObstacleMap (egocentric/virtual_map.hpp).

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/egocentric/floor.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/scan/depth_image.hpp"
#include "rangenav/scan/laser_scan.hpp"

namespace rangenav {

template <std::floating_point Scalar = double>
struct HeightImageParams {
  /// ε_H of Eq. (15), m: the smallest obstacle height; not below the sensor's height noise.
  Scalar epsilon_h{0.03};
  /// m: W extends along the image column while points stay this close horizontally.
  Scalar window_radius{0.1};
  /// The most pixels visited each way along the column (8 rows of an SR4000 span 3 cm of a
  /// vertical face 2 m away).
  std::size_t window_steps{8};
  /// The virtual corridor [z_min, z_max] (m): obstacle points outside it are ignored.
  Scalar z_min{0.0};
  Scalar z_max{1.0};
  /// Points lower than -below_floor become artificial obstacles on the floor plane (§4.2).
  Scalar below_floor{0.05};
  /// The sensor's maximum range (m): the reading of a column without obstacles.
  Scalar max_range{5.0};

  void validate(std::string_view where = "HeightImageParams") const {
    detail::require_positive(where, "epsilon_h", epsilon_h);
    detail::require_non_negative(where, "window_radius", window_radius);
    detail::require_finite(where, "z_min", z_min);
    detail::require_finite(where, "z_max", z_max);
    if (!(z_max >= z_min))
      detail::throw_invalid_argument(where, "z_max", z_max,
                                     "must be >= z_min = " + detail::format_value(z_min));
    detail::require_non_negative(where, "below_floor", below_floor);
    detail::require_positive(where, "max_range", max_range);
  }
};

/// Eq. (15) and the virtual scan for one camera. detect() reuses its buffers: after the first
/// frame it allocates nothing.
template <std::floating_point Scalar = double>
class HeightImageObstacleDetector {
 public:
  explicit HeightImageObstacleDetector(const HeightImageParams<Scalar>& params = {})
      : params_(params) {
    params_.validate("HeightImageObstacleDetector");
  }

  [[nodiscard]] const HeightImageParams<Scalar>& params() const { return params_; }

  /// Detects the obstacles of one depth image; `extrinsics` maps the camera body frame (x along
  /// the optical axis, y left, z up; see DepthImage) into the robot frame (z = height above the
  /// floor). Returns the number of obstacle points.
  std::size_t detect(const DepthImage<Scalar>& image, const Transform<3, Scalar>& extrinsics) {
    image.validate("HeightImageObstacleDetector::detect");
    const std::size_t w = image.width(), h = image.height(), n = w * h;
    constexpr Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
    update_rays(image);
    points_.resize(n);
    obstacle_.assign(n, 0);
    const Eigen::Matrix<Scalar, 3, 3> rot = extrinsics.linear();
    const Point<3, Scalar> t = extrinsics.translation();
    for (std::size_t i = 0; i < n; ++i) {
      const Scalar d = image.depth[i];
      points_[i] = DepthImage<Scalar>::is_valid_depth(d)
                       ? Point<3, Scalar>(rot * (d * rays_[i]) + t)
                       : Point<3, Scalar>::Constant(nan);
    }
    const Point<3, Scalar> origin = extrinsics.translation();
    obstacle_points_.clear();
    obstacle_points_.reserve(n);
    for (std::size_t r = 0; r < h; ++r)
      for (std::size_t c = 0; c < w; ++c) {
        const std::size_t i = r * w + c;
        const Point<3, Scalar>& p = points_[i];
        if (!p.allFinite()) continue;
        if (p.z() < -params_.below_floor) {  // a hole or descending stair: §4.2
          if (const auto q = floor_intersection(origin, p)) {
            obstacle_[i] = 1;
            obstacle_points_.push_back(*q);
          }
          continue;
        }
        Scalar lo, hi;
        detail::window_height_range(std::span<const Point<3, Scalar>>(points_), w, h, r, c,
                                    params_.window_radius, params_.window_steps,
                                    params_.below_floor, lo, hi, p.z() - params_.epsilon_h);
        if (p.z() - lo > params_.epsilon_h && p.z() >= params_.z_min &&
            p.z() <= params_.z_max) {  // Eq. (15), inside the corridor
          obstacle_[i] = 1;
          obstacle_points_.push_back(p);
        }
      }
    build_virtual_scan(image, extrinsics);
    return obstacle_points_.size();
  }

  /// The image's points in the robot frame, organised (row-major), NaN where invalid.
  [[nodiscard]] const std::vector<Point<3, Scalar>>& points() const { return points_; }
  /// 1 where a pixel is an obstacle (Eq. 15 or below floor level), row-major.
  [[nodiscard]] const std::vector<std::uint8_t>& obstacle_mask() const { return obstacle_; }
  /// The obstacle points in the robot frame (artificial ones on the floor plane), in pixel order.
  [[nodiscard]] const std::vector<Point<3, Scalar>>& obstacle_points() const {
    return obstacle_points_;
  }
  /// The virtual scan: one beam per image column over the camera's horizontal aperture, counter-
  /// clockwise; per beam the obstacle point nearest in the xy-plane, max range where none.
  [[nodiscard]] LaserScan<Scalar> virtual_scan(double timestamp = 0.0) const {
    return LaserScan<Scalar>(scan_geometry_, scan_ranges_, {}, timestamp);
  }
  /// The ranges of virtual_scan() without building a LaserScan.
  [[nodiscard]] const std::vector<Scalar>& virtual_scan_ranges() const { return scan_ranges_; }
  [[nodiscard]] const ScanGeometry<Scalar>& virtual_scan_geometry() const { return scan_geometry_; }

 private:
  // The body-frame ray of every pixel, scaled so that depth * ray is the point; recomputed only
  // when the intrinsics or the depth kind change.
  void update_rays(const DepthImage<Scalar>& image) {
    const auto& in = image.intrinsics;
    if (rays_.size() == in.width * in.height && in.fx == rays_for_.fx && in.fy == rays_for_.fy &&
        in.cx == rays_for_.cx && in.cy == rays_for_.cy && in.width == rays_for_.width &&
        image.kind == rays_kind_)
      return;
    rays_.resize(in.width * in.height);
    for (std::size_t r = 0; r < in.height; ++r)
      for (std::size_t c = 0; c < in.width; ++c)
        rays_[r * in.width + c] = image.pixel_point(r, c, Scalar(1));
    rays_for_ = in;
    rays_kind_ = image.kind;
  }

  void build_virtual_scan(const DepthImage<Scalar>& image, const Transform<3, Scalar>& extr) {
    const auto& in = image.intrinsics;
    const std::size_t w = in.width;
    // The camera's heading in the robot frame and its horizontal aperture.
    const Point<3, Scalar> axis = extr.linear().col(0);
    const Scalar yaw = std::atan2(axis.y(), axis.x());
    const Scalar fov = std::atan((static_cast<Scalar>(w) / 2) / in.fx) * 2;
    const Scalar inc = fov / static_cast<Scalar>(w);
    scan_geometry_ =
        ScanGeometry<Scalar>{yaw - fov / 2 + inc / 2, inc, w, Scalar(0), params_.max_range};
    scan_ranges_.assign(w, params_.max_range);
    const Scalar lo = yaw - fov / 2;
    for (const auto& p : obstacle_points_) {
      const Scalar range = std::hypot(p.x(), p.y());
      const Scalar f = normalize_angle(detail::fast_atan2(p.y(), p.x()) - lo) / inc;
      if (!(f >= Scalar(0)) || f >= static_cast<Scalar>(w)) continue;
      Scalar& slot = scan_ranges_[static_cast<std::size_t>(f)];
      slot = std::min(slot, range);
    }
  }

  HeightImageParams<Scalar> params_;
  std::vector<Point<3, Scalar>> rays_;
  PinholeIntrinsics<Scalar> rays_for_{};
  DepthKind rays_kind_{DepthKind::radial};
  std::vector<Point<3, Scalar>> points_;
  std::vector<std::uint8_t> obstacle_;
  std::vector<Point<3, Scalar>> obstacle_points_;
  ScanGeometry<Scalar> scan_geometry_{};
  std::vector<Scalar> scan_ranges_;
};

}  // namespace rangenav
