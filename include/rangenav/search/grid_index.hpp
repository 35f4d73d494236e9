#pragma once
// A growing uniform-grid index for 2D point maps (models NearestNeighborSearch). Points are
// appended and bucketed into square cells of `cell_size` kept in a dense array over the cells'
// bounding box (grown geometrically when a point falls outside), so an insertion is O(1)
// amortised and a query bounded by r visits the (2 ceil(r / cell_size) + 1)^2 cells around the
// query, ring by ring, stopping as soon as the next ring cannot hold a closer point. With the
// rejection radii of ICP (a few tenths of a metre) and a sparse map (points eps_D apart) that
// is a handful of cells; it beats the GrowingKdTree's chain of trees on the MIT CSAIL log (see
// docs/benchmarks.md, bench_slam_relations: the same mapper with either index).
//
// Points that would grow the array beyond `max_cells` cells (a stray reading kilometres away)
// go to an overflow list that every query scans linearly. A query from outside the array meets
// no point before the ring that reaches the array's nearest cell; when the rings up to there
// hold more cells than the index holds points, the query scans the points instead (a query
// kilometres off the map would otherwise visit millions of empty cells). Indices are stable
// (insertion order), as in GrowingKdTree.
//
// Memory: 16 B per point (double) + 4 B per point (bucket chain) + 4 B per cell of the
// bounding box; memory_bytes() reports the exact figure.

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/search/nearest_neighbor_search.hpp"

namespace rangenav {

/// Parameters of GridIndex2.
template <std::floating_point Scalar = double>
struct GridIndexParams {
  Scalar cell_size = Scalar(0.25);               ///< m, edge of a cell
  std::size_t max_cells = std::size_t(1) << 24;  ///< cap of the dense array (64 MB)

  /// Throws invalid_argument unless cell_size is finite and > 0 and max_cells >= 1.
  void validate() const {
    detail::require_positive("GridIndex", "cell_size", cell_size);
    if (max_cells < 1)
      detail::throw_invalid_argument("GridIndex", "max_cells", max_cells, "must be >= 1");
  }
};

/// A growing uniform-grid index over 2D points (see the file comment). Models
/// NearestNeighborSearch; indices are stable (insertion order of the finite points).
template <std::floating_point Scalar = double>
class GridIndex2 : public SearchQueries<GridIndex2<Scalar>, 2, Scalar> {
 public:
  static constexpr int dimension = 2;   ///< always 2
  using scalar_type = Scalar;           ///< coordinate type
  using point_type = Point<2, Scalar>;  ///< a stored point (m)

  /// Throws invalid_argument for a cell size that is not finite and > 0.
  explicit GridIndex2(GridIndexParams<Scalar> params = {}) : params_(params) {
    params_.validate();
    inv_cell_ = Scalar(1) / params_.cell_size;
  }

  /// Appends the finite points of a cloud; returns how many were appended.
  template <PointCloudOf<2> C>
  std::size_t insert(const C& cloud) {
    const std::size_t before = points_.size();
    const std::size_t n = traits::size(cloud);
    points_.reserve(before + n);
    next_.reserve(before + n);
    for (std::size_t i = 0; i < n; ++i) {
      const point_type p = traits::point(cloud, i).template cast<Scalar>();
      if (p.allFinite()) add(p);
    }
    return points_.size() - before;
  }

  /// Appends one point; returns false (and stores nothing) when it is not finite.
  bool insert_point(const point_type& p) {
    if (!p.allFinite()) return false;
    add(p);
    return true;
  }

  /// Removes every point; the parameters stay.
  void clear() {
    points_.clear();
    next_.clear();
    heads_.clear();
    overflow_.clear();
    nx_ = ny_ = 0;
  }

  /// Number of stored points.
  [[nodiscard]] std::size_t size() const { return points_.size(); }
  /// True when no point is stored.
  [[nodiscard]] bool empty() const { return points_.empty(); }
  /// Stored point i (the i-th finite point inserted), i < size().
  [[nodiscard]] const point_type& point(std::size_t i) const { return points_[i]; }
  /// The stored points in insertion order, indexed as the query results are.
  [[nodiscard]] const std::vector<point_type>& points() const { return points_; }
  /// The parameters the index was built with.
  [[nodiscard]] const GridIndexParams<Scalar>& params() const { return params_; }
  /// Bytes held by the index's arrays (their capacity): points, cell chains, cells and the
  /// overflow list.
  [[nodiscard]] std::size_t memory_bytes() const {
    return points_.capacity() * sizeof(point_type) + next_.capacity() * sizeof(std::uint32_t) +
           heads_.capacity() * sizeof(std::uint32_t) + overflow_.capacity() * sizeof(std::uint32_t);
  }

  // nearest() / knn() / radius(): SearchQueries.

 private:
  friend class SearchQueries<GridIndex2, 2, Scalar>;
  static constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();
  /// Cells farther than this from cell 0 go to the overflow list: their coordinates, and the
  /// array's extent with its margins, stay well inside int64.
  static constexpr Scalar max_cell_coord = Scalar(std::int64_t(1) << 60);

  [[nodiscard]] std::int64_t cell_coord(Scalar v) const {
    return static_cast<std::int64_t>(std::floor(v * inv_cell_));
  }

  void add(const point_type& p) {
    const auto index = static_cast<std::uint32_t>(points_.size());
    points_.push_back(p);
    next_.push_back(none);
    if (!(std::abs(p.x() * inv_cell_) < max_cell_coord &&
          std::abs(p.y() * inv_cell_) < max_cell_coord)) {
      overflow_.push_back(index);
      return;
    }
    const std::int64_t cx = cell_coord(p.x()), cy = cell_coord(p.y());
    if (!covers(cx, cy) && !grow_to(cx, cy)) {
      overflow_.push_back(index);
      return;
    }
    std::uint32_t& head = heads_[cell_index(cx, cy)];
    next_[index] = head;
    head = index;
  }

  [[nodiscard]] bool covers(std::int64_t cx, std::int64_t cy) const {
    return cx >= x0_ && cy >= y0_ && cx < x0_ + nx_ && cy < y0_ + ny_;
  }
  [[nodiscard]] std::size_t cell_index(std::int64_t cx, std::int64_t cy) const {
    return static_cast<std::size_t>((cy - y0_) * nx_ + (cx - x0_));
  }

  // Grows the array to cover cell (cx, cy) with a margin of half the new extent; false when
  // that would exceed max_cells.
  bool grow_to(std::int64_t cx, std::int64_t cy) {
    std::int64_t lx = cx, ly = cy, hx = cx + 1, hy = cy + 1;
    if (nx_ > 0) {
      lx = std::min(lx, x0_);
      ly = std::min(ly, y0_);
      hx = std::max(hx, x0_ + nx_);
      hy = std::max(hy, y0_ + ny_);
    }
    const std::int64_t mx = std::max<std::int64_t>(8, (hx - lx) / 2);
    const std::int64_t my = std::max<std::int64_t>(8, (hy - ly) / 2);
    lx -= mx;
    hx += mx;
    ly -= my;
    hy += my;
    const auto cells = static_cast<double>(hx - lx) * static_cast<double>(hy - ly);
    if (cells > static_cast<double>(params_.max_cells)) return false;
    x0_ = lx;
    y0_ = ly;
    nx_ = hx - lx;
    ny_ = hy - ly;
    heads_.assign(static_cast<std::size_t>(nx_ * ny_), none);
    // Re-bucket every gridded point (overflow points stay in the overflow list).
    std::vector<unsigned char> in_overflow(points_.size(), 0);
    for (const std::uint32_t i : overflow_)
      in_overflow[i] = 1;
    for (std::size_t i = 0; i + 1 < points_.size(); ++i) {
      if (in_overflow[i] != 0) continue;
      std::uint32_t& head =
          heads_[cell_index(cell_coord(points_[i].x()), cell_coord(points_[i].y()))];
      next_[i] = head;
      head = static_cast<std::uint32_t>(i);
    }
    return true;
  }

  template <class Collector>
  void scan_cell(Collector& c, const point_type& q, std::int64_t cx, std::int64_t cy) const {
    if (!covers(cx, cy)) return;
    for (std::uint32_t i = heads_[cell_index(cx, cy)]; i != none; i = next_[i])
      c.addPoint((points_[i] - q).squaredNorm(), i);
  }

  // Visits cells ring by ring (Chebyshev distance r from the query's cell); a point in ring
  // r + 1 or beyond is at least r * cell_size away, so the search stops once the collector's
  // bound is below that, or once the rings leave both the bound and the array.
  template <class Collector>
  void collect(Collector& c, const point_type& q, Scalar max_distance_sq) const {
    for (const std::uint32_t i : overflow_)
      c.addPoint((points_[i] - q).squaredNorm(), i);
    if (nx_ == 0 || !q.allFinite()) return;
    const Scalar qx = q.x() * inv_cell_, qy = q.y() * inv_cell_;
    // Rings that can hold a point within max_distance_sq, and rings that reach the array.
    const Scalar far = std::max(
        {std::abs(qx - static_cast<Scalar>(x0_)), std::abs(qx - static_cast<Scalar>(x0_ + nx_)),
         std::abs(qy - static_cast<Scalar>(y0_)), std::abs(qy - static_cast<Scalar>(y0_ + ny_))});
    Scalar limit = far + 1;
    if (max_distance_sq < unbounded_sq<Scalar>)
      limit = std::min(limit, std::sqrt(max_distance_sq) * inv_cell_ + 1);
    if (!(limit >= 0)) return;
    // The query's distance from the array, in cells (0 inside): no ring before it holds a cell
    // of the array. Beyond the bound nothing is found; rings up to it that hold more cells than
    // there are points cost more than scanning the points (see the file comment).
    const Scalar gap =
        std::max({static_cast<Scalar>(x0_) - qx, qx - static_cast<Scalar>(x0_ + nx_),
                  static_cast<Scalar>(y0_) - qy, qy - static_cast<Scalar>(y0_ + ny_), Scalar(0)});
    if (gap > limit) return;
    if (2 * gap + 1 > std::sqrt(static_cast<Scalar>(points_.size()))) {
      std::size_t o = 0;  // the overflow list is ascending and was scanned above
      for (std::size_t i = 0; i < points_.size(); ++i) {
        if (o < overflow_.size() && overflow_[o] == i) {
          ++o;
          continue;
        }
        c.addPoint((points_[i] - q).squaredNorm(), static_cast<std::uint32_t>(i));
      }
      return;
    }
    const auto max_ring = static_cast<std::int64_t>(limit);
    const std::int64_t cx = static_cast<std::int64_t>(std::floor(qx));
    const std::int64_t cy = static_cast<std::int64_t>(std::floor(qy));
    for (std::int64_t r = 0; r <= max_ring; ++r) {
      if (r == 0) {
        scan_cell(c, q, cx, cy);
      } else {
        for (std::int64_t x = cx - r; x <= cx + r; ++x) {
          scan_cell(c, q, x, cy - r);
          scan_cell(c, q, x, cy + r);
        }
        for (std::int64_t y = cy - r + 1; y <= cy + r - 1; ++y) {
          scan_cell(c, q, cx - r, y);
          scan_cell(c, q, cx + r, y);
        }
      }
      const Scalar reach = static_cast<Scalar>(r) * params_.cell_size;
      if (c.worstDist() <= reach * reach) break;
    }
  }

  GridIndexParams<Scalar> params_;
  Scalar inv_cell_ = 1;
  std::vector<point_type> points_;
  std::vector<std::uint32_t> next_;   ///< next point of the same cell
  std::vector<std::uint32_t> heads_;  ///< first point of each cell, row-major
  std::vector<std::uint32_t> overflow_;
  std::int64_t x0_ = 0, y0_ = 0, nx_ = 0, ny_ = 0;
};

}  // namespace rangenav
