#pragma once
// Snapping 2D points to the 32-bit integer grid that Boost.Polygon's voronoi_builder works on
// (its input coordinates must be integers). One copy for every user of the Voronoi diagram: the
// path graph of paper 000 and the alpha-shape hulls of paper 004.

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// A square grid of `resolution` metres whose cells are addressed by 32-bit integers.
struct IntegerGrid {
  using cell_type = std::array<std::int32_t, 2>;  ///< a cell: (x, y) in grid steps

  double resolution = 0.001;  ///< m per grid step

  /// The largest |coordinate| (in grid steps) a snapped point may have; half the int32 range so
  /// that differences of two coordinates still fit.
  static constexpr double limit = double(std::numeric_limits<std::int32_t>::max() / 2);

  /// The grid cell nearest to `p`. Throws invalid_argument, naming `where` and `name`, when `p` is
  /// not finite or does not fit the grid.
  [[nodiscard]] cell_type snap(const Point2d& p, std::string_view where,
                               const std::string& name) const {
    if (!p.allFinite())
      detail::throw_invalid_argument(
          where, name, detail::format_value(p.x()) + " " + detail::format_value(p.y()),
          "must be finite");
    const double gx = std::round(p.x() / resolution);
    const double gy = std::round(p.y() / resolution);
    if (std::abs(gx) > limit || std::abs(gy) > limit)
      detail::throw_invalid_argument(
          where, name, detail::format_value(p.x()) + " " + detail::format_value(p.y()),
          "does not fit the 32-bit grid at resolution " + detail::format_value(resolution));
    return {static_cast<std::int32_t>(gx), static_cast<std::int32_t>(gy)};
  }

  /// The point (m) of a grid cell.
  [[nodiscard]] Point2d to_point(const cell_type& c) const {
    return {c[0] * resolution, c[1] * resolution};
  }
};

}  // namespace rangenav
