#pragma once
// Floor handling for obstacle maps (3D-perception paper 002 §4.2).
//
// Points on traversable floor must not enter an obstacle map. Two ways are offered:
//  - the simple height threshold floor(p) = p_z in [-ε_z, ε_z] (ε_z = 2.5 cm in the paper), which
//    also removes small objects lower than ε_z;
//  - the neighbourhood-based classification after Wulf et al. / Nüchter et al., which uses the
//    order of points in a scan and of scans in a sweep (or of pixels in a depth image): in an
//    organised grid (rows = scans in pitch order or image rows, columns = beams or pixels) a point
//    near z = 0 is an obstacle only if it rises more than a step height ε_H above the lowest point
//    of its neighbourhood W (and more than min_height above the floor plane); otherwise it is
//    floor. W is the Moore neighbourhood extended along the point's column (the same beam in
//    the neighbouring scans of the sweep, or the image column) as long as the points stay within
//    window_radius horizontally: a vertical face is sampled densely in height, so W must reach
//    down its full height to the floor in front of it. The front face and the edges of a 2-cm
//    object rise above the floor next to them and survive, while flat floor with noise does not,
//    and only the high side of a step is marked, so the obstacle boundary stays where it is.
// Readings below floor level (holes, descending stairs) become an artificial obstacle where the
// beam meets the floor plane, so the robot stops before the first step.

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "rangenav/core/cloud.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// The classes of §4.2 (after Wulf et al. 2004 / Nüchter et al. 2005), plus invalid readings and
/// readings below floor level.
enum class PointClass : std::uint8_t {
  invalid,      ///< non-finite point
  floor,        ///< traversable floor
  obstacle,     ///< anything between floor and walls / ceiling the robot could hit
  wall,         ///< non-horizontal structure above wall_height
  ceiling,      ///< horizontal structure above ceiling_height
  below_floor,  ///< lower than the floor: a hole or a descending stair
};

/// The simple height threshold of §4.2: p_z in [-ε_z, ε_z].
template <std::floating_point Scalar>
[[nodiscard]] bool is_floor_height(Scalar z, Scalar epsilon_z = Scalar(0.025)) {
  return z >= -epsilon_z && z <= epsilon_z;
}

/// The height noise (1 sigma, m) of floor readings of a range sensor with range noise
/// `range_noise` (1 sigma, m) whose steepest beam onto the floor points `steepest_depression`
/// (rad) below the horizontal: a range error moves a reading along its beam, so a floor reading
/// seen under the depression δ scatters in height with σ_r sin δ (the "tolerance according to the
/// sensor's accuracy" of §4.2). For a pitching scanner δ_max is its largest pitch (Eq. 3).
template <std::floating_point Scalar>
[[nodiscard]] Scalar floor_height_noise(Scalar range_noise, Scalar steepest_depression) {
  detail::require_non_negative("floor_height_noise", "range_noise", range_noise);
  detail::require_finite("floor_height_noise", "steepest_depression", steepest_depression);
  return range_noise * std::abs(std::sin(steepest_depression));
}

/// Parameters of the neighbourhood-based classification. Heights are above the floor (m).
///
/// A floor reading is only called an obstacle when it lies noise_factor σ_z above the floor plane
/// and above the lowest point of its neighbourhood, σ_z = floor_height_noise(range_noise, δ) for
/// the depression δ under which the sensor sees it (when the classification knows the sensor's
/// origin), else for steepest_depression. Thresholds fixed in metres fail with noise: the lowest
/// point of W is the minimum of some 10-40 noisy floor readings, about 2.5 σ_z below the floor,
/// so the neighbourhood test alone passes a floor reading only 1 σ_z high, and 1.5 cm above the
/// plane is only 2.3 σ_z for the steepest beams of a pitching scanner with 1 cm range noise.
/// With noise_factor = 5 a floor reading passes with a probability below 3e-7 (one-sided 5 σ).
/// The defaults are the simulator's pitching scanner (σ_r = 1 cm, pitch up to 40 deg, axis 0.55 m
/// high): 3.2 cm where the beams are steepest, near the robot, falling to the 1.5 cm floor of
/// min_height / step_height from about 1.75 m on; a 3-cm object 1.5 m ahead keeps its front face
/// above 1.7 cm (§4.2: small objects must survive), and the map keeps it as the robot comes
/// closer. Without the sensor's origin every point gets the steepest beam's 3.2 cm.
template <std::floating_point Scalar = double>
struct FloorClassifierParams {
  /// |z| <= floor_band may be floor; whether it is, the neighbourhood decides.
  Scalar floor_band{Scalar(0.05)};
  /// ε_H: a point more than max(step_height, noise_factor σ_z) above the lowest point of its
  /// neighbourhood is not floor.
  Scalar step_height{Scalar(0.015)};
  /// ... and it must lie max(min_height, noise_factor σ_z) above the floor plane z = 0
  /// (against isolated noise and the floor's own unevenness).
  Scalar min_height{Scalar(0.015)};
  /// σ_r (m, 1 sigma): the sensor's range noise; 1 cm is the simulator's default, 5 mm a SICK
  /// LMS 2xx's. 0: the fixed thresholds alone.
  Scalar range_noise{Scalar(0.01)};
  /// δ_max (rad): the steepest depression of a beam onto the floor, used when the sensor's
  /// origin is not known (a pitching scanner's largest pitch; 40 deg in the simulator).
  Scalar steepest_depression{std::numbers::pi_v<Scalar> * 2 / 9};
  /// How many σ_z a floor reading must rise to count as an obstacle.
  Scalar noise_factor{Scalar(5)};
  /// m: the neighbourhood extends along the column while points stay this close horizontally.
  Scalar window_radius{Scalar(0.1)};
  /// The most points visited in each direction of the column.
  std::size_t window_steps{16};
  /// z < -below_floor is below floor level (§4.2: holes, descending stairs).
  Scalar below_floor{Scalar(0.05)};
  /// Non-floor points at or above this height are walls (if not ceiling).
  Scalar wall_height{Scalar(1.0)};
  /// Horizontal points (neighbourhood height range <= step_height) at or above this height.
  Scalar ceiling_height{Scalar(1.9)};

  /// The heights a point seen from `sensor_origin` (nullptr: unknown) must rise above the floor
  /// plane and above the lowest point of its neighbourhood to be an obstacle.
  [[nodiscard]] std::pair<Scalar, Scalar> thresholds(const Point<3, Scalar>& p,
                                                     const Point<3, Scalar>* sensor_origin) const {
    // floor_height_noise(range_noise, δ) with sin δ from the beam when the origin is known.
    const Scalar d = sensor_origin != nullptr ? (p - *sensor_origin).norm() : Scalar(0);
    const Scalar sin_depression =
        d > Scalar(0) ? (sensor_origin->z() - p.z()) / d : std::sin(steepest_depression);
    const Scalar noise = noise_factor * range_noise * std::abs(sin_depression);
    return {std::max(min_height, noise), std::max(step_height, noise)};
  }

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where = "FloorClassifierParams") const {
    detail::require_non_negative(where, "floor_band", floor_band);
    detail::require_positive(where, "step_height", step_height);
    detail::require_non_negative(where, "min_height", min_height);
    detail::require_non_negative(where, "range_noise", range_noise);
    detail::require_finite(where, "steepest_depression", steepest_depression);
    detail::require_non_negative(where, "noise_factor", noise_factor);
    detail::require_non_negative(where, "window_radius", window_radius);
    detail::require_non_negative(where, "below_floor", below_floor);
    detail::require_finite(where, "wall_height", wall_height);
    detail::require_finite(where, "ceiling_height", ceiling_height);
  }
};

namespace detail {

/// Lowest and highest z in the neighbourhood W of point (r, c) of an organised grid: the Moore
/// neighbourhood plus the points of the same column within `radius` horizontally (at most
/// `steps` each way). Points lower than -below_floor and non-finite points are skipped.
template <std::floating_point Scalar>
void window_height_range(std::span<const Point<3, Scalar>> points, std::size_t width,
                         std::size_t height, std::size_t r, std::size_t c, Scalar radius,
                         std::size_t steps, Scalar below_floor, Scalar& lo, Scalar& hi,
                         Scalar stop_below = -std::numeric_limits<Scalar>::infinity()) {
  const Point<3, Scalar>& p = points[r * width + c];
  lo = hi = p.z();
  const auto visit = [&](const Point<3, Scalar>& q) {
    const Scalar z = q.z();
    if (!std::isfinite(z) || z < -below_floor) return;
    lo = std::min(lo, z);
    hi = std::max(hi, z);
  };
  const std::size_t r0 = r == 0 ? 0 : r - 1, r1 = std::min(r + 1, height - 1);
  const std::size_t c0 = c == 0 ? 0 : c - 1, c1 = std::min(c + 1, width - 1);
  for (std::size_t rr = r0; rr <= r1; ++rr)
    for (std::size_t cc = c0; cc <= c1; ++cc)
      visit(points[rr * width + cc]);
  const Scalar radius_sq = radius * radius;
  for (int dir = -1; dir <= 1; dir += 2)
    for (std::size_t k = 2; k <= steps; ++k) {
      const std::ptrdiff_t rr =
          static_cast<std::ptrdiff_t>(r) + dir * static_cast<std::ptrdiff_t>(k);
      if (rr < 0 || rr >= static_cast<std::ptrdiff_t>(height)) break;
      const Point<3, Scalar>& q = points[static_cast<std::size_t>(rr) * width + c];
      if (!q.allFinite()) continue;
      if ((q.template head<2>() - p.template head<2>()).squaredNorm() > radius_sq) break;
      visit(q);
      if (lo < stop_below) return;
    }
}

}  // namespace detail

/// The class of point (r, c) of an organised grid of `height` rows (see classify_points).
template <std::floating_point Scalar>
[[nodiscard]] PointClass classify_point(std::span<const Point<3, Scalar>> points, std::size_t width,
                                        std::size_t height, std::size_t r, std::size_t c,
                                        const FloorClassifierParams<Scalar>& params,
                                        const Point<3, Scalar>* sensor_origin = nullptr) {
  const Point<3, Scalar>& p = points[r * width + c];
  if (!p.allFinite()) return PointClass::invalid;
  const Scalar z = p.z();
  if (z < -params.below_floor) return PointClass::below_floor;
  // Neighbours below floor level do not count: a floor point at the edge of a stair is still
  // floor (the stair gets its own artificial obstacle).
  Scalar lo, hi;
  detail::window_height_range(points, width, height, r, c, params.window_radius,
                              params.window_steps, params.below_floor, lo, hi);
  if (std::abs(z) <= params.floor_band) {
    const auto [min_height, step_height] = params.thresholds(p, sensor_origin);
    if (z - lo <= step_height || z <= min_height) return PointClass::floor;
  }
  if (z >= params.ceiling_height && hi - lo <= params.step_height) return PointClass::ceiling;
  if (z >= params.wall_height) return PointClass::wall;
  return PointClass::obstacle;
}

/// Classifies the points of an organised grid (row-major, `width` columns; rows = consecutive
/// scans of a sweep or image rows, columns = beams or pixels; non-finite points are invalid) into
/// `classes` (resized to the point count). Heights z are above the floor in the robot frame.
/// `sensor_origin` (same frame, nullptr: unknown) gives each point its own noise threshold.
template <std::floating_point Scalar>
void classify_points(std::span<const Point<3, Scalar>> points, std::size_t width,
                     const FloorClassifierParams<Scalar>& params, std::vector<PointClass>& classes,
                     const Point<3, Scalar>* sensor_origin = nullptr) {
  if (width == 0 || points.size() % width != 0)
    detail::throw_invalid_argument(
        "classify_points", "width", width,
        "must be > 0 and divide the point count " + std::to_string(points.size()));
  params.validate("classify_points");
  const std::size_t height = points.size() / width;
  classes.resize(points.size());
  for (std::size_t r = 0; r < height; ++r)
    for (std::size_t c = 0; c < width; ++c)
      classes[r * width + c] = classify_point(points, width, height, r, c, params, sensor_origin);
}

/// The same for an organised Cloud (width x height).
template <std::floating_point Scalar>
void classify_points(const Cloud<3, Scalar>& cloud, const FloorClassifierParams<Scalar>& params,
                     std::vector<PointClass>& classes) {
  cloud.validate("classify_points");
  classify_points(std::span<const Point<3, Scalar>>(cloud.points), cloud.width, params, classes);
}

/// Where the beam from the sensor origin through a point below floor level meets the floor plane
/// z = 0 (§4.2, the red cross of Fig. 4); empty when the origin is not above the floor or the
/// point not below it.
template <std::floating_point Scalar>
[[nodiscard]] std::optional<Point<3, Scalar>> floor_intersection(
    const Point<3, Scalar>& sensor_origin, const Point<3, Scalar>& below) {
  if (!(sensor_origin.z() > Scalar(0) && below.z() < Scalar(0))) return std::nullopt;
  const Scalar t = sensor_origin.z() / (sensor_origin.z() - below.z());
  Point<3, Scalar> q = sensor_origin + t * (below - sensor_origin);
  q.z() = Scalar(0);
  return q;
}

/// The points an obstacle map should receive from classified points (§4.2): every obstacle, wall
/// and ceiling point as measured (the map's virtual corridor decides on its height), and for
/// every point below floor level an artificial obstacle on the floor plane where its beam from
/// `sensor_origin` meets it. Appends to `out`; returns the number appended.
template <std::floating_point Scalar>
std::size_t append_obstacle_points(std::span<const Point<3, Scalar>> points,
                                   std::span<const PointClass> classes,
                                   const Point<3, Scalar>& sensor_origin,
                                   std::vector<Point<3, Scalar>>& out) {
  if (classes.size() != points.size())
    detail::throw_invalid_argument("append_obstacle_points", "classes.size()", classes.size(),
                                   "must equal points.size() = " + std::to_string(points.size()));
  const std::size_t before = out.size();
  for (std::size_t i = 0; i < points.size(); ++i) {
    switch (classes[i]) {
      case PointClass::obstacle:
      case PointClass::wall:
      case PointClass::ceiling:
        out.push_back(points[i]);
        break;
      case PointClass::below_floor:
        if (const auto q = floor_intersection(sensor_origin, points[i])) out.push_back(*q);
        break;
      case PointClass::floor:
      case PointClass::invalid:
        break;
    }
  }
  return out.size() - before;
}

/// The simple variant of §4.2: drops points with |z| <= ε_z, turns points below -ε_z into
/// artificial obstacles on the floor plane, keeps the rest. Appends to `out`.
template <std::floating_point Scalar>
std::size_t append_obstacle_points_threshold(std::span<const Point<3, Scalar>> points,
                                             Scalar epsilon_z,
                                             const Point<3, Scalar>& sensor_origin,
                                             std::vector<Point<3, Scalar>>& out) {
  detail::require_non_negative("append_obstacle_points_threshold", "epsilon_z", epsilon_z);
  const std::size_t before = out.size();
  for (const auto& p : points) {
    if (!p.allFinite() || is_floor_height(p.z(), epsilon_z)) continue;
    if (p.z() < -epsilon_z) {
      if (const auto q = floor_intersection(sensor_origin, p)) out.push_back(*q);
    } else {
      out.push_back(p);
    }
  }
  return out.size() - before;
}

}  // namespace rangenav
