#pragma once
// LaserScan: a 2D range scan S = {(d_i, theta_i)} (Eq. 1 of the 3D-perception paper, 002 §2),
// ordered counter-clockwise by bearing, with each beam's Cartesian point p_i =
// (d_i cos theta_i, d_i sin theta_i) (Eq. 2) computed once and cached, as §4.1 asks.
//
// A beam is valid when its range is finite, > 0, >= range_min and < range_max. Invalid beams
// (NaN, inf, 0, below minimum, max-range readings) are data, not errors: they are flagged and
// skipped by the PointCloud adaptor, which exposes the valid points only.

#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// The fixed layout of a scanner's beams.
template <std::floating_point Scalar = double>
struct ScanGeometry {
  Scalar angle_min{0};        ///< bearing of beam 0 (rad)
  Scalar angle_increment{0};  ///< bearing step between beams (rad), > 0
  std::size_t beam_count{0};  ///< number of beams, > 0
  Scalar range_min{0};        ///< shorter readings are invalid (m)
  Scalar range_max{0};        ///< readings at or beyond are invalid (m)

  /// Beams spread evenly over [angle_min, angle_min + fov] with both ends included, e.g.
  /// from_fov(deg_to_rad(270.0), deg_to_rad(0.5), ...) gives the SICK S300's 541 beams.
  [[nodiscard]] static ScanGeometry from_fov(Scalar fov, Scalar resolution, Scalar range_min_m,
                                             Scalar range_max_m) {
    detail::require_positive("ScanGeometry::from_fov", "fov", fov);
    detail::require_positive("ScanGeometry::from_fov", "resolution", resolution);
    const auto n = static_cast<std::size_t>(std::llround(fov / resolution)) + 1;
    return {-fov / 2, resolution, n, range_min_m, range_max_m};
  }

  /// The bearing of beam i (rad).
  [[nodiscard]] Scalar angle(std::size_t i) const {
    return angle_min + static_cast<Scalar>(i) * angle_increment;
  }
  /// The bearing of the last beam (rad).
  [[nodiscard]] Scalar angle_max() const {
    return beam_count == 0 ? angle_min : angle(beam_count - 1);
  }

  /// Throws invalid_argument naming the first violated contract.
  void validate(std::string_view where = "ScanGeometry") const {
    detail::require_finite(where, "angle_min", angle_min);
    detail::require_positive(where, "angle_increment", angle_increment);
    if (beam_count == 0) detail::throw_invalid_argument(where, "beam_count", 0, "must be > 0");
    detail::require_non_negative(where, "range_min", range_min);
    detail::require_positive(where, "range_max", range_max);
    if (!(range_max > range_min))
      detail::throw_invalid_argument(where, "range_max", range_max,
                                     "must exceed range_min = " + detail::format_value(range_min));
    if (static_cast<Scalar>(beam_count - 1) * angle_increment >
        2 * std::numbers::pi_v<Scalar> + angle_increment / 2)
      detail::throw_invalid_argument(where, "beam_count", beam_count,
                                     "times angle_increment exceeds a full turn");
  }
};

/// A 2D laser scan: one range per beam, the beams' Cartesian points (computed once, Eq. (2) of
/// paper 002) and validity flags. It models PointCloud over its valid points.
template <std::floating_point Scalar = double>
class LaserScan {
 public:
  /// The range type.
  using scalar_type = Scalar;
  /// The point type, Point<2, Scalar>.
  using point_type = Point<2, Scalar>;

  /// An empty scan (no beams).
  LaserScan() = default;

  /// A scan with the given geometry and one range per beam; `intensities` is empty or one per
  /// beam. Throws invalid_argument for a bad geometry or mismatched sizes.
  LaserScan(const ScanGeometry<Scalar>& geometry, std::vector<Scalar> ranges,
            std::vector<Scalar> intensities = {}, double timestamp = 0.0)
      : geometry_(geometry),
        ranges_(std::move(ranges)),
        intensities_(std::move(intensities)),
        timestamp_(timestamp) {
    check_and_cache();
  }

  /// A scan whose beam count is ranges.size().
  LaserScan(Scalar angle_min, Scalar angle_increment, Scalar range_min, Scalar range_max,
            std::vector<Scalar> ranges, std::vector<Scalar> intensities = {},
            double timestamp = 0.0)
      : geometry_{angle_min, angle_increment, ranges.size(), range_min, range_max},
        ranges_(std::move(ranges)),
        intensities_(std::move(intensities)),
        timestamp_(timestamp) {
    check_and_cache();
  }

  /// The beam layout.
  [[nodiscard]] const ScanGeometry<Scalar>& geometry() const { return geometry_; }
  /// Number of beams.
  [[nodiscard]] std::size_t size() const { return ranges_.size(); }
  /// True when the scan has no beams.
  [[nodiscard]] bool empty() const { return ranges_.empty(); }
  /// The first beam's bearing (rad).
  [[nodiscard]] Scalar angle_min() const { return geometry_.angle_min; }
  /// The last beam's bearing (rad).
  [[nodiscard]] Scalar angle_max() const { return geometry_.angle_max(); }
  /// The step between beams (rad).
  [[nodiscard]] Scalar angle_increment() const { return geometry_.angle_increment; }
  /// Readings below this are invalid (m).
  [[nodiscard]] Scalar range_min() const { return geometry_.range_min; }
  /// Readings at or beyond this are invalid, "no return" (m).
  [[nodiscard]] Scalar range_max() const { return geometry_.range_max; }
  /// When the scan was taken (s).
  [[nodiscard]] double timestamp() const { return timestamp_; }
  /// Sets when the scan was taken (s).
  void set_timestamp(double t) { timestamp_ = t; }

  /// Every beam's range, valid or not (m).
  [[nodiscard]] const std::vector<Scalar>& ranges() const { return ranges_; }
  /// Beam i's range (m).
  [[nodiscard]] Scalar range(std::size_t i) const { return ranges_[i]; }
  /// Beam i's bearing (rad).
  [[nodiscard]] Scalar angle(std::size_t i) const { return geometry_.angle(i); }
  /// Every beam's intensity; empty when the sensor gave none.
  [[nodiscard]] const std::vector<Scalar>& intensities() const { return intensities_; }
  /// True when there is one intensity per beam.
  [[nodiscard]] bool has_intensities() const { return !intensities_.empty(); }

  /// Whether a range is a valid reading for this scan's limits.
  [[nodiscard]] bool is_valid_range(Scalar r) const {
    return std::isfinite(r) && r > Scalar(0) && r >= geometry_.range_min && r < geometry_.range_max;
  }
  /// False when beam i's reading is NaN, infinite, 0, below range_min or at or beyond range_max.
  [[nodiscard]] bool is_valid(std::size_t i) const { return valid_[i] != 0; }

  /// Cartesian point of beam i (Eq. 2); for invalid beams the point of whatever range is stored.
  [[nodiscard]] const point_type& point(std::size_t i) const { return points_[i]; }
  /// Cartesian points of all beams, in beam order.
  [[nodiscard]] std::span<const point_type> points() const { return points_; }

  /// Indices of the valid beams, increasing.
  [[nodiscard]] const std::vector<std::uint32_t>& valid_indices() const { return valid_indices_; }
  /// Cartesian points of the valid beams, in beam order.
  [[nodiscard]] const std::vector<point_type>& valid_points() const { return valid_points_; }
  /// Number of valid beams.
  [[nodiscard]] std::size_t valid_count() const { return valid_indices_.size(); }

  /// Replaces the ranges (same beam count) and refreshes the cached coordinates.
  void set_ranges(std::vector<Scalar> ranges) {
    if (ranges.size() != geometry_.beam_count)
      detail::throw_invalid_argument(
          "LaserScan::set_ranges", "ranges.size()", ranges.size(),
          "must equal beam_count = " + std::to_string(geometry_.beam_count));
    ranges_ = std::move(ranges);
    update_cache();
  }

 private:
  void check_and_cache() {
    geometry_.validate("LaserScan");
    if (ranges_.size() != geometry_.beam_count)
      detail::throw_invalid_argument(
          "LaserScan", "ranges.size()", ranges_.size(),
          "must equal beam_count = " + std::to_string(geometry_.beam_count));
    if (!intensities_.empty() && intensities_.size() != ranges_.size())
      detail::throw_invalid_argument(
          "LaserScan", "intensities.size()", intensities_.size(),
          "must be 0 or the beam count " + std::to_string(ranges_.size()));
    update_cache();
  }

  void update_cache() {
    const std::size_t n = ranges_.size();
    if (cos_.size() != n) {  // bearings only change with the geometry
      cos_.resize(n);
      sin_.resize(n);
      for (std::size_t i = 0; i < n; ++i) {
        cos_[i] = std::cos(geometry_.angle(i));
        sin_[i] = std::sin(geometry_.angle(i));
      }
    }
    points_.resize(n);
    valid_.assign(n, 0);
    valid_indices_.clear();
    valid_points_.clear();
    for (std::size_t i = 0; i < n; ++i) {
      points_[i] = point_type(ranges_[i] * cos_[i], ranges_[i] * sin_[i]);
      if (is_valid_range(ranges_[i])) {
        valid_[i] = 1;
        valid_indices_.push_back(static_cast<std::uint32_t>(i));
        valid_points_.push_back(points_[i]);
      }
    }
  }

  ScanGeometry<Scalar> geometry_{};
  std::vector<Scalar> ranges_;
  std::vector<Scalar> intensities_;
  double timestamp_{0.0};
  std::vector<Scalar> cos_, sin_;
  std::vector<point_type> points_;
  std::vector<std::uint8_t> valid_;
  std::vector<std::uint32_t> valid_indices_;
  std::vector<point_type> valid_points_;
};

/// A laser scan in double precision.
using LaserScand = LaserScan<double>;
/// A laser scan in single precision.
using LaserScanf = LaserScan<float>;

namespace traits {
/// A LaserScan is a 2D PointCloud of its valid points.
template <class S>
struct cloud_access<LaserScan<S>> {
  /// A scan is two-dimensional.
  static constexpr int dimension = 2;
  /// The range type.
  using Scalar = S;
  /// Number of valid beams.
  static std::size_t size(const LaserScan<S>& s) { return s.valid_count(); }
  /// The i-th valid beam's point (sensor frame).
  static const Point<2, S>& point(const LaserScan<S>& s, std::size_t i) {
    return s.valid_points()[i];
  }
};
}  // namespace traits

}  // namespace rangenav
