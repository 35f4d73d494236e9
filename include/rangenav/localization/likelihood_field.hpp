#pragma once
// The likelihood-field ("end-point") sensor model of Probabilistic Robotics (§6.4, Table 6.3)
// over an OccupancyGrid, the observation model paper 001 §IV uses for the static map: a beam's
// end point is scored by its distance d to the nearest occupied cell,
//   p(z_j | x, m) = z_hit N(d; 0, sigma_hit^2) + z_rand / z_max,
// and beams are independent (Eq. 5 of paper 001). The distances come from an exact Euclidean
// distance transform of the occupied cells (Felzenszwalb & Huttenlocher's lower-envelope
// algorithm), and log p is precomputed per cell, so scoring a particle is one table lookup per
// beam: no allocation, no branch but the map bounds. Readings without a return are skipped.
//
// Beams are not independent (neighbouring beams see the same wall and the same unmapped object),
// so Eq. (5) over all 181 beams of a scan is overconfident: a closed door missing from the map
// (two short unexplained segments per doorway) then shifts the scan's likelihood maximum along a
// corridor by up to a door's width, by tens of nats per scan, and the filter follows it and loses
// the robot. As AMCL does, the defaults use at most 30 evenly spaced beams and sigma_hit = 0.2 m
// (AMCL's laser_max_beams and laser_sigma_hit), which keeps standard MCL within the paper's
// 0.05-0.22 m band with closed doors removed from the map (tests/localization/mcl.cpp).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <string_view>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/mapping/occupancy_grid.hpp"
#include "rangenav/scan/laser_scan.hpp"

namespace rangenav {

namespace detail {
/// One pass of the 1D squared Euclidean distance transform along n samples of f (stride apart):
/// d[q] = min_p (q - p)^2 + f[p]. v and z are scratch of n and n + 1 entries.
inline void squared_distance_1d(float* f, std::size_t n, std::size_t stride, std::vector<float>& d,
                                std::vector<int>& v, std::vector<float>& z) {
  constexpr float inf = std::numeric_limits<float>::infinity();
  const auto at = [&](std::size_t i) { return f[i * stride]; };
  int k = -1;
  for (int q = 0; q < static_cast<int>(n); ++q) {
    const float fq = at(static_cast<std::size_t>(q));
    if (fq == inf) continue;
    float s = -inf;
    while (k >= 0) {
      const int p = v[static_cast<std::size_t>(k)];
      const float fp = at(static_cast<std::size_t>(p));
      s = ((fq + float(q) * float(q)) - (fp + float(p) * float(p))) / (2.0f * float(q - p));
      if (s > z[static_cast<std::size_t>(k)]) break;
      --k;
    }
    ++k;
    v[static_cast<std::size_t>(k)] = q;
    z[static_cast<std::size_t>(k)] = k == 0 ? -inf : s;
    z[static_cast<std::size_t>(k) + 1] = inf;
  }
  if (k < 0) return;  // no site on this line: all stays infinite
  int j = 0;
  for (int q = 0; q < static_cast<int>(n); ++q) {
    while (z[static_cast<std::size_t>(j) + 1] < float(q))
      ++j;
    const int p = v[static_cast<std::size_t>(j)];
    d[static_cast<std::size_t>(q)] = float(q - p) * float(q - p) + at(static_cast<std::size_t>(p));
  }
  for (std::size_t q = 0; q < n; ++q)
    f[q * stride] = d[q];
}
}  // namespace detail

/// Squared Euclidean distances (in cells^2) from every cell of a width x height row-major mask
/// to the nearest set cell; +inf everywhere when no cell is set.
[[nodiscard]] inline std::vector<float> squared_distance_transform(
    const std::vector<std::uint8_t>& mask, std::size_t width, std::size_t height) {
  // width * height must not wrap around to mask.size().
  const bool wraps = height != 0 && width > std::numeric_limits<std::size_t>::max() / height;
  if (wraps || mask.size() != width * height)
    detail::throw_invalid_argument(
        "squared_distance_transform", "mask.size()", mask.size(),
        "must equal width * height = " +
            (wraps ? std::to_string(width) + " * " + std::to_string(height) + " (overflows)"
                   : std::to_string(width * height)));
  std::vector<float> f(mask.size());
  for (std::size_t i = 0; i < mask.size(); ++i)
    f[i] = mask[i] ? 0.0f : std::numeric_limits<float>::infinity();
  const std::size_t n = std::max(width, height);
  std::vector<float> d(n), z(n + 1);
  std::vector<int> v(n);
  for (std::size_t x = 0; x < width; ++x)
    detail::squared_distance_1d(&f[x], height, width, d, v, z);
  for (std::size_t y = 0; y < height; ++y)
    detail::squared_distance_1d(&f[y * width], width, 1, d, v, z);
  return f;
}

/// Parameters of the likelihood-field sensor model (Probabilistic Robotics §6.4; AMCL's defaults).
struct LikelihoodFieldParams {
  double sigma_hit{0.2};       ///< std. deviation of the end point's distance (m)
  double z_hit{0.95};          ///< weight of the Gaussian
  double z_rand{0.05};         ///< weight of random readings, spread uniformly over [0, range_max]
  double range_max{30.0};      ///< the z_max of the random term (m)
  double max_distance{2.0};    ///< distances are clamped here (m); also the value off the map
  std::size_t beam_stride{1};  ///< use every beam_stride-th valid beam (>= 1)
  std::size_t max_beams{30};   ///< then at most this many, evenly spaced (0: no limit)

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where) const {
    detail::require_positive(where, "sigma_hit", sigma_hit);
    detail::require_non_negative(where, "z_hit", z_hit);
    detail::require_non_negative(where, "z_rand", z_rand);
    if (!(z_rand > 0 || z_hit > 0)) detail::throw_invalid(where, "z_hit + z_rand must be > 0");
    detail::require_positive(where, "range_max", range_max);
    detail::require_positive(where, "max_distance", max_distance);
    if (beam_stride == 0)
      detail::throw_invalid_argument(where, "beam_stride", beam_stride, "must be >= 1");
  }
};

/// Calls f(k) for the positions k in [0, n) of the valid beams a scan contributes: every
/// beam_stride-th one, then at most max_beams of those, evenly spaced from the first to the last.
template <class F>
void for_each_used_beam(std::size_t n, const LikelihoodFieldParams& params, F&& f) {
  const std::size_t stride = std::max<std::size_t>(1, params.beam_stride);
  const std::size_t strided = n == 0 ? 0 : (n - 1) / stride + 1;
  if (params.max_beams == 0 || strided <= params.max_beams) {
    for (std::size_t k = 0; k < n; k += stride)
      f(k);
    return;
  }
  if (params.max_beams == 1) {
    f(std::size_t{0});
    return;
  }
  // m-th of max_beams picks: round(m (strided - 1) / (max_beams - 1)), in integers.
  const std::size_t span = strided - 1, parts = params.max_beams - 1;
  for (std::size_t m = 0; m < params.max_beams; ++m)
    f(stride * ((m * span + parts / 2) / parts));
}

/// The likelihood-field sensor model over an occupancy grid: log p per cell precomputed from an
/// exact Euclidean distance transform, one lookup per beam end point.
class LikelihoodFieldModel {
 public:
  /// A scan prepared once for scoring many particles: the end points of the used beams in the
  /// robot frame.
  struct Observation {
    std::vector<Eigen::Vector2f> end_points;  ///< robot frame
  };

  /// Precomputes the field of the grid's occupied cells (OccupancyGrid::is_occupied()).
  explicit LikelihoodFieldModel(const OccupancyGrid& grid, const LikelihoodFieldParams& params = {})
      : params_(params) {
    params_.validate("LikelihoodFieldModel");
    width_ = grid.width();
    height_ = grid.height();
    origin_ = grid.origin();
    resolution_ = grid.resolution();
    std::vector<std::uint8_t> mask(grid.cell_count());
    for (int y = 0; y < height_; ++y)
      for (int x = 0; x < width_; ++x)
        mask[grid.linear({x, y})] = grid.is_occupied({x, y}) ? 1 : 0;
    const std::vector<float> d_sq = squared_distance_transform(
        mask, static_cast<std::size_t>(width_), static_cast<std::size_t>(height_));
    distance_.resize(d_sq.size());
    log_p_.resize(d_sq.size());
    const double r_sq = resolution_ * resolution_;
    for (std::size_t i = 0; i < d_sq.size(); ++i) {
      const double d = std::min(params_.max_distance, std::sqrt(double(d_sq[i]) * r_sq));
      distance_[i] = static_cast<float>(d);
      log_p_[i] = static_cast<float>(log_likelihood_of_distance(d));
    }
    off_map_ = static_cast<float>(log_likelihood_of_distance(params_.max_distance));
  }

  /// The parameters.
  [[nodiscard]] const LikelihoodFieldParams& params() const { return params_; }

  /// log p(z_j | d) for an end point at distance d from the nearest obstacle.
  [[nodiscard]] double log_likelihood_of_distance(double d) const {
    const double s = params_.sigma_hit;
    const double gauss = std::exp(-0.5 * d * d / (s * s)) / (s * std::sqrt(2 * std::numbers::pi));
    return std::log(params_.z_hit * gauss + params_.z_rand / params_.range_max);
  }

  /// Distance from p to the nearest occupied cell centre (clamped to max_distance; off the map:
  /// max_distance).
  [[nodiscard]] double distance(const Point2d& p) const {
    const auto i = index_of(p.x(), p.y());
    return i < 0 ? params_.max_distance : double(distance_[static_cast<std::size_t>(i)]);
  }
  /// log p(z_j | x, m) of an end point given in the map frame.
  [[nodiscard]] double log_likelihood_at(const Point2d& p) const {
    return log_likelihood_of_cell(index_of(p.x(), p.y()));
  }

  /// Row-major index of the cell holding p (the cell log_likelihood_at() reads), -1 off the map.
  [[nodiscard]] std::ptrdiff_t cell_index(const Point2d& p) const { return index_of(p.x(), p.y()); }
  /// log p(z_j | x, m) of an end point in cell i (cell_index(); -1: off the map), the same value
  /// as log_likelihood_at().
  [[nodiscard]] double log_likelihood_of_cell(std::ptrdiff_t i) const {
    return i < 0 ? double(off_map_) : double(log_p_[static_cast<std::size_t>(i)]);
  }

  /// Prepares a scan taken by a sensor at `sensor_pose` in the robot frame into `out` (its buffer
  /// is reused). Throws invalid_argument for a non-finite sensor pose.
  template <class S>
  void prepare(const LaserScan<S>& scan, const Pose2d& sensor_pose, Observation& out) const {
    detail::require_finite("LikelihoodFieldModel::prepare", "sensor_pose.x", sensor_pose.x);
    detail::require_finite("LikelihoodFieldModel::prepare", "sensor_pose.y", sensor_pose.y);
    detail::require_finite("LikelihoodFieldModel::prepare", "sensor_pose.theta", sensor_pose.theta);
    out.end_points.clear();
    const auto& valid = scan.valid_indices();
    for_each_used_beam(valid.size(), params_, [&](std::size_t k) {
      const auto& q = scan.point(valid[k]);
      out.end_points.push_back(
          sensor_pose.transform_point(Point2d(double(q.x()), double(q.y()))).cast<float>());
    });
  }
  /// As prepare(scan, sensor_pose, out), returning a new Observation.
  template <class S>
  [[nodiscard]] Observation prepare(const LaserScan<S>& scan,
                                    const Pose2d& sensor_pose = {}) const {
    Observation out;
    prepare(scan, sensor_pose, out);
    return out;
  }

  /// Eq. (5) of paper 001 for the static map: the sum of the beams' log-likelihoods.
  [[nodiscard]] double log_likelihood(const Pose2d& x, const Observation& z) const {
    const float inv = static_cast<float>(1.0 / resolution_);
    const float c = static_cast<float>(std::cos(x.theta)) * inv;
    const float s = static_cast<float>(std::sin(x.theta)) * inv;
    const float gx0 = static_cast<float>((x.x - origin_.x()) / resolution_);
    const float gy0 = static_cast<float>((x.y - origin_.y()) / resolution_);
    const float w = static_cast<float>(width_), h = static_cast<float>(height_);
    float sum = 0;
    for (const Eigen::Vector2f& q : z.end_points) {
      const float gx = gx0 + c * q.x() - s * q.y();
      const float gy = gy0 + s * q.x() + c * q.y();
      if (gx >= 0 && gy >= 0 && gx < w && gy < h)
        sum += log_p_[static_cast<std::size_t>(gy) * static_cast<std::size_t>(width_) +
                      static_cast<std::size_t>(gx)];
      else
        sum += off_map_;
    }
    return double(sum);
  }

 private:
  [[nodiscard]] std::ptrdiff_t index_of(double px, double py) const {
    const double gx = (px - origin_.x()) / resolution_, gy = (py - origin_.y()) / resolution_;
    if (!(gx >= 0 && gy >= 0 && gx < width_ && gy < height_)) return -1;
    return static_cast<std::ptrdiff_t>(gy) * width_ + static_cast<std::ptrdiff_t>(gx);
  }

  LikelihoodFieldParams params_;
  int width_{0}, height_{0};
  Point2d origin_{0, 0};
  double resolution_{1};
  std::vector<float> distance_;
  std::vector<float> log_p_;
  float off_map_{0};
};

}  // namespace rangenav
