#pragma once
// Branch-and-bound correlative scan matching over a multi-resolution grid (Olson 2009, "Real-time
// correlative scan matching"; Hess, Kohler, Rapp, Andor 2016, "Real-time loop closure in 2D LIDAR
// SLAM", §V): the global search that gives loop closure its coarse alignment.
//
// The model (a submap's points) is rasterised into a likelihood grid of cell size r: a cell's value
// is exp(-d² / 2σ²), d the distance from the cell's centre to the nearest model point (Olson's
// rasterised Gaussian cost). The score of a pose ξ = (x, y, θ) of the scan points h_k is Hess et
// al.'s Eq. (9), the mean grid value at the transformed points,
//   score(ξ) = 1/K Σ_k M_nearest(T_ξ h_k).
// The search covers a window of ±W_x, ±W_y around an initial pose (in steps of r) and ±W_θ (in
// steps of δθ, Eq. (7): δθ = arccos(1 − r² / (2 d_max²)), d_max the farthest scan point, so that
// one angular step moves no point by more than one cell). Exhaustive search of that window is
// Eq. (10); branch and bound (Algorithm 3) finds the same maximum: a node of height h stands for
// the 2^h × 2^h translations starting at its offset, and its bound (Eq. (15)) is the score on the
// precomputed grid
//   M_precomp^h(x, y) = max { M(x', y') : x' ∈ [x, x + 2^h), y' ∈ [y, y + 2^h) }    (Eq. (14))
// which is ≥ the score of every translation it covers. Nodes are expanded depth-first, best bound
// first (the greedy order of §V.C), and pruned once their bound cannot beat the best leaf found
// (or `min_score`). The precomputed grids come from the one below by a 2 × 2 max of offset
// 2^(h-1), exact and O(cells) per level.
//
// Cells hold the likelihood in 16-bit fixed point (value × 65535, rounded), as Cartographer's
// precomputation grids hold theirs in 8 bits: rounding is monotone, so the max of Eq. (14) and
// the bound of Eq. (15) stay exact on the stored values, a score is off by at most 1/131070 per
// point, the grids take half the memory of floats, and the bounds are exact integer sums (the
// same whatever the order of summation).
//
// The grid is two-dimensional only: 3D loop closures are verified by ICP alone.

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <string_view>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// Parameters of the correlative matcher's grid.
template <std::floating_point Scalar = double>
struct CorrelativeScanMatcherParams {
  /// Cell size r of the finest grid (m). The match only has to land in the basin of the ICP
  /// that refines it (a pairing distance of tens of cm), so a coarser cell than Hess et al.'s
  /// 5 cm is enough and makes the grids four times smaller.
  Scalar resolution = Scalar(0.1);
  /// σ of the likelihood exp(-d² / 2σ²) (m): the spread of a wall's points in the grid, i.e.
  /// the sensor noise plus half a cell of rasterisation; at σ = r a point half a cell off a
  /// wall still scores 0.88, one a cell and a half off 0.32.
  Scalar sigma = Scalar(0.1);
  /// Heights of precomputed grids (Hess et al. use 7: a root node covers 2^6 = 64 cells).
  int levels = 7;
  /// Most bytes the grids of one matcher may take (all levels): a model spread over a larger
  /// area than that affords at this resolution is refused with invalid_argument instead of
  /// exhausting memory. 1 GiB holds about 870 m × 870 m at the default resolution and levels,
  /// far more than a submap.
  std::size_t max_memory_bytes = std::size_t(1) << 30;

  /// Throws invalid_argument naming the first parameter out of range.
  void validate() const {
    constexpr std::string_view where = "CorrelativeScanMatcherParams";
    detail::require_positive(where, "resolution", resolution);
    detail::require_positive(where, "sigma", sigma);
    if (levels < 1 || levels > 16)
      detail::throw_invalid_argument(where, "levels", levels, "must be in [1, 16]");
    if (max_memory_bytes == 0)
      detail::throw_invalid_argument(where, "max_memory_bytes", max_memory_bytes, "must be > 0");
  }
};

/// The region searched around an initial pose: ±linear in x and y (m), ±angular (rad); a
/// rectangle when `linear_y` is set (±linear in x, ±linear_y in y, both in the model frame),
/// e.g. the bounding box of an elongated position uncertainty.
template <std::floating_point Scalar = double>
struct SearchWindow {
  /// ±1 m, ±0.5 rad.
  constexpr SearchWindow() = default;
  /// ±half_width in x and y (±half_height in y when given), ±half_angle.
  constexpr SearchWindow(Scalar half_width, Scalar half_angle,
                         std::optional<Scalar> half_height = std::nullopt)
      : linear(half_width), angular(half_angle), linear_y(half_height) {}

  Scalar linear = Scalar(1);       ///< m, half-width in x (and in y unless linear_y is set)
  Scalar angular = Scalar(0.5);    ///< rad, half-width in θ
  std::optional<Scalar> linear_y;  ///< m, half-width in y when it differs from x's
};

/// The window that holds `sigmas` standard deviations of a position uncertainty: the bounding box
/// of the ellipse xᵀ C⁻¹ x = sigmas², C the covariance of the position in the model frame (m²),
/// is ±sigmas √C_xx by ±sigmas √C_yy (each half-width clamped to [min_linear, max_linear]);
/// ±angular (rad). Never wider than the square ±sigmas √λ_max of the ellipse's longest axis,
/// and much narrower across an elongated ellipse aligned with the frame.
template <std::floating_point Scalar>
[[nodiscard]] SearchWindow<Scalar> uncertainty_window(
    const Eigen::Matrix<Scalar, 2, 2>& position_covariance, Scalar sigmas, Scalar angular,
    Scalar min_linear, Scalar max_linear) {
  const auto half_width = [&](Scalar variance) {
    return std::clamp(sigmas * std::sqrt(std::max(Scalar(0), variance)), min_linear, max_linear);
  };
  return SearchWindow<Scalar>(half_width(position_covariance(0, 0)), angular,
                              half_width(position_covariance(1, 1)));
}

/// A region of translations a search leaves out: those within `radius` (m) of `center`'s.
template <std::floating_point Scalar = double>
struct SearchExclusion {
  Transform<2, Scalar> center = Transform<2, Scalar>::Identity();  ///< its translation counts
  Scalar radius = 0;                                               ///< m
};

/// The best pose found and its score (Eq. (9), in [0, 1]).
template <std::floating_point Scalar = double>
struct CorrelativeMatch {
  Transform<2, Scalar> pose = Transform<2, Scalar>::Identity();  ///< scan -> model frame
  Scalar score = 0;        ///< Eq. (9), mean likelihood in [0, 1]
  std::size_t points = 0;  ///< scan points scored (one per grid cell)
};

/// A likelihood grid of model points with its precomputed max grids; match() searches it.
template <std::floating_point Scalar = double>
class CorrelativeScanMatcher {
 public:
  using point_type = Point<2, Scalar>;          ///< a point
  using transform_type = Transform<2, Scalar>;  ///< a pose

  /// Rasterises the finite points of `model` (in the model frame). Throws invalid_argument for
  /// invalid parameters, a model without a finite point, or one whose grids would exceed
  /// params.max_memory_bytes.
  explicit CorrelativeScanMatcher(std::span<const point_type> model,
                                  CorrelativeScanMatcherParams<Scalar> params = {})
      : params_((params.validate(), params)) {
    const Extent box = extent(model);
    if (box.empty())
      detail::throw_invalid("CorrelativeScanMatcher", "argument 'model' has no finite point");
    const Scalar bytes = grid_bytes(box, params_);
    if (!(bytes <= Scalar(params_.max_memory_bytes)))
      detail::throw_invalid(
          "CorrelativeScanMatcher",
          "argument 'model' spans " + detail::format_value(box.hi_x - box.lo_x) + " m x " +
              detail::format_value(box.hi_y - box.lo_y) + " m: its grids would take " +
              detail::format_value(std::ceil(bytes)) + " bytes, more than max_memory_bytes = " +
              detail::format_value(params_.max_memory_bytes));
    const Scalar r = params_.resolution;
    const int reach = static_cast<int>(reach_cells(params_));
    pad_ = pad_cells(params_);
    origin_ = point_type(box.lo_x - Scalar(reach + 1) * r, box.lo_y - Scalar(reach + 1) * r);
    width_ = static_cast<int>(std::ceil((box.hi_x - origin_.x()) / r)) + reach + 2;
    height_ = static_cast<int>(std::ceil((box.hi_y - origin_.y()) / r)) + reach + 2;
    stride_ = width_ + pad_;
    const std::size_t cells =
        static_cast<std::size_t>(stride_) * static_cast<std::size_t>(height_ + pad_);
    grids_.assign(static_cast<std::size_t>(params_.levels), std::vector<Cell16>(cells, 0));
    // Level 0: the likelihood of the nearest model point, splatted over 3σ around each point.
    auto& base = grids_[0];
    const Scalar inv_two_sigma_sq = Scalar(1) / (2 * params_.sigma * params_.sigma);
    for (const auto& p : model) {
      if (!p.allFinite()) continue;
      const int cx = static_cast<int>(std::floor((p.x() - origin_.x()) / r));
      const int cy = static_cast<int>(std::floor((p.y() - origin_.y()) / r));
      for (int y = cy - reach; y <= cy + reach; ++y)
        for (int x = cx - reach; x <= cx + reach; ++x) {
          const Scalar dx = origin_.x() + (Scalar(x) + Scalar(0.5)) * r - p.x();
          const Scalar dy = origin_.y() + (Scalar(y) + Scalar(0.5)) * r - p.y();
          Cell16& cell = base[index(x, y)];
          cell = std::max(cell, quantize(std::exp(-(dx * dx + dy * dy) * inv_two_sigma_sq)));
        }
    }
    // Eq. (14) level by level: the max over [x, x + 2^h) is that of [x, x + s) and [x + s,
    // x + 2s) with s = 2^(h-1), both of level h - 1.
    for (int h = 1; h < params_.levels; ++h) {
      const int s = 1 << (h - 1);
      const auto& below = grids_[static_cast<std::size_t>(h - 1)];
      auto& level = grids_[static_cast<std::size_t>(h)];
      for (int y = -pad_; y < height_; ++y)
        for (int x = -pad_; x < width_; ++x) {
          Cell16 m = below[index(x, y)];
          if (x + s < width_) m = std::max(m, below[index(x + s, y)]);
          if (y + s < height_) {
            m = std::max(m, below[index(x, y + s)]);
            if (x + s < width_) m = std::max(m, below[index(x + s, y + s)]);
          }
          level[index(x, y)] = m;
        }
    }
  }

  /// The pose of `scan` (points in the scan frame) with the highest score within `window`
  /// around `initial` (scan -> model), if that score reaches `min_score`; translations in
  /// `exclusion` are left out (a search for a second, distinct peak). The scan is thinned to
  /// one point per grid cell first. Never throws on data: an empty or non-finite scan gives
  /// no match. Not thread-safe (scratch buffers): one matcher per thread.
  [[nodiscard]] std::optional<CorrelativeMatch<Scalar>> match(
      std::span<const point_type> scan, const transform_type& initial,
      const SearchWindow<Scalar>& window, Scalar min_score,
      const std::optional<SearchExclusion<Scalar>>& exclusion = std::nullopt) const {
    if (!prepare(scan, initial, window)) return std::nullopt;
    return run(min_score, exclusion);
  }

  /// The best match as match() finds it, and the best pose farther than `distance` (m) from it
  /// that scores at least `ratio` × its score (Olson 2009 §IV: a second peak nearly as high
  /// makes the match ambiguous), both from one set of rotated scans and root bounds.
  [[nodiscard]] std::pair<std::optional<CorrelativeMatch<Scalar>>,
                          std::optional<CorrelativeMatch<Scalar>>>
  match_with_runner_up(std::span<const point_type> scan, const transform_type& initial,
                       const SearchWindow<Scalar>& window, Scalar min_score, Scalar ratio,
                       Scalar distance) const {
    if (!prepare(scan, initial, window)) return {};
    auto best = run(min_score, std::nullopt);
    if (!best) return {};
    auto second = run(ratio * best->score, SearchExclusion<Scalar>{best->pose, distance});
    return {best, second};
  }

  /// Eq. (9) at one pose: the mean likelihood of `scan`'s points (thinned as by match()) placed
  /// by `pose` (scan -> model); 0 for a scan without a finite point.
  [[nodiscard]] Scalar score(std::span<const point_type> scan, const transform_type& pose) const {
    thin(scan);
    if (points_.empty()) return 0;
    Scalar sum = 0;
    for (const auto& p : points_)
      sum += likelihood(pose * p);
    return sum / static_cast<Scalar>(points_.size());
  }

  /// The likelihood (level 0) at a point of the model frame; 0 outside the grid.
  [[nodiscard]] Scalar likelihood(const point_type& p) const {
    return Scalar(value(0, static_cast<int>(std::floor((p.x() - origin_.x()) / params_.resolution)),
                        static_cast<int>(std::floor((p.y() - origin_.y()) / params_.resolution)))) /
           Scalar(cell_max);
  }
  /// The parameters the matcher was built with.
  [[nodiscard]] const CorrelativeScanMatcherParams<Scalar>& params() const { return params_; }
  /// Bytes held by the grids.
  [[nodiscard]] std::size_t memory_bytes() const {
    return grids_.size() * (grids_.empty() ? 0 : grids_[0].size() * sizeof(Cell16));
  }

  /// Whether a matcher over `model` can be built with valid `params`: the model has a finite
  /// point and its grids fit params.max_memory_bytes (the constructor's test, without its
  /// exception). One pass over the model.
  [[nodiscard]] static bool fits(std::span<const point_type> model,
                                 const CorrelativeScanMatcherParams<Scalar>& params) {
    const Extent box = extent(model);
    return !box.empty() && grid_bytes(box, params) <= Scalar(params.max_memory_bytes);
  }

 private:
  using Cell16 = std::uint16_t;  ///< a likelihood in fixed point, 65535 = 1
  using Sum = std::uint64_t;     ///< a sum of cells (never overflows)
  static constexpr Cell16 cell_max = std::numeric_limits<Cell16>::max();

  /// The bounding box of the finite points of a model (empty without one).
  struct Extent {
    Scalar lo_x = std::numeric_limits<Scalar>::infinity(), lo_y = lo_x, hi_x = -lo_x, hi_y = -lo_x;
    [[nodiscard]] bool empty() const { return !(lo_x <= hi_x); }
  };
  static Extent extent(std::span<const point_type> model) {
    Extent box;
    for (const auto& p : model)
      if (p.allFinite()) {
        box.lo_x = std::min(box.lo_x, p.x());
        box.lo_y = std::min(box.lo_y, p.y());
        box.hi_x = std::max(box.hi_x, p.x());
        box.hi_y = std::max(box.hi_y, p.y());
      }
    return box;
  }
  /// Cells of the kernel's reach (3σ) around a point.
  static Scalar reach_cells(const CorrelativeScanMatcherParams<Scalar>& params) {
    return std::ceil(3 * params.sigma / params.resolution);
  }
  /// Padding of the grids for the coarsest level's 2^(levels-1) cells.
  static int pad_cells(const CorrelativeScanMatcherParams<Scalar>& params) {
    return (1 << (params.levels - 1)) - 1;
  }
  /// The bytes of all levels of the grids over a non-empty extent, in floating point (+inf when
  /// huge) so that it is checked before any integer conversion.
  static Scalar grid_bytes(const Extent& box, const CorrelativeScanMatcherParams<Scalar>& params) {
    const Scalar r = params.resolution;
    const Scalar margin = 2 * reach_cells(params) + 4 + Scalar(pad_cells(params));
    const Scalar side_x = std::ceil((box.hi_x - box.lo_x) / r) + margin;
    const Scalar side_y = std::ceil((box.hi_y - box.lo_y) / r) + margin;
    return side_x * side_y * Scalar(params.levels) * Scalar(sizeof(Cell16));
  }
  static Cell16 quantize(Scalar likelihood) {
    return static_cast<Cell16>(
        std::lround(std::clamp(likelihood, Scalar(0), Scalar(1)) * cell_max));
  }
  struct Candidate {
    int angle, x, y;  ///< angle index, cell offsets
    Sum score;        ///< summed bound (the score at height 0)
  };
  struct Cell {
    int x, y;
  };
  static bool by_score(const Candidate& a, const Candidate& b) { return a.score > b.score; }

  [[nodiscard]] std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y + pad_) * static_cast<std::size_t>(stride_) +
           static_cast<std::size_t>(x + pad_);
  }
  [[nodiscard]] Cell16 value(int level, int x, int y) const {
    if (x < -pad_ || y < -pad_ || x >= width_ || y >= height_) return 0;
    return grids_[static_cast<std::size_t>(level)][index(x, y)];
  }

  // The rotated, discretised scans of the window (Hess et al.'s precomputed rotated scans) and
  // the sorted root nodes; false when there is nothing to search.
  bool prepare(std::span<const point_type> scan, const transform_type& initial,
               const SearchWindow<Scalar>& window) const {
    const Scalar r = params_.resolution;
    thin(scan);
    const Scalar linear_y = window.linear_y.value_or(window.linear);
    if (points_.empty() || !initial.matrix().allFinite() || !(window.linear >= 0) ||
        !(linear_y >= 0) || !(window.angular >= 0))
      return false;
    // Eq. (7) with d_max the 90 % quantile of the points' ranges instead of the farthest: one
    // far reading would otherwise set the step for all, while a step moves 90 % of the points
    // by at most a cell (and the refining ICP absorbs the rest); at least a tenth of a degree.
    ranges_.clear();
    for (const auto& p : points_)
      ranges_.push_back(p.norm());
    const Scalar d_far = *std::max_element(ranges_.begin(), ranges_.end());
    const auto q = ranges_.begin() + static_cast<std::ptrdiff_t>(ranges_.size() * 9 / 10);
    std::nth_element(ranges_.begin(), q, ranges_.end());
    const Scalar d_max = *q;
    step_ = std::max(std::acos(std::clamp(1 - r * r / (2 * std::max(d_max * d_max, r * r)),
                                          Scalar(-1), Scalar(1))),
                     Scalar(std::numbers::pi_v<Scalar> / 1800));
    angles_ =
        static_cast<int>(std::ceil(std::min(window.angular, std::numbers::pi_v<Scalar>) / step_));
    theta0_ = std::atan2(initial.linear()(1, 0), initial.linear()(0, 0));
    t0_ = initial.translation();
    // A scan point lands in cell c + o for an offset o, with |c| <= `near` cells (its distance
    // from the grid's corner), and scores only inside [-pad, size): offsets beyond `reachable`
    // put every point off the grid, score 0 and cannot be a match, so a window wider than the
    // grid is clipped to it (the result is the same; the roots below stay few).
    const Scalar near =
        std::ceil(((t0_ - origin_).template lpNorm<Eigen::Infinity>() + d_far) / r) + 1;
    const Scalar reachable = near + Scalar(std::max(width_, height_) + pad_ + 1);
    const auto cells = [&](Scalar half_width) {
      return static_cast<int>(std::min({std::ceil(half_width / r), reachable, Scalar(1 << 20)}));
    };
    wx_ = cells(window.linear);
    wy_ = cells(linear_y);
    const Scalar w = Scalar(wx_), h = Scalar(wy_);

    // Per angle, the scan's cells split by what the window's offsets ([-wx, wx] × [-wy, wy]
    // cells) do to them: a cell outside the grid for every offset adds 0 to every bound and is
    // dropped; one inside for every offset is kept as its linear index (no bounds test in the
    // search's inner loop); the rest are tested per node.
    const std::size_t n = points_.size();
    const auto angle_count = static_cast<std::size_t>(2 * angles_ + 1);
    inside_.clear();
    border_.clear();
    inside_begin_.assign(angle_count + 1, 0);
    border_begin_.assign(angle_count + 1, 0);
    for (int a = -angles_; a <= angles_; ++a) {
      const Scalar theta = theta0_ + Scalar(a) * step_;
      const Scalar c = std::cos(theta), s = std::sin(theta);
      for (std::size_t k = 0; k < n; ++k) {
        const point_type& p = points_[k];
        const Scalar x = c * p.x() - s * p.y() + t0_.x(), y = s * p.x() + c * p.y() + t0_.y();
        const Scalar fx = std::floor((x - origin_.x()) / r), fy = std::floor((y - origin_.y()) / r);
        if (fx + w < Scalar(-pad_) || fy + h < Scalar(-pad_) || fx - w >= Scalar(width_) ||
            fy - h >= Scalar(height_))
          continue;  // never on the grid (also keeps the casts below in range)
        const Cell cell{static_cast<int>(fx), static_cast<int>(fy)};
        if (cell.x - wx_ >= -pad_ && cell.y - wy_ >= -pad_ && cell.x + wx_ < width_ &&
            cell.y + wy_ < height_)
          inside_.push_back(static_cast<std::ptrdiff_t>(index(cell.x, cell.y)));
        else
          border_.push_back(cell);
      }
      const auto next = static_cast<std::size_t>(a + angles_) + 1;
      inside_begin_[next] = inside_.size();
      border_begin_[next] = border_.size();
    }
    if (inside_.empty() && border_.empty()) return false;  // the scan never meets the grid
    const int top = params_.levels - 1;
    roots_.clear();
    for (int a = -angles_; a <= angles_; ++a)
      for (int x = -wx_; x <= wx_; x += 1 << top)
        for (int y = -wy_; y <= wy_; y += 1 << top)
          roots_.push_back({a + angles_, x, y, score(top, a + angles_, x, y)});
    std::sort(roots_.begin(), roots_.end(), by_score);
    return true;
  }

  // Branch and bound over the prepared roots.
  std::optional<CorrelativeMatch<Scalar>> run(
      Scalar min_score, const std::optional<SearchExclusion<Scalar>>& exclusion) const {
    const Scalar r = params_.resolution;
    const auto n = static_cast<Scalar>(points_.size());
    exclusion_ = exclusion;
    if (exclusion_) {  // in cell offsets from t0
      exclusion_->center.translation() = (exclusion_->center.translation() - t0_) / r;
      exclusion_->radius /= r;
    }
    // The least sum that does not beat min_score: a leaf must exceed it, as before.
    const Scalar threshold = std::clamp(min_score, Scalar(0), Scalar(1)) * n * Scalar(cell_max);
    Candidate best{0, 0, 0, static_cast<Sum>(std::floor(threshold))};
    bool found = false;
    search(roots_, params_.levels - 1, best, found);
    if (!found) return std::nullopt;
    CorrelativeMatch<Scalar> m;
    const Scalar theta = theta0_ + Scalar(best.angle - angles_) * step_;
    m.pose = make_transform2(t0_.x() + Scalar(best.x) * r, t0_.y() + Scalar(best.y) * r, theta);
    m.score = static_cast<Scalar>(best.score) / (n * Scalar(cell_max));
    m.points = points_.size();
    return m;
  }

  // Eq. (15): the summed precomputed grid of height h at the scan's cells shifted by (x, y).
  [[nodiscard]] Sum score(int h, int angle, int x, int y) const {
    const auto a = static_cast<std::size_t>(angle);
    const Cell16* grid = grids_[static_cast<std::size_t>(h)].data();
    const std::ptrdiff_t shift = static_cast<std::ptrdiff_t>(y) * stride_ + x;
    Sum sum = 0;
    for (std::size_t k = inside_begin_[a]; k < inside_begin_[a + 1]; ++k)
      sum += grid[inside_[k] + shift];
    for (std::size_t k = border_begin_[a]; k < border_begin_[a + 1]; ++k)
      sum += value(h, border_[k].x + x, border_[k].y + y);
    return sum;
  }
  // score() of the four children of the node at (x, y) (offsets 0 and s per axis, in the order
  // 2 dx + dy) in one pass over the scan's cells, which dominates the search: the same sums as
  // four score() calls.
  [[nodiscard]] std::array<Sum, 4> score_children(int h, int angle, int x, int y, int s) const {
    const auto a = static_cast<std::size_t>(angle);
    const Cell16* grid = grids_[static_cast<std::size_t>(h)].data();
    const std::ptrdiff_t shift = static_cast<std::ptrdiff_t>(y) * stride_ + x;
    const std::ptrdiff_t sx = s, sy = static_cast<std::ptrdiff_t>(s) * stride_;
    std::array<Sum, 4> sum{};
    for (std::size_t k = inside_begin_[a]; k < inside_begin_[a + 1]; ++k) {
      const Cell16* g = grid + inside_[k] + shift;
      sum[0] += g[0];
      sum[1] += g[sy];
      sum[2] += g[sx];
      sum[3] += g[sx + sy];
    }
    for (std::size_t k = border_begin_[a]; k < border_begin_[a + 1]; ++k) {
      const int bx = border_[k].x + x, by = border_[k].y + y;
      sum[0] += value(h, bx, by);
      sum[1] += value(h, bx, by + s);
      sum[2] += value(h, bx + s, by);
      sum[3] += value(h, bx + s, by + s);
    }
    return sum;
  }
  // Algorithm 3 (depth-first branch and bound, best child first).
  void search(const std::vector<Candidate>& candidates, int h, Candidate& best, bool& found) const {
    for (const Candidate& c : candidates) {
      if (c.score <= best.score) break;  // sorted: nothing later can beat the best
      expand(c, h, best, found);
    }
  }
  void expand(const Candidate& c, int h, Candidate& best, bool& found) const {
    if (excluded(c, h)) return;
    if (h == 0) {
      best = c;
      found = true;
      return;
    }
    const int s = 1 << (h - 1);
    // Children beyond the window stay at 0 and sort last (best.score >= 0 stops the loop first).
    std::array<Candidate, 4> children;
    children.fill({c.angle, c.x, c.y, 0});
    if (c.x + s <= wx_ && c.y + s <= wy_) {
      const std::array<Sum, 4> scores = score_children(h - 1, c.angle, c.x, c.y, s);
      for (int i = 0; i < 4; ++i)
        children[static_cast<std::size_t>(i)] = {c.angle, c.x + (i >> 1) * s, c.y + (i & 1) * s,
                                                 scores[static_cast<std::size_t>(i)]};
    } else {
      for (int dx = 0; dx < 2; ++dx)
        for (int dy = 0; dy < 2; ++dy) {
          const int x = c.x + dx * s, y = c.y + dy * s;
          if (x > wx_ || y > wy_) continue;
          children[static_cast<std::size_t>(2 * dx + dy)] = {c.angle, x, y,
                                                             score(h - 1, c.angle, x, y)};
        }
    }
    std::sort(children.begin(), children.end(), by_score);
    for (std::size_t i = 0; i < children.size(); ++i) {
      if (children[i].score <= best.score) break;
      expand(children[i], h - 1, best, found);
    }
  }
  // Whether every translation of node c (height h) lies in the exclusion: the farthest corner
  // of its square of offsets is within the radius.
  [[nodiscard]] bool excluded(const Candidate& c, int h) const {
    if (!exclusion_) return false;
    const Scalar size = Scalar((1 << h) - 1);
    const auto& e = exclusion_->center.translation();
    const Scalar dx = std::max(std::abs(Scalar(c.x) - e.x()), std::abs(Scalar(c.x) + size - e.x()));
    const Scalar dy = std::max(std::abs(Scalar(c.y) - e.y()), std::abs(Scalar(c.y) + size - e.y()));
    return dx * dx + dy * dy < exclusion_->radius * exclusion_->radius;
  }
  // One point per finest cell of the scan frame (mutable scratch: match() is const).
  void thin(std::span<const point_type> scan) const {
    const Scalar r = params_.resolution;
    keyed_.clear();
    for (const auto& p : scan)
      if (p.allFinite())
        keyed_.push_back({static_cast<std::int64_t>(std::floor(p.x() / r)),
                          static_cast<std::int64_t>(std::floor(p.y() / r)), p});
    std::sort(keyed_.begin(), keyed_.end(), [](const Keyed& a, const Keyed& b) {
      return a.cx < b.cx || (a.cx == b.cx && a.cy < b.cy);
    });
    points_.clear();
    for (std::size_t i = 0; i < keyed_.size(); ++i)
      if (i == 0 || keyed_[i].cx != keyed_[i - 1].cx || keyed_[i].cy != keyed_[i - 1].cy)
        points_.push_back(keyed_[i].p);
  }
  struct Keyed {
    std::int64_t cx, cy;
    point_type p;
  };

  CorrelativeScanMatcherParams<Scalar> params_;
  point_type origin_;  ///< model-frame corner of cell (0, 0)
  int width_ = 0, height_ = 0, pad_ = 0, stride_ = 0;
  std::vector<std::vector<Cell16>> grids_;  ///< level h: Eq. (14), cells [-pad, size)
  mutable std::vector<Keyed> keyed_;
  mutable std::vector<point_type> points_;
  mutable std::vector<Scalar> ranges_;
  // The prepared search (prepare()): rotated scans split per angle, sorted roots, the step.
  mutable std::vector<std::ptrdiff_t> inside_;
  mutable std::vector<Cell> border_;
  mutable std::vector<std::size_t> inside_begin_, border_begin_;
  mutable std::vector<Candidate> roots_;
  mutable Scalar step_ = 0, theta0_ = 0;
  mutable point_type t0_ = point_type::Zero();
  mutable int angles_ = 0, wx_ = 0, wy_ = 0;
  mutable std::optional<SearchExclusion<Scalar>> exclusion_;  ///< in cell offsets
};

}  // namespace rangenav
