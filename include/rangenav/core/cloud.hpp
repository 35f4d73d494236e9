#pragma once
// Cloud: points with optional per-point attributes (intensity, colour, normal), organised
// (width x height, row-major, invalid points NaN) or not (height == 1). It is what the PCD / PLY
// readers return and what depth images convert to; it models PointCloud over all its points,
// including the NaN points of an organised cloud: use finite_points() for the dense subset.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// An 8-bit RGBA colour.
using Rgba = std::array<std::uint8_t, 4>;

template <int D, class Scalar = double>
/// A cloud of D-dimensional points with optional per-point attributes (see the file comment).
struct Cloud {
  /// The point type, Point<D, Scalar>.
  using point_type = Point<D, Scalar>;

  /// The points; NaN where an organised cloud has no reading.
  std::vector<point_type> points;
  std::vector<float> intensities;   ///< empty, or one per point
  std::vector<Rgba> colors;         ///< empty, or one per point
  std::vector<point_type> normals;  ///< empty, or one per point
  std::size_t width = 0;            ///< points per row; equals size() when not organised
  std::size_t height = 1;           ///< rows; > 1 means organised (row-major)

  /// Number of points (width x height).
  [[nodiscard]] std::size_t size() const { return points.size(); }
  /// True when the cloud has no points.
  [[nodiscard]] bool empty() const { return points.empty(); }
  /// True when the points form an image of height > 1 rows (row-major).
  [[nodiscard]] bool is_organized() const { return height > 1; }
  /// True when there is one intensity per point.
  [[nodiscard]] bool has_intensities() const { return !intensities.empty(); }
  /// True when there is one colour per point.
  [[nodiscard]] bool has_colors() const { return !colors.empty(); }
  /// True when there is one normal per point.
  [[nodiscard]] bool has_normals() const { return !normals.empty(); }

  /// The point at (row, col) of an organised cloud.
  [[nodiscard]] const point_type& at(std::size_t row, std::size_t col) const {
    return points[row * width + col];
  }

  /// Throws invalid_argument when the attribute sizes or width x height disagree with size().
  void validate(std::string_view where = "Cloud") const {
    const auto check = [&](std::size_t n, std::string_view name) {
      if (n != 0 && n != points.size())
        detail::throw_invalid_argument(
            where, name, n,
            "(attribute count) must be 0 or the point count " + std::to_string(points.size()));
    };
    check(intensities.size(), "intensities");
    check(colors.size(), "colors");
    check(normals.size(), "normals");
    if (width * height != points.size())
      detail::throw_invalid_argument(where, "width*height", width * height,
                                     "must equal the point count " + std::to_string(points.size()));
  }
};

/// A 3D cloud in double precision.
using Cloud3d = Cloud<3, double>;
/// A 3D cloud in single precision (what PCL's PointXYZ files hold).
using Cloud3f = Cloud<3, float>;
/// A 2D cloud in double precision.
using Cloud2d = Cloud<2, double>;

namespace traits {
template <int D, class S>
/// Cloud is a PointCloud over all its points (NaN points of an organised cloud included).
struct cloud_access<Cloud<D, S>> {
  /// The cloud's dimension D.
  static constexpr int dimension = D;
  /// The points' scalar type.
  using Scalar = S;
  /// Number of points.
  static std::size_t size(const Cloud<D, S>& c) { return c.points.size(); }
  /// The i-th point.
  static const Point<D, S>& point(const Cloud<D, S>& c, std::size_t i) { return c.points[i]; }
};
}  // namespace traits

}  // namespace rangenav
