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

#include "rangenav/core/cloud.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/egocentric/floor.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/scan/depth_image.hpp"
#include "rangenav/scan/laser_scan.hpp"

namespace rangenav {

/// Parameters of the height-image obstacle detection (Eq. 15 of paper 002) and its virtual scan.
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
  Scalar z_max{1.0};  ///< upper bound of the virtual corridor (m)
  /// Points lower than -below_floor become artificial obstacles on the floor plane (§4.2).
  Scalar below_floor{0.05};
  /// The sensor's maximum range (m): the reading of a column without obstacles.
  Scalar max_range{5.0};

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
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
  /// A detector with these parameters; throws invalid_argument for invalid ones.
  explicit HeightImageObstacleDetector(const HeightImageParams<Scalar>& params = {})
      : params_(params) {
    params_.validate("HeightImageObstacleDetector");
  }

  /// The parameters.
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
    const Eigen::Matrix<Scalar, 3, 3> rot = extrinsics.linear();
    const Point<3, Scalar> t = extrinsics.translation();
    for (std::size_t i = 0; i < n; ++i) {
      const Scalar d = image.depth[i];
      points_[i] = DepthImage<Scalar>::is_valid_depth(d)
                       ? Point<3, Scalar>(rot * (d * rays_[i]) + t)
                       : Point<3, Scalar>::Constant(nan);
    }
    const auto& in = image.intrinsics;
    const Point<3, Scalar> axis = extrinsics.linear().col(0);
    const Scalar fov = std::atan((static_cast<Scalar>(w) / 2) / in.fx) * 2;
    return detect_points(w, h, extrinsics.translation(), std::atan2(axis.y(), axis.x()), fov);
  }

  /// The same for an organised cloud (e.g. an RGB-D frame; invalid points NaN) given in the
  /// camera body frame. The virtual scan then spans the bearings of the cloud's valid points.
  std::size_t detect(const Cloud<3, Scalar>& cloud, const Transform<3, Scalar>& extrinsics) {
    cloud.validate("HeightImageObstacleDetector::detect");
    if (cloud.empty())
      detail::throw_invalid("HeightImageObstacleDetector::detect", "the cloud is empty");
    points_.resize(cloud.size());
    Scalar lo = std::numeric_limits<Scalar>::infinity(), hi = -lo;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      points_[i] = extrinsics * cloud.points[i];
      if (!points_[i].allFinite()) continue;
      const Scalar b = std::atan2(points_[i].y(), points_[i].x());
      lo = std::min(lo, b);
      hi = std::max(hi, b);
    }
    if (!(hi > lo)) lo = hi = 0;
    const Scalar fov = std::max(hi - lo, Scalar(1e-6)) * (Scalar(1) + Scalar(1e-9));
    return detect_points(cloud.width, cloud.height, extrinsics.translation(), (lo + hi) / 2, fov);
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
  /// The beam layout of virtual_scan().
  [[nodiscard]] const ScanGeometry<Scalar>& virtual_scan_geometry() const { return scan_geometry_; }

 private:
  // Eq. (15) on points_ (w x h, robot frame) and the virtual scan over [yaw - fov/2, yaw + fov/2].
  std::size_t detect_points(std::size_t w, std::size_t h, const Point<3, Scalar>& origin,
                            Scalar yaw, Scalar fov) {
    const std::size_t n = w * h;
    constexpr Scalar inf = std::numeric_limits<Scalar>::infinity();
    constexpr Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
    obstacle_.assign(n, 0);
    obstacle_points_.clear();
    obstacle_points_.reserve(n);
    // Structure of arrays for the window test: heights that count (+inf: invalid or below floor)
    // and the horizontal position (NaN: invalid).
    zc_.resize(n);
    x_.resize(n);
    y_.resize(n);
    moore_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Point<3, Scalar>& p = points_[i];
      const bool valid = p.allFinite();
      x_[i] = valid ? p.x() : nan;
      y_[i] = valid ? p.y() : nan;
      zc_[i] = valid && p.z() >= -params_.below_floor ? p.z() : inf;
    }
    // The Moore-neighbourhood minimum, separably: along the rows into moore_, then the columns.
    for (std::size_t r = 0; r < h; ++r) {
      const Scalar* z = &zc_[r * w];
      Scalar* m = &moore_[r * w];
      for (std::size_t c = 0; c < w; ++c) {
        Scalar v = z[c];
        if (c > 0) v = std::min(v, z[c - 1]);
        if (c + 1 < w) v = std::min(v, z[c + 1]);
        m[c] = v;
      }
    }
    col_.resize(w);
    std::vector<Scalar>& above = col_;  // the previous row's row minima
    for (std::size_t r = 0; r < h; ++r) {
      Scalar* m = &moore_[r * w];
      for (std::size_t c = 0; c < w; ++c) {
        const Scalar here = m[c];
        Scalar v = here;
        if (r > 0) v = std::min(v, above[c]);
        if (r + 1 < h) v = std::min(v, moore_[(r + 1) * w + c]);
        above[c] = here;
        m[c] = v;
      }
    }
    // A lower bound of every W: the minimum over the whole column window of +-window_steps rows
    // (van Herk / Gil-Werman: prefix and suffix minima over blocks of 2 steps + 1 rows, three
    // comparisons per pixel). A point not more than ε_H above it is no obstacle, and the exact
    // walk along the column, which stops where the points leave window_radius, is skipped.
    const auto steps = static_cast<std::ptrdiff_t>(params_.window_steps);
    const auto hh = static_cast<std::ptrdiff_t>(h);
    const std::size_t block = 2 * params_.window_steps + 1;
    prefix_.resize(n);
    suffix_.resize(n);
    for (std::size_t r0 = 0; r0 < h; r0 += block) {
      const std::size_t r1 = std::min(r0 + block, h);
      for (std::size_t c = 0; c < w; ++c)
        prefix_[r0 * w + c] = zc_[r0 * w + c];
      for (std::size_t r = r0 + 1; r < r1; ++r)
        for (std::size_t c = 0; c < w; ++c)
          prefix_[r * w + c] = std::min(prefix_[(r - 1) * w + c], zc_[r * w + c]);
      for (std::size_t c = 0; c < w; ++c)
        suffix_[(r1 - 1) * w + c] = zc_[(r1 - 1) * w + c];
      for (std::size_t r = r1 - 1; r-- > r0;)
        for (std::size_t c = 0; c < w; ++c)
          suffix_[r * w + c] = std::min(suffix_[(r + 1) * w + c], zc_[r * w + c]);
    }
    const Scalar radius_sq = params_.window_radius * params_.window_radius;
    for (std::size_t r = 0; r < h; ++r)
      for (std::size_t c = 0; c < w; ++c) {
        const std::size_t i = r * w + c;
        const Point<3, Scalar>& p = points_[i];
        if (!p.allFinite()) continue;
        const Scalar z = p.z();
        if (z < -params_.below_floor) {  // a hole or descending stair: §4.2
          if (const auto q = floor_intersection(origin, p)) {
            obstacle_[i] = 1;
            obstacle_points_.push_back(*q);
          }
          continue;
        }
        if (z < params_.z_min || z > params_.z_max) continue;  // outside the corridor
        // Eq. (15) on W = Moore neighbourhood + the column within window_radius: is the point
        // more than ε_H above the lowest point of W?
        const Scalar threshold = z - params_.epsilon_h;
        Scalar lo = moore_[i];
        if (!(lo < threshold)) {
          // The column window [r - steps, r + steps] clamped to the image spans at most two
          // blocks: its minimum is min(suffix at its top, prefix at its bottom).
          const std::size_t top = r > params_.window_steps ? r - params_.window_steps : 0;
          const std::size_t bottom = std::min(r + params_.window_steps, h - 1);
          const Scalar bound = top / block == bottom / block
                                   ? column_min(top, bottom, c, w)
                                   : std::min(suffix_[top * w + c], prefix_[bottom * w + c]);
          if (!(bound < threshold)) continue;  // flat within ε_H: no obstacle
        }
        for (int dir = -1; dir <= 1 && !(lo < threshold); dir += 2)
          for (std::ptrdiff_t k = 2; k <= steps; ++k) {
            const std::ptrdiff_t rr = static_cast<std::ptrdiff_t>(r) + dir * k;
            if (rr < 0 || rr >= hh) break;
            const std::size_t j = static_cast<std::size_t>(rr) * w + c;
            const Scalar dx = x_[j] - x_[i], dy = y_[j] - y_[i];
            if (dx * dx + dy * dy > radius_sq) break;  // NaN (invalid): not a break
            lo = std::min(lo, zc_[j]);
            if (lo < threshold) break;
          }
        if (lo < threshold) {
          obstacle_[i] = 1;
          obstacle_points_.push_back(p);
        }
      }
    build_virtual_scan(w, yaw, fov);
    return obstacle_points_.size();
  }

  // The minimum of zc_ over rows [top, bottom] of column c when both lie in one block (only at
  // the image's last, shorter block or when the window is clamped).
  Scalar column_min(std::size_t top, std::size_t bottom, std::size_t c, std::size_t w) const {
    Scalar v = zc_[top * w + c];
    for (std::size_t r = top + 1; r <= bottom; ++r)
      v = std::min(v, zc_[r * w + c]);
    return v;
  }

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

  void build_virtual_scan(std::size_t w, Scalar yaw, Scalar fov) {
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
  std::vector<Scalar> zc_, x_, y_, moore_, col_, prefix_, suffix_;
  std::vector<std::uint8_t> obstacle_;
  std::vector<Point<3, Scalar>> obstacle_points_;
  ScanGeometry<Scalar> scan_geometry_{};
  std::vector<Scalar> scan_ranges_;
};

}  // namespace rangenav
