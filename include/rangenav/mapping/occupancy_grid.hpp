#pragma once
// OccupancyGrid: a log-odds occupancy grid mapped with known poses, with the per-cell attributes
// of paper 001 §III (door paper, Nieuwenhuisen et al.) that separate static from dynamic readings:
//
//   transient      the cell has once been estimated free with high likelihood (probability below
//                  `transient_probability`), so it may only hold transient objects. Small pose
//                  errors put spurious readings next to static features, so a cell is marked
//                  transient only when every cell of its neighbourhood is that free too (§III);
//                  this also keeps grazing beams, which wear a wall's cells down, from turning a
//                  wall transient (the cells behind it are occupied or unknown).
//   seen-occupied  the cell's probability has once exceeded `seen_occupied_probability`.
//
// integrate() classifies a scan's readings before it maps them: readings that fall into
// transient cells are dynamic (Fig. 2a of paper 001) and do not touch the grid; the static ones
// are ray-traced (free cells along the beam, occupied at its end; readings at or beyond the
// maximum range clear free space only up to `max_free_range`).
//
// Seen-occupied cells that fall below the transient probability (with a free neighbourhood) give
// their mean hit point to a second set of dynamic points (a door that was closed and is now
// open). Both sets feed the door detection of mapping/doors.hpp.
//
// Grazing beams. A beam that meets a surface at a shallow angle beta runs within one cell of it
// for its last resolution / sin(beta) metres: 0.9 m for a wall seen at 3 deg from 17 m down a
// corridor. Plain ray tracing clears the cells it passes there, i.e. the wall's own cells, with
// every such beam, while only the few beams that end exactly in a cell mark it: far down a
// corridor the wall's cells end up free. Where the space behind the wall is seen free as well (a
// thin partition, or a wall beside an open doorway whose room is seen through it at the same
// shallow angle) the neighbourhood test no longer protects them: they turn transient, every later
// reading of the wall is classified dynamic and never restores it, and the wall beside a door
// joins the door's leaf in the line extraction. So a beam does not clear the cells that come
// within `surface_margin_cells` cells of the surface it hit: the line through its end point
// along the surface, whose direction is taken from the neighbouring end points of the scan (the
// side of larger incidence, so that a depth jump beside the beam does not count as grazing; the
// normal is the beam itself without valid neighbours). At normal incidence this spares the cell
// in front of the end cell; at grazing incidence, the row of cells along the wall.
//
// Cells are square, `resolution` metres wide; cell (0, 0) has its lower-left corner at `origin`;
// x grows along columns (index ix in [0, width)), y along rows (iy in [0, height)).
//
// Bad input is answered at the boundary: a non-finite pose, a box or origin whose extent
// overflows, a cell outside the grid given to an accessor raise invalid_argument. Points far off
// the grid (or NaN) map to cells far outside it, never to an overflowed index, and rays are
// clipped to the grid and a border as wide as the grid, so a reading of any length costs at most
// a few grid widths.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/scan/laser_scan.hpp"

namespace rangenav {

/// Log-odds of a probability, log(p / (1 - p)).
[[nodiscard]] inline double log_odds(double p) {
  return std::log(p / (1.0 - p));
}
/// Probability of a log-odds value.
[[nodiscard]] inline double probability_from_log_odds(double l) {
  return 1.0 - 1.0 / (1.0 + std::exp(l));
}

/// Parameters of OccupancyGrid. The sensor-model increments are the usual inverse-model values
/// (hit 0.7, miss 0.4); the thresholds are those the door paper describes qualitatively.
struct OccupancyGridParams {
  double resolution{0.05};            ///< cell side (m), > 0
  double hit_probability{0.7};        ///< inverse sensor model at a beam's end, in (0.5, 1)
  double miss_probability{0.4};       ///< inverse sensor model along a beam, in (0, 0.5)
  double min_probability{0.02};       ///< clamping keeps cells able to change (0 < min < 0.5)
  double max_probability{0.98};       ///< (0.5 < max < 1)
  double max_free_range{10.0};        ///< readings at/after the maximum range clear up to this (m)
  double transient_probability{0.1};  ///< below it a cell was "free with high likelihood"
  double seen_occupied_probability{0.9};  ///< above it a cell is seen-occupied
  int transient_neighborhood{2};          ///< cells: no cell this close may lean occupied (>= 0)
  /// A beam clears cells only while it is farther than this many cells from the surface it hit
  /// (see "Grazing beams" above; 0 = plain ray tracing up to the end cell), >= 0.
  double surface_margin_cells{1.0};
  double occupied_probability{0.5};  ///< is_occupied(): probability above this
  /// false: integrate() maps every valid reading (plain occupancy mapping, no dynamic readings).
  /// For a map to localize in, built from poses that are only approximately consistent (e.g. a
  /// SLAM-corrected log revisiting its corridors): there, a wall seen free from a slightly
  /// misaligned pass turns transient and its later readings would be discarded as dynamic.
  bool classify_dynamic{true};

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where) const {
    detail::require_positive(where, "resolution", resolution);
    const auto open_interval = [&](std::string_view name, double v, double lo, double hi) {
      if (!(v > lo && v < hi))
        detail::throw_invalid_argument(
            where, name, v,
            "must be in (" + detail::format_value(lo) + ", " + detail::format_value(hi) + ")");
    };
    open_interval("hit_probability", hit_probability, 0.5, 1.0);
    open_interval("miss_probability", miss_probability, 0.0, 0.5);
    open_interval("min_probability", min_probability, 0.0, 0.5);
    open_interval("max_probability", max_probability, 0.5, 1.0);
    detail::require_non_negative(where, "max_free_range", max_free_range);
    open_interval("transient_probability", transient_probability, 0.0, 0.5);
    open_interval("seen_occupied_probability", seen_occupied_probability, 0.5, 1.0);
    if (transient_neighborhood < 0)
      detail::throw_invalid_argument(where, "transient_neighborhood", transient_neighborhood,
                                     "must be >= 0");
    open_interval("occupied_probability", occupied_probability, 0.0, 1.0);
    detail::require_non_negative(where, "surface_margin_cells", surface_margin_cells);
  }
};

/// How integrate() classified one scan's readings (paper 001 §III, Fig. 2a).
struct ScanClassification {
  std::vector<std::uint32_t> static_beams;   ///< valid readings that updated the grid
  std::vector<std::uint32_t> dynamic_beams;  ///< valid readings that fell into transient cells
  std::vector<Point2d> dynamic_points;       ///< their end points in the map frame
  /// Mean hit points of seen-occupied cells that this scan turned free (the second set of
  /// dynamic points of §III).
  std::vector<Point2d> vanished_points;

  /// Empties every list (a reused classification allocates nothing).
  void clear() {
    static_beams.clear();
    dynamic_beams.clear();
    dynamic_points.clear();
    vanished_points.clear();
  }
};

/// A log-odds occupancy grid mapped with known poses, with paper 001's transient and
/// seen-occupied cells and the classification of dynamic readings (§III).
class OccupancyGrid {
 public:
  /// A cell (x, y).
  using Index = Eigen::Vector2i;
  /// The largest width or height of a grid (cells).
  static constexpr std::size_t max_side = std::size_t{1} << 15;
  /// The most cells of a grid: 2^27, about 2.3 GB of cell state (6.7 x 6.7 km at 0.5 m,
  /// 580 x 580 m at 5 cm).
  static constexpr std::size_t max_cells = std::size_t{1} << 27;

  /// A grid of width x height cells whose cell (0, 0) has its lower-left corner at `origin`;
  /// every cell starts unknown (probability 0.5).
  OccupancyGrid(const Point2d& origin, std::size_t width, std::size_t height,
                const OccupancyGridParams& params = {})
      : params_(params), origin_(origin) {
    constexpr std::string_view where = "OccupancyGrid";
    params_.validate(where);
    if (!origin.allFinite()) detail::throw_invalid(where, "origin must be finite");
    if (width == 0 || width > max_side)
      detail::throw_invalid_argument(where, "width", width, "must be in [1, 32768]");
    if (height == 0 || height > max_side)
      detail::throw_invalid_argument(where, "height", height, "must be in [1, 32768]");
    if (width * height > max_cells)
      detail::throw_invalid_argument(where, "width * height", width * height,
                                     "must be <= " + std::to_string(max_cells) + " cells");
    const Point2d far_corner =
        origin +
        Point2d(static_cast<double>(width), static_cast<double>(height)) * params_.resolution;
    if (!far_corner.allFinite())
      detail::throw_invalid(where,
                            "origin + size * resolution overflows (origin or resolution "
                            "too large)");
    width_ = static_cast<int>(width);
    height_ = static_cast<int>(height);
    inv_resolution_ = 1.0 / params_.resolution;
    l_hit_ = log_odds(params_.hit_probability);
    l_miss_ = log_odds(params_.miss_probability);
    l_min_ = log_odds(params_.min_probability);
    l_max_ = log_odds(params_.max_probability);
    l_transient_ = log_odds(params_.transient_probability);
    l_seen_occupied_ = log_odds(params_.seen_occupied_probability);
    l_occupied_ = log_odds(params_.occupied_probability);
    const std::size_t n = width * height;
    log_odds_.assign(n, 0.0f);
    flags_.assign(n, 0);
    hit_sum_.assign(n, Eigen::Vector2f::Zero());
    hit_count_.assign(n, 0);
  }

  /// The smallest grid covering the box [lo, hi] plus `margin` on every side.
  [[nodiscard]] static OccupancyGrid covering(const Point2d& lo, const Point2d& hi, double margin,
                                              const OccupancyGridParams& params = {}) {
    constexpr std::string_view where = "OccupancyGrid::covering";
    params.validate(where);
    detail::require_non_negative(where, "margin", margin);
    if (!lo.allFinite() || !hi.allFinite() || (hi.array() < lo.array()).any())
      detail::throw_invalid(where, "the box [lo, hi] must be finite with lo <= hi");
    const Point2d a = lo - Point2d::Constant(margin), b = hi + Point2d::Constant(margin);
    // Counted in double and checked before the conversion: a box of +-1e300 m overflows.
    const auto cells = [&](double extent, std::string_view axis) {
      const double n = std::ceil(extent / params.resolution) + 1;
      if (!(n <= double(max_side)))
        detail::throw_invalid_argument(
            where, std::string(axis) + " extent of [lo, hi] + margin", extent,
            "m needs more than " + std::to_string(max_side) + " cells of " +
                detail::format_value(params.resolution) + " m");
      return static_cast<std::size_t>(n);
    };
    return OccupancyGrid(a, cells(b.x() - a.x(), "x"), cells(b.y() - a.y(), "y"), params);
  }

  // ---- geometry ------------------------------------------------------------------------------
  /// The parameters.
  [[nodiscard]] const OccupancyGridParams& params() const { return params_; }
  /// Cells along x.
  [[nodiscard]] int width() const { return width_; }
  /// Cells along y.
  [[nodiscard]] int height() const { return height_; }
  /// width x height.
  [[nodiscard]] std::size_t cell_count() const { return log_odds_.size(); }
  /// Cell edge (m).
  [[nodiscard]] double resolution() const { return params_.resolution; }
  /// The lower-left corner of cell (0, 0) (m).
  [[nodiscard]] const Point2d& origin() const { return origin_; }
  /// True when the cell lies inside the grid.
  [[nodiscard]] bool contains(const Index& c) const {
    return c.x() >= 0 && c.y() >= 0 && c.x() < width_ && c.y() < height_;
  }
  /// The cell containing p (it may lie outside the grid; check with contains()). Coordinates
  /// more than 2^30 cells away, and NaN, give a cell at +-2^30: outside, never an overflow.
  [[nodiscard]] Index cell_of(const Point2d& p) const {
    return {to_index((p.x() - origin_.x()) * inv_resolution_),
            to_index((p.y() - origin_.y()) * inv_resolution_)};
  }
  /// The centre of a cell (m).
  [[nodiscard]] Point2d cell_center(const Index& c) const {
    return origin_ + (c.cast<double>() + Point2d::Constant(0.5)) * params_.resolution;
  }
  /// Row-major linear index of a cell inside the grid.
  [[nodiscard]] std::size_t linear(const Index& c) const {
    return static_cast<std::size_t>(c.y()) * static_cast<std::size_t>(width_) +
           static_cast<std::size_t>(c.x());
  }

  // ---- cell state ----------------------------------------------------------------------------
  // Every accessor taking a cell throws invalid_argument for a cell outside the grid.
  /// The cell's log odds log(p / (1 - p)); 0 = unknown.
  [[nodiscard]] double log_odds_at(const Index& c) const {
    return log_odds_[checked(c, "OccupancyGrid::log_odds_at")];
  }
  /// The cell's occupancy probability.
  [[nodiscard]] double probability(const Index& c) const {
    return probability_from_log_odds(log_odds_at(c));
  }
  /// Occupied: probability above OccupancyGridParams::occupied_probability.
  [[nodiscard]] bool is_occupied(const Index& c) const { return log_odds_at(c) > l_occupied_; }
  /// Observed and leaning free (probability below 0.5).
  [[nodiscard]] bool is_free(const Index& c) const { return log_odds_at(c) < 0; }
  /// Never observed (log odds exactly 0).
  [[nodiscard]] bool is_unknown(const Index& c) const { return log_odds_at(c) == 0; }
  /// Was free with high likelihood in a free neighbourhood (paper 001 §III).
  [[nodiscard]] bool is_transient(const Index& c) const {
    return (flags_[checked(c, "OccupancyGrid::is_transient")] & transient_flag) != 0;
  }
  /// Was occupied with high likelihood (paper 001 §III).
  [[nodiscard]] bool is_seen_occupied(const Index& c) const {
    return (flags_[checked(c, "OccupancyGrid::is_seen_occupied")] & seen_occupied_flag) != 0;
  }
  /// Mean of the beam end points that hit the cell (its centre when none did).
  [[nodiscard]] Point2d mean_hit_point(const Index& c) const {
    const std::size_t i = checked(c, "OccupancyGrid::mean_hit_point");
    if (hit_count_[i] == 0) return cell_center(c);
    return (hit_sum_[i] / static_cast<float>(hit_count_[i])).cast<double>();
  }
  /// Row-major log-odds of every cell (for drawing and for the likelihood field).
  [[nodiscard]] const std::vector<float>& log_odds_data() const { return log_odds_; }

  /// Sets a cell back to unknown and clears its attributes (e.g. a detected door's cells, which
  /// paper 001 §III removes from the static grid).
  void clear_cell(const Index& c) {
    const std::size_t i = checked(c, "OccupancyGrid::clear_cell");
    log_odds_[i] = 0;
    flags_[i] = 0;
    hit_sum_[i].setZero();
    hit_count_[i] = 0;
  }
  /// Forces a cell's log-odds (clamped; +-inf clamp too, NaN is rejected), e.g. to mark it free.
  void set_log_odds(const Index& c, double l) {
    const std::size_t i = checked(c, "OccupancyGrid::set_log_odds");
    if (std::isnan(l))
      detail::throw_invalid_argument("OccupancyGrid::set_log_odds", "l", l, "must not be NaN");
    log_odds_[i] = static_cast<float>(std::clamp(l, l_min_, l_max_));
  }

  // ---- ray tracing ---------------------------------------------------------------------------
  /// Calls f(cell) for every cell the segment a-b passes through, in order from a's cell to b's
  /// cell inclusive, 4-connected (Amanatides & Woo's voxel traversal); cells may lie outside the
  /// grid. The number of cells is |dx| + |dy| + 1 for the cell offsets dx, dy between the ends.
  /// Only the part of the segment within the grid and a border as wide as the grid's larger side
  /// is traversed (the segment is clipped there, Liang-Barsky), so the cost is bounded for a
  /// segment of any length; a segment with a non-finite end visits nothing.
  template <class F>
  void trace(const Point2d& a, const Point2d& b, F&& f) const {
    Point2d ga = (a - origin_) * inv_resolution_, gb = (b - origin_) * inv_resolution_;
    if (!clip_to_border(ga, gb)) return;
    Index c(static_cast<int>(std::floor(ga.x())), static_cast<int>(std::floor(ga.y())));
    const Index end(static_cast<int>(std::floor(gb.x())), static_cast<int>(std::floor(gb.y())));
    const Point2d d = gb - ga;
    const int step_x = d.x() > 0 ? 1 : -1, step_y = d.y() > 0 ? 1 : -1;
    constexpr double inf = std::numeric_limits<double>::infinity();
    const double delta_x = d.x() != 0 ? 1.0 / std::abs(d.x()) : inf;
    const double delta_y = d.y() != 0 ? 1.0 / std::abs(d.y()) : inf;
    double t_x =
        d.x() != 0 ? (step_x > 0 ? (c.x() + 1 - ga.x()) : (ga.x() - c.x())) * delta_x : inf;
    double t_y =
        d.y() != 0 ? (step_y > 0 ? (c.y() + 1 - ga.y()) : (ga.y() - c.y())) * delta_y : inf;
    int remaining = std::abs(end.x() - c.x()) + std::abs(end.y() - c.y());
    f(c);
    for (; remaining > 0; --remaining) {
      // Rounding may disagree with the end cell; never step past it on an axis already done.
      const bool along_x = c.y() == end.y() || (c.x() != end.x() && t_x < t_y);
      if (along_x) {
        c.x() += step_x;
        t_x += delta_x;
      } else {
        c.y() += step_y;
        t_y += delta_y;
      }
      f(c);
    }
  }

  // ---- mapping -------------------------------------------------------------------------------
  /// Classifies the scan's readings taken from `sensor_pose` (the laser's pose in the map frame)
  /// into static and dynamic, maps the static ones, and reports the seen-occupied cells that
  /// turned free. `out` is cleared first; its buffers are reused.
  /// Throws invalid_argument for a non-finite sensor pose.
  template <class S>
  void integrate(const Pose2d& sensor_pose, const LaserScan<S>& scan, ScanClassification& out) {
    constexpr std::string_view where = "OccupancyGrid::integrate";
    detail::require_finite(where, "sensor_pose.x", sensor_pose.x);
    detail::require_finite(where, "sensor_pose.y", sensor_pose.y);
    detail::require_finite(where, "sensor_pose.theta", sensor_pose.theta);
    out.clear();
    const Point2d origin = sensor_pose.position();
    const double c = std::cos(sensor_pose.theta), s = std::sin(sensor_pose.theta);
    const auto to_map = [&](double r, double bearing) {
      return Point2d(origin.x() + r * std::cos(bearing + sensor_pose.theta),
                     origin.y() + r * std::sin(bearing + sensor_pose.theta));
    };
    // Classify against the attributes as they were before this scan (§III).
    for (std::uint32_t i = 0; i < scan.size(); ++i) {
      if (!scan.is_valid(i)) continue;
      const Point<2, S>& q = scan.point(i);
      const Point2d p(origin.x() + c * double(q.x()) - s * double(q.y()),
                      origin.y() + s * double(q.x()) + c * double(q.y()));
      const Index cell = cell_of(p);
      if (params_.classify_dynamic && contains(cell) && is_transient(cell)) {
        out.dynamic_beams.push_back(i);
        out.dynamic_points.push_back(p);
      } else {
        out.static_beams.push_back(i);
      }
    }
    touched_.clear();
    const auto miss = [&](const Index& cell) {
      if (!contains(cell)) return;
      const std::size_t k = linear(cell);
      log_odds_[k] = static_cast<float>(std::max(l_min_, double(log_odds_[k]) + l_miss_));
      touched_.push_back(cell);
    };
    const double margin = params_.surface_margin_cells * params_.resolution;
    for (const std::uint32_t i : out.static_beams) {
      const Point<2, S>& q = scan.point(i);
      const Point2d p(origin.x() + c * double(q.x()) - s * double(q.y()),
                      origin.y() + s * double(q.x()) + c * double(q.y()));
      const Index end = cell_of(p);
      if (margin > 0) {
        const Point2d nq = surface_normal(scan, i, q.template cast<double>());
        const Point2d n(c * nq.x() - s * nq.y(), s * nq.x() + c * nq.y());
        // Distance from the surface line to the nearest point of a cell's square.
        const double half_extent = (std::abs(n.x()) + std::abs(n.y())) * params_.resolution / 2;
        trace(origin, p, [&](const Index& cell) {
          if (cell != end && std::abs(n.dot(cell_center(cell) - p)) - half_extent >= margin)
            miss(cell);
        });
      } else {
        trace(origin, p, [&](const Index& cell) {
          if (cell != end) miss(cell);
        });
      }
      if (!contains(end)) continue;
      const std::size_t k = linear(end);
      log_odds_[k] = static_cast<float>(std::min(l_max_, double(log_odds_[k]) + l_hit_));
      hit_sum_[k] += p.cast<float>();
      ++hit_count_[k];
      if (log_odds_[k] > l_seen_occupied_)
        flags_[k] = static_cast<std::uint8_t>((flags_[k] | seen_occupied_flag) & ~vanished_flag);
    }
    // Readings at or beyond the maximum range (no return) clear free space up to the cap.
    const double range_max = double(scan.range_max());
    const double free_range = std::min(range_max, params_.max_free_range);
    if (free_range > 0)
      for (std::uint32_t i = 0; i < scan.size(); ++i) {
        const double r = double(scan.range(i));
        if (!(r >= range_max)) continue;  // NaN, valid or too short: nothing known
        const Point2d p = to_map(free_range, double(scan.angle(i)));
        trace(origin, p, [&](const Index& cell) { miss(cell); });
      }
    // Attributes of the cells this scan cleared.
    for (const Index& cell : touched_) {
      const std::size_t k = linear(cell);
      if (log_odds_[k] >= l_transient_) continue;
      const bool vanishing =
          (flags_[k] & (seen_occupied_flag | vanished_flag)) == seen_occupied_flag;
      if (!vanishing && (flags_[k] & transient_flag) != 0) continue;
      // The neighbourhood test guards both attributes: grazing beams wear down the cells of a
      // wall's face, but the cells behind a wall stay occupied or unknown.
      if (!neighborhood_free(cell)) continue;
      flags_[k] |= transient_flag;
      if (vanishing) {
        flags_[k] |= vanished_flag;
        out.vanished_points.push_back(mean_hit_point(cell));
      }
    }
  }

  /// integrate() returning the classification.
  template <class S>
  ScanClassification integrate(const Pose2d& sensor_pose, const LaserScan<S>& scan) {
    ScanClassification out;
    integrate(sensor_pose, scan, out);
    return out;
  }

 private:
  static constexpr std::uint8_t transient_flag = 1, seen_occupied_flag = 2, vanished_flag = 4;

  /// A grid coordinate (in cells) as an index, saturated at +-2^30 (NaN: -2^30).
  static int to_index(double g) {
    constexpr double bound = double(1 << 30);
    if (!(g > -bound)) return -(1 << 30);
    if (!(g < bound)) return 1 << 30;
    return static_cast<int>(std::floor(g));
  }

  /// The linear index of c, or invalid_argument naming `where` when c lies outside the grid.
  std::size_t checked(const Index& c, std::string_view where) const {
    if (!contains(c))
      detail::throw_invalid(where, "cell (" + std::to_string(c.x()) + ", " + std::to_string(c.y()) +
                                       ") is outside the " + std::to_string(width_) + " x " +
                                       std::to_string(height_) + " grid");
    return linear(c);
  }

  /// Clips the segment ga-gb (grid coordinates) to the grid grown by a border of its larger side
  /// (Liang-Barsky); false when nothing of it is left or an end is not finite.
  bool clip_to_border(Point2d& ga, Point2d& gb) const {
    if (!ga.allFinite() || !gb.allFinite()) return false;
    const double border = std::max(width_, height_);
    const Point2d lo = Point2d::Constant(-border);
    const Point2d hi(width_ + border, height_ + border);
    if ((ga.array() >= lo.array()).all() && (ga.array() <= hi.array()).all() &&
        (gb.array() >= lo.array()).all() && (gb.array() <= hi.array()).all())
      return true;  // the common case: nothing to clip
    const Point2d d = gb - ga;
    double t0 = 0, t1 = 1;
    for (int k = 0; k < 2; ++k) {
      // Inside along axis k: lo <= ga + t d <= hi.
      for (const auto& [p, q] : {std::pair{-d[k], ga[k] - lo[k]}, std::pair{d[k], hi[k] - ga[k]}}) {
        if (p == 0) {
          if (q < 0) return false;
          continue;
        }
        const double t = q / p;
        if (p < 0)
          t0 = std::max(t0, t);
        else
          t1 = std::min(t1, t);
      }
    }
    if (!(t0 <= t1)) return false;
    const Point2d a = ga;
    ga = a + t0 * d;
    gb = a + t1 * d;
    // d can overflow for ends beyond +-1e308 even when both are finite.
    return ga.allFinite() && gb.allFinite();
  }

  /// Unit normal (sensor frame) of the surface beam i hit at its end point q: perpendicular to
  /// the direction to a neighbouring end point, the side whose direction makes the larger angle
  /// with the beam; the beam's direction without a valid neighbour.
  template <class S>
  [[nodiscard]] static Point2d surface_normal(const LaserScan<S>& scan, std::uint32_t i,
                                              const Point2d& q) {
    const Point2d u = q.normalized();
    double best_sin = -1;
    Point2d normal = u;
    const auto side = [&](std::uint32_t j) {
      if (!scan.is_valid(j)) return;
      const Point2d t = scan.point(j).template cast<double>() - q;
      const double t_norm = t.norm();
      if (!(t_norm > 0)) return;
      const double sin_beta = std::abs(u.x() * t.y() - u.y() * t.x()) / t_norm;
      if (sin_beta > best_sin) {
        best_sin = sin_beta;
        normal = Point2d(-t.y(), t.x()) / t_norm;
      }
    };
    if (i > 0) side(i - 1);
    if (i + 1 < scan.size()) side(i + 1);
    return normal;
  }

  [[nodiscard]] bool neighborhood_free(const Index& cell) const {
    const int r = params_.transient_neighborhood;
    for (int dy = -r; dy <= r; ++dy)
      for (int dx = -r; dx <= r; ++dx) {
        const Index n(cell.x() + dx, cell.y() + dy);
        if (!contains(n) || !(log_odds_[linear(n)] < l_transient_)) return false;
      }
    return true;
  }

  OccupancyGridParams params_;
  Point2d origin_;
  int width_{0}, height_{0};
  double inv_resolution_{1};
  double l_hit_{0}, l_miss_{0}, l_min_{0}, l_max_{0}, l_transient_{0}, l_seen_occupied_{0},
      l_occupied_{0};
  std::vector<float> log_odds_;
  std::vector<std::uint8_t> flags_;
  std::vector<Eigen::Vector2f> hit_sum_;
  std::vector<std::uint32_t> hit_count_;
  std::vector<Index> touched_;  ///< scratch: cells cleared by the current scan
};

}  // namespace rangenav
