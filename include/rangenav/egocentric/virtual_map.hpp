#pragma once
// Egocentric virtual 2D maps (3D-perception paper 002 §4): a vector of N = Θ / Δθ bearing bins
// around the robot, each holding one point in polar (range, bearing) and Cartesian (x, y)
// coordinates plus its height z (a 2.5D representation, §4.4.3) and an age counter. Which of two
// readings in one bin is kept is the map's policy: an obstacle map keeps the nearest reading
// inside the virtual corridor (§4.2), a structure map the farthest (§4.3).
//
// Empty bins hold dummy points (§4.4): max range for obstacle maps, 0 m for structure maps; as a
// LaserScan those are invalid readings that every scan algorithm ignores, so ICP, Monte-Carlo
// localization or free-space steering run on a virtual map unchanged (to_laser_scan()). The map
// itself models the 2D PointCloud concept over its non-dummy points, in bin order.
//
// The update procedure of §4.4 with a pose shift and new readings:
//   1. transformation of every stored point by the pose shift (Eq. 4), keeping the polar
//      coordinates in step; two points falling into one bin are resolved by the policy;
//   2. removal of points transformed more than max_age times (§4.4.2);
//   3. replacement of stored points by the new readings per the policy (§4.4.3); a reading of
//      the surface already stored (within the policy's noise tolerance) restarts its age.
// Steps 1 and 2 are skipped when the robot did not move. Steps 1-2 run in one pass into a second
// bin buffer, all dummies, that is then swapped in; the bins just read are reset to dummies, so the
// buffer is ready for the next update. An update allocates nothing (the staging buffer of step 3
// for 2D scans grows only for a scan with more valid beams than any before).

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/scan/laser_scan.hpp"

namespace rangenav {

namespace detail {

/// atan2(y, x) in (-pi, pi] with an absolute error below 1e-10 rad (double), about twice as fast
/// as the C library's: octant reduction to t = min/max in [0, 1], then
/// atan(t) = pi/6 + atan((sqrt(3) t - 1) / (sqrt(3) + t)) for t > tan(15 deg) so that the
/// argument stays within |t| <= tan(15 deg), where the Taylor series to t^15 is accurate to
/// t^17 / 17 < 1.1e-11. atan2(0, 0) is 0.
template <std::floating_point S>
[[nodiscard]] inline S fast_atan2(S y, S x) {
  constexpr S pi = std::numbers::pi_v<S>;
  constexpr S sqrt3 = std::numbers::sqrt3_v<S>;
  constexpr S tan15 = S(0.26794919243112270647);
  const S ax = std::abs(x), ay = std::abs(y);
  const S hi = std::max(ax, ay), lo = std::min(ax, ay);
  if (!(hi > S(0))) return S(0);
  S t = lo / hi;
  S a = S(0);
  if (t > tan15) {
    t = (sqrt3 * t - S(1)) / (sqrt3 + t);
    a = pi / 6;
  }
  const S t2 = t * t;
  S p = S(-1) / S(15);
  p = p * t2 + S(1) / S(13);
  p = p * t2 - S(1) / S(11);
  p = p * t2 + S(1) / S(9);
  p = p * t2 - S(1) / S(7);
  p = p * t2 + S(1) / S(5);
  p = p * t2 - S(1) / S(3);
  p = p * t2 + S(1);
  a += t * p;
  if (ay > ax) a = pi / 2 - a;
  if (x < S(0)) a = pi - a;
  return y < S(0) ? -a : a;
}

/// The bearing of q + t given the bearing of q (|q| = q_range > 0): the angle between q and
/// q + t is atan(r) with r = (q x t) / (|q|^2 + q . t); for |r| <= 0.1 the series to r^9 is
/// accurate to 1e-12, otherwise (large shifts, near the origin) the full fast_atan2 is used.
/// Keeping the polar coordinates in step this way is what §4.4.1 asks for, and cheaper than
/// recomputing them. The series is evaluated in Estrin's form, (1 - r^2/3) + r^4 (1/5 - r^2/7 +
/// r^4/9), not Horner's: the bearing decides the bin and with it the memory the map update
/// touches next, so the latency of this chain, not its instruction count, bounds how many points
/// are in flight (Horner's five dependent multiply-adds make the update 3-8 % slower).
template <std::floating_point S>
[[nodiscard]] inline S shifted_bearing(S qx, S qy, S q_range, S q_bearing, S tx, S ty) {
  const S den = q_range * q_range + qx * tx + qy * ty;
  const S num = qx * ty - qy * tx;
  if (den > S(0) && std::abs(num) <= S(0.1) * den) {
    const S r = num / den, r2 = r * r, r4 = r2 * r2;
    const S atan_r =
        r * ((S(1) - r2 * (S(1) / 3)) + r4 * ((S(1) / 5 - r2 * (S(1) / 7)) + r4 * (S(1) / 9)));
    S b = q_bearing + atan_r;
    if (b > std::numbers::pi_v<S>) b -= 2 * std::numbers::pi_v<S>;
    if (b <= -std::numbers::pi_v<S>) b += 2 * std::numbers::pi_v<S>;
    return b;
  }
  return fast_atan2(qy + ty, qx + tx);
}

/// shifted_bearing() for the transformation of stored points by one pose shift, which is
/// small against their distances (a robot moves millimetres between scans): for |r| <= 0.01 the
/// series to r^5 is accurate to r^7 / 7 < 1.5e-15, two multiply-adds shorter (about 4 % of the
/// update's time). The replacement does not use it: the readings of a scanner mounted off
/// the rotation centre put r on both sides of 0.01, and the branch would be mispredicted.
template <std::floating_point S>
[[nodiscard]] inline S shifted_bearing_small_shift(S qx, S qy, S q_range, S q_bearing, S tx, S ty) {
  const S den = q_range * q_range + qx * tx + qy * ty;
  const S num = qx * ty - qy * tx;
  if (den > S(0) && std::abs(num) <= S(0.01) * den) {
    const S r = num / den, r2 = r * r, r4 = r2 * r2;
    S b = q_bearing + (r - r * r2 * (S(1) / 3) + r * r4 * (S(1) / 5));
    if (b > std::numbers::pi_v<S>) b -= 2 * std::numbers::pi_v<S>;
    if (b <= -std::numbers::pi_v<S>) b += 2 * std::numbers::pi_v<S>;
    return b;
  }
  return shifted_bearing(qx, qy, q_range, q_bearing, tx, ty);
}

}  // namespace detail

/// One bin of a virtual map: a point in robot coordinates with its polar coordinates, height and
/// the number of transformations (pose shifts) it has seen since it was measured.
template <std::floating_point Scalar = double>
struct VirtualMapPoint {
  Scalar x{0};           ///< m, robot frame
  Scalar y{0};           ///< m, robot frame
  Scalar z{0};           ///< m, height above the floor (2.5D)
  Scalar range{0};       ///< m, sqrt(x^2 + y^2)
  Scalar bearing{0};     ///< rad, atan2(y, x) in (-pi, pi]
  std::uint32_t age{0};  ///< transformations (pose shifts) since it was measured
  bool dummy{true};      ///< an empty bin (range = the policy's dummy range)

  /// The point (x, y).
  [[nodiscard]] Point<2, Scalar> xy() const { return {x, y}; }
  /// The point (x, y, z).
  [[nodiscard]] Point<3, Scalar> xyz() const { return {x, y, z}; }
};

/// A virtual-map policy decides which readings are admitted (`admits(range, z, max_range)`),
/// which of two readings in one bin is kept (`prefers(candidate_range, kept_range)`: true when
/// the candidate replaces the kept point) and the range of the dummy points of empty bins
/// (`dummy_range(max_range)`). Optionally `refreshes(new_range, kept_range)` says whether a new
/// reading the policy does not prefer is a re-observation of the stored point, which then keeps
/// its coordinates but restarts its age (§4.4.2 removes only points not measured again).
template <class P, class Scalar = double>
concept VirtualMapPolicy = std::floating_point<Scalar> && requires(const P& policy, Scalar value) {
  { policy.admits(value, value, value) } -> std::convertible_to<bool>;
  { policy.prefers(value, value) } -> std::convertible_to<bool>;
  { policy.dummy_range(value) } -> std::convertible_to<Scalar>;
};

namespace detail {
/// The policy's `refreshes` when it has one; without it nothing is a re-observation.
template <class P, std::floating_point S>
[[nodiscard]] bool policy_refreshes(const P& policy, S candidate, S kept) {
  if constexpr (requires {
                  { policy.refreshes(candidate, kept) } -> std::convertible_to<bool>;
                })
    return policy.refreshes(candidate, kept);
  else
    return false;
}
}  // namespace detail

/// Obstacle map (§4.2): keeps the nearest reading per bearing, admitting only readings whose
/// height lies in the virtual corridor [z_min, z_max], the robot's height band. A reading at
/// equal or smaller distance replaces the stored one (§4.4.3: "less than or equal"). A reading
/// at most refresh_tolerance (the sensor's range noise) farther is a re-observation of the
/// same surface: the stored, nearer point stays but its age restarts, so a point still in view
/// never ages out (§4.4.2 removes points *not* measured again) and the kept range never creeps
/// away from the robot. A reading farther than that is another surface and is ignored.
/// Floor points must be removed before insertion (egocentric/floor.hpp): with z_min = 0 the
/// corridor itself admits artificial obstacles placed on the floor plane (descending stairs).
struct ObstacleMapPolicy {
  double z_min{0.0};  ///< m, lower bound of the virtual corridor
  double z_max{1.0};  ///< m, upper bound of the virtual corridor (the robot's height)
  /// m; about 6 sigma of the SICK LMS 2xx range noise (5 mm). 0: nothing refreshes.
  double refresh_tolerance{0.03};

  /// Readings inside the virtual corridor and below the maximum range.
  template <std::floating_point S>
  [[nodiscard]] bool admits(S range, S z, S max_range) const {
    return range < max_range && z >= static_cast<S>(z_min) && z <= static_cast<S>(z_max);
  }
  /// The nearer (or equally near) reading replaces the kept one.
  template <std::floating_point S>
  [[nodiscard]] bool prefers(S candidate, S kept) const {
    return candidate <= kept;
  }
  /// A reading at most refresh_tolerance behind the kept one is the same surface seen again.
  template <std::floating_point S>
  [[nodiscard]] bool refreshes(S candidate, S kept) const {
    return candidate <= kept + static_cast<S>(refresh_tolerance);
  }
  /// Empty bins read the maximum range.
  template <std::floating_point S>
  [[nodiscard]] S dummy_range(S max_range) const {
    return max_range;
  }
};

/// Structure map (§4.3): keeps the farthest reading per bearing at any height, so objects that do
/// not span the whole area of interest are overwritten by the walls behind them; max-range
/// readings are ignored, as they would replace valid ones. As in the obstacle map, a reading at
/// most refresh_tolerance nearer than the stored one restarts its age.
struct StructureMapPolicy {
  /// m; 0: nothing refreshes.
  double refresh_tolerance{0.03};

  /// Readings below the maximum range, at any height.
  template <std::floating_point S>
  [[nodiscard]] bool admits(S range, S /*z*/, S max_range) const {
    return range < max_range;
  }
  /// The farther (or equally far) reading replaces the kept one.
  template <std::floating_point S>
  [[nodiscard]] bool prefers(S candidate, S kept) const {
    return candidate >= kept;
  }
  /// A reading at most refresh_tolerance nearer than the kept one is the same surface seen again.
  template <std::floating_point S>
  [[nodiscard]] bool refreshes(S candidate, S kept) const {
    return candidate >= kept - static_cast<S>(refresh_tolerance);
  }
  /// Empty bins read 0.
  template <std::floating_point S>
  [[nodiscard]] S dummy_range(S /*max_range*/) const {
    return S(0);
  }
};

static_assert(VirtualMapPolicy<ObstacleMapPolicy, double>);
static_assert(VirtualMapPolicy<StructureMapPolicy, float>);

/// Layout and ageing of a virtual map.
template <std::floating_point Scalar = double>
struct VirtualMapParams {
  /// The most bins a map may have (2^20: 1.2 arcseconds over a full turn).
  static constexpr std::size_t max_bins = std::size_t{1} << 20;

  /// Θ, rad, in (0, 2 pi]; the bins span [-Θ/2, Θ/2) around the robot's heading.
  Scalar aperture{2 * std::numbers::pi_v<Scalar>};
  /// Δθ, rad; N = round(Θ / Δθ) bins, each Θ / N wide (0.5 deg: 720 bins over 360 deg).
  Scalar resolution{std::numbers::pi_v<Scalar> / 360};
  /// m; readings at or beyond are ignored, and it is the obstacle map's dummy range.
  Scalar max_range{30};
  /// A point transformed more than this many times becomes a dummy (§4.4.2: 500, about 5 s with
  /// the pitching scanner's 75 Hz).
  std::uint32_t max_age{500};
  /// m; points nearer to the robot's origin than this are not removed by age. §4.4.2 removes old
  /// points because a static obstacle "will immediately be measured again" while it is still in
  /// the virtual corridor; that fails where the sensor cannot look: a pitching scanner does not
  /// see the floor nearer than pitching_blind_range() (egocentric/pitching_stream.hpp), a ToF
  /// camera tilted down has a similar blind zone. An obstacle the robot stopped in front of would
  /// otherwise be forgotten while the robot turns on the spot, and then hit. A point that leaves
  /// the blind zone is aged out at the next transformation if it is old enough. 0: the paper's
  /// rule.
  Scalar blind_range{0};

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where = "VirtualMapParams") const {
    detail::require_positive(where, "aperture", aperture);
    if (aperture > 2 * std::numbers::pi_v<Scalar> * (1 + 1e-9))
      detail::throw_invalid_argument(where, "aperture", aperture, "must be <= 2 pi");
    detail::require_positive(where, "resolution", resolution);
    if (resolution > aperture)
      detail::throw_invalid_argument(
          where, "resolution", resolution,
          "must not exceed the aperture " + detail::format_value(aperture));
    // Checked before the bin count is rounded and allocated: 1e-9 rad would ask for 6e9 bins.
    if (!(aperture / resolution <= static_cast<Scalar>(max_bins)))
      detail::throw_invalid_argument(where, "resolution", resolution,
                                     "gives more than " + std::to_string(max_bins) +
                                         " bins over the aperture " +
                                         detail::format_value(aperture));
    detail::require_positive(where, "max_range", max_range);
    detail::require_non_negative(where, "blind_range", blind_range);
  }
};

/// A planar sensor mounting: the sensor's pose in the robot frame and the height of its
/// measurement plane above the floor.
template <std::floating_point Scalar = double>
struct PlanarMount {
  Pose2<Scalar> pose{};  ///< the sensor's pose in the robot frame
  Scalar height{0};      ///< m, the measurement plane's height above the floor
};

/// What one call of the update procedure did.
struct VirtualMapUpdateStats {
  std::size_t moved{0};     ///< points carried over by the transformation (step 1)
  std::size_t merged{0};    ///< points lost to a bin collision or leaving the aperture (step 1)
  std::size_t aged_out{0};  ///< points removed by age (step 2)
  std::size_t replaced{0};  ///< bins written by new readings (step 3)
};

/// An egocentric virtual 2D map (paper 002 §4): one point per bearing bin around the robot,
/// kept by the Policy, moved with the robot and aged (see the file comment and docs/egocentric.md).
template <class Policy, std::floating_point Scalar = double>
requires VirtualMapPolicy<Policy, Scalar>
class VirtualMap {
 public:
  /// The coordinate type.
  using scalar_type = Scalar;
  /// A map point, Point<2, Scalar>.
  using point_type = Point<2, Scalar>;
  /// A bin's content.
  using bin_type = VirtualMapPoint<Scalar>;
  /// The policy.
  using policy_type = Policy;

  /// The policy's parameters may be changed between updates (e.g. the virtual corridor adapted to
  /// the robot's velocity).
  Policy policy{};

  /// A map with this layout and policy, every bin a dummy; throws invalid_argument for an
  /// invalid layout.
  explicit VirtualMap(const VirtualMapParams<Scalar>& params = {}, Policy map_policy = {})
      : policy(std::move(map_policy)), params_(params) {
    params_.validate("VirtualMap");
    const auto n = static_cast<std::size_t>(std::llround(params_.aperture / params_.resolution));
    bin_count_ = std::max<std::size_t>(n, 1);
    resolution_ = params_.aperture / static_cast<Scalar>(bin_count_);
    inv_resolution_ = Scalar(1) / resolution_;
    bin_count_f_ = static_cast<Scalar>(bin_count_);
    angle_min_ = -params_.aperture / 2;
    full_circle_ = std::abs(params_.aperture - 2 * std::numbers::pi_v<Scalar>) < resolution_ / 2;
    bins_.resize(bin_count_ + 1);  // + the sink bin of branch-free selection (select_bin)
    scratch_.resize(bin_count_ + 1);
    valid_points_.reserve(bin_count_);
    valid_indices_.reserve(bin_count_);
    clear();
  }

  /// The layout and ageing parameters.
  [[nodiscard]] const VirtualMapParams<Scalar>& params() const { return params_; }
  /// N, the number of bins.
  [[nodiscard]] std::size_t size() const { return bin_count_; }
  /// Θ / N, the width of a bin (rad).
  [[nodiscard]] Scalar resolution() const { return resolution_; }
  /// The first bin's lower bearing (rad).
  [[nodiscard]] Scalar angle_min() const { return angle_min_; }
  /// Readings at or beyond are ignored (m).
  [[nodiscard]] Scalar max_range() const { return params_.max_range; }
  /// Transformations after which a point ages out.
  [[nodiscard]] std::uint32_t max_age() const { return params_.max_age; }
  /// The dummy range of this map's policy.
  [[nodiscard]] Scalar dummy_range() const { return policy.dummy_range(params_.max_range); }

  /// Changes the age threshold of §4.4.2 (takes effect at the next transformation).
  void set_max_age(std::uint32_t max_age) { params_.max_age = max_age; }

  /// Every bin, in bearing order.
  [[nodiscard]] std::span<const bin_type> bins() const { return {bins_.data(), bin_count_}; }
  /// Bin i.
  [[nodiscard]] const bin_type& bin(std::size_t i) const { return bins_[i]; }
  /// Bearing of the centre of bin i.
  [[nodiscard]] Scalar bin_bearing(std::size_t i) const {
    return angle_min_ + (static_cast<Scalar>(i) + Scalar(0.5)) * resolution_;
  }
  /// The bin of a bearing, or size() when the bearing lies outside the aperture.
  [[nodiscard]] std::size_t bin_index(Scalar bearing) const {
    const Scalar f = (normalize_angle(bearing) - angle_min_) * inv_resolution_;
    return index_of(f);
  }

  /// Non-dummy points, in bin order (the PointCloud view).
  [[nodiscard]] const std::vector<point_type>& valid_points() const { return valid_points_; }
  /// Bins holding a non-dummy point, increasing.
  [[nodiscard]] const std::vector<std::uint32_t>& valid_indices() const { return valid_indices_; }
  /// Number of non-dummy bins.
  [[nodiscard]] std::size_t valid_count() const { return valid_indices_.size(); }

  /// Fills every bin with a dummy point.
  void clear() {
    const Scalar d = dummy_range();
    for (std::size_t i = 0; i < bin_count_; ++i) {
      const Scalar b = bin_bearing(i);
      bins_[i] = bin_type{d * std::cos(b), d * std::sin(b), Scalar(0), d, b, 0, true};
    }
    dummies_ = bins_;
    scratch_ = bins_;  // the scratch buffer holds only dummies between updates (transform_bins)
    refresh();
  }

  /// Steps 1 and 2 of §4.4: the robot moved by `motion` (its new pose in its previous frame, e.g.
  /// relative(previous_odometry, odometry)); every stored point p becomes motion^-1 * p, which is
  /// Eq. (4) with Δθ = -motion.theta and (Δx, Δy) = -R(Δθ) (motion.x, motion.y). Points whose
  /// count of transformations exceeds max_age become dummies. Nothing happens when the motion is
  /// exactly zero (the robot did not move).
  /// Throws invalid_argument for a non-finite motion (it would turn every point into NaN).
  VirtualMapUpdateStats transform(const Pose2<Scalar>& motion) {
    require_finite_motion(motion, "VirtualMap::transform");
    VirtualMapUpdateStats stats = transform_bins(motion);
    refresh();
    return stats;
  }

  /// Step 3 of §4.4 for 3D readings in the robot frame (x, y, and z = height above the floor):
  /// each reading admitted by the policy replaces the point in its bin when the policy prefers it.
  /// Non-finite points are skipped. Returns the number of bins written.
  template <PointCloudOf<3> C>
  std::size_t insert(const C& readings) {
    const std::size_t written = insert_bins(readings);
    refresh();
    return written;
  }

  /// Step 3 of §4.4 for a 2D scan from a planar sensor mounted at `mount` (its valid readings
  /// only; the scan's range_max and the map's max_range both limit them). Throws
  /// invalid_argument for a non-finite mounting.
  std::size_t insert(const LaserScan<Scalar>& scan, const PlanarMount<Scalar>& mount = {}) {
    require_finite_mount(mount, "VirtualMap::insert");
    const std::size_t written = insert_bins(scan, mount);
    refresh();
    return written;
  }

  /// The whole procedure of §4.4: transform by `motion` (skipped when zero), age out, insert.
  /// Throws invalid_argument as transform() and insert() do.
  template <class Readings>
  VirtualMapUpdateStats update(const Pose2<Scalar>& motion, const Readings& readings) {
    require_finite_motion(motion, "VirtualMap::update");
    VirtualMapUpdateStats stats = transform_bins(motion);
    stats.replaced = insert_bins(readings);
    refresh();
    return stats;
  }
  /// As update(motion, readings) for a planar scan from a sensor mounted at `mount`.
  VirtualMapUpdateStats update(const Pose2<Scalar>& motion, const LaserScan<Scalar>& scan,
                               const PlanarMount<Scalar>& mount) {
    require_finite_motion(motion, "VirtualMap::update");
    require_finite_mount(mount, "VirtualMap::update");
    VirtualMapUpdateStats stats = transform_bins(motion);
    stats.replaced = insert_bins(scan, mount);
    refresh();
    return stats;
  }

  /// The map as a laser scan with one beam per bin at the bin's centre bearing; dummy bins carry
  /// the dummy range (max range or 0), which the scan flags invalid. A stored point's bearing is
  /// rounded to its bin centre (at most Δθ/2); use bins() for the exact coordinates.
  [[nodiscard]] LaserScan<Scalar> to_laser_scan(double timestamp = 0.0) const {
    std::vector<Scalar> ranges(bin_count_);
    for (std::size_t i = 0; i < bin_count_; ++i)
      ranges[i] = bins_[i].range;
    ScanGeometry<Scalar> g{angle_min_ + resolution_ / 2, resolution_, bin_count_, Scalar(0),
                           params_.max_range};
    return LaserScan<Scalar>(g, std::move(ranges), {}, timestamp);
  }

 private:
  static void require_finite_motion(const Pose2<Scalar>& motion, std::string_view where) {
    detail::require_finite(where, "motion.x", motion.x);
    detail::require_finite(where, "motion.y", motion.y);
    detail::require_finite(where, "motion.theta", motion.theta);
  }
  static void require_finite_mount(const PlanarMount<Scalar>& mount, std::string_view where) {
    detail::require_finite(where, "mount.pose.x", mount.pose.x);
    detail::require_finite(where, "mount.pose.y", mount.pose.y);
    detail::require_finite(where, "mount.pose.theta", mount.pose.theta);
    detail::require_finite(where, "mount.height", mount.height);
  }

  VirtualMapUpdateStats transform_bins(const Pose2<Scalar>& motion) {
    VirtualMapUpdateStats stats;
    if (motion.x == Scalar(0) && motion.y == Scalar(0) && motion.theta == Scalar(0)) return stats;
    const Scalar dtheta = normalize_angle(-motion.theta);  // once per update
    const Scalar c = std::cos(dtheta), s = std::sin(dtheta);
    const Scalar tx = -(c * motion.x - s * motion.y), ty = -(s * motion.x + c * motion.y);
    const Scalar max_range = params_.max_range;
    const std::uint32_t max_age = params_.max_age;
    const Scalar blind_range = params_.blind_range;
    std::size_t moved = 0, merged = 0;
    for (const std::uint32_t i : valid_indices_) {
      const bin_type& b = bins_[i];
      // Would exceed max_age with this transformation (step 2), unless the sensor cannot see it.
      if (b.age >= max_age && !(b.range < blind_range)) {
        ++stats.aged_out;
        continue;
      }
      // Eq. (4), with the polar coordinates carried along (§4.4.1).
      const Scalar qx = c * b.x - s * b.y, qy = s * b.x + c * b.y;
      const Scalar x = qx + tx, y = qy + ty;
      const Scalar range = std::sqrt(x * x + y * y);
      // b.bearing + dtheta lies in (-2 pi, 2 pi]; shifted_bearing's single wrap normalises it.
      const Scalar bearing =
          detail::shifted_bearing_small_shift(qx, qy, b.range, b.bearing + dtheta, tx, ty);
      const std::size_t k = index_of((bearing - angle_min_) * inv_resolution_);
      if (k == bin_count_ || !policy.admits(range, b.z, max_range)) {
        ++stats.merged;
        continue;
      }
      // A branch, not the sink selection of place(): most destinations are still empty (in the
      // benchmark about 380 of 440 points; a collision goes either way), so it is predicted
      // well, and the store's address is then known without waiting for the comparison, which
      // the next point's load of its destination would otherwise have to wait for.
      const bin_type& dst = scratch_[k];
      const bool empty = dst.dummy;
      const bool take = empty | static_cast<bool>(policy.prefers(range, dst.range));
      moved += static_cast<std::size_t>(empty);
      merged += static_cast<std::size_t>(!empty);
      if (take)
        scratch_[k] =
            bin_type{x,
                     y,
                     b.z,
                     range,
                     bearing,
                     b.age < max_age ? b.age + 1 : max_age,  // no overflow in the blind zone
                     false};
    }
    stats.moved = moved;
    stats.merged += merged;
    // Only the bins just read hold points: resetting them (about 410 of 720 in the benchmark)
    // leaves an all-dummy buffer for the next update, instead of a block copy of all N bins.
    for (const std::uint32_t i : valid_indices_)
      bins_[i] = dummies_[i];
    std::swap(bins_, scratch_);
    return stats;
  }

  template <PointCloudOf<3> C>
  std::size_t insert_bins(const C& readings) {
    const std::size_t n = traits::size(readings);
    std::size_t written = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const Point<3, Scalar> p = traits::point(readings, i).template cast<Scalar>();
      written += insert_one(p.x(), p.y(), p.z());
    }
    return written;
  }

  /// In two passes: the first computes every admitted reading's coordinates and bin into
  /// staged_, the second resolves the bins. Which reading a bin keeps is data-dependent, so
  /// place() selects its store address from the loaded bin (no branch to mispredict); fused with
  /// the bearing computation, that made each beam's bin load wait for the previous beam's long
  /// chain (Eq. 4, a division, the bearing series, the bin index); staged, the chains of all
  /// beams overlap and the second pass only loads, compares and stores (about 6 % faster).
  std::size_t insert_bins(const LaserScan<Scalar>& scan, const PlanarMount<Scalar>& mount = {}) {
    const Pose2<Scalar>& m = mount.pose;
    const Scalar c = std::cos(m.theta), s = std::sin(m.theta);
    const Scalar max_range = params_.max_range;
    // Grows only for a scan with more valid beams than any before.
    if (staged_.size() < scan.valid_indices().size()) staged_.resize(scan.valid_indices().size());
    std::size_t n = 0;
    for (const std::uint32_t i : scan.valid_indices()) {
      const point_type& p = scan.point(i);
      const Scalar qx = c * p.x() - s * p.y(), qy = s * p.x() + c * p.y();
      const Scalar x = qx + m.x, y = qy + m.y;
      const Scalar range = std::sqrt(x * x + y * y);
      if (!(range > Scalar(0)) || !policy.admits(range, mount.height, max_range)) continue;
      // The scan's bearings are known: shift them by the mounting instead of an atan2 per beam.
      const Scalar bearing = detail::shifted_bearing(
          qx, qy, scan.range(i), normalize_rotated(scan.angle(i) + m.theta), m.x, m.y);
      const std::size_t k = index_of((bearing - angle_min_) * inv_resolution_);
      staged_[n] = StagedReading{x, y, range, bearing, k};
      n += static_cast<std::size_t>(k != bin_count_);  // outside the aperture: overwritten
    }
    std::size_t written = 0;
    for (std::size_t j = 0; j < n; ++j) {
      const StagedReading& r = staged_[j];
      written += place_in(r.bin, r.x, r.y, mount.height, r.range, r.bearing);
    }
    return written;
  }

  static Scalar normalize_rotated(Scalar a) {
    constexpr Scalar pi = std::numbers::pi_v<Scalar>;
    if (a > pi) return a - 2 * pi;
    if (a <= -pi) return a + 2 * pi;
    return a;
  }

  /// The bin of f = (bearing - angle_min) / (Θ / N), or size() outside the aperture. Bins are
  /// half-open, [k, k + 1) in f, and a full circle wraps at ±pi (f = N is bin 0). A bearing on a
  /// bin border (a scan whose beams start at -pi with increment Δθ, a rotation by a multiple of
  /// Δθ) arrives here as k ± a few ulps; the border tolerance (in bins, far below any sensor's
  /// angular noise) sends it to bin k every time, so such a scan fills each bin exactly once.
  std::size_t index_of(Scalar f) const {
    f += border_tolerance_;
    if (!(f >= Scalar(0))) {  // below the aperture, or NaN
      if (!full_circle_ || !(f > -bin_count_f_)) return bin_count_;
      f += bin_count_f_;
    } else if (f >= bin_count_f_) {
      if (!full_circle_ || !(f < 2 * bin_count_f_)) return bin_count_;
      f -= bin_count_f_;
    }
    const auto k = static_cast<std::size_t>(f);
    return k < bin_count_ ? k : (full_circle_ ? 0 : bin_count_);  // f + N rounded up to N
  }

  /// k when `take`, else the sink bin, without a branch: which of two readings a policy keeps is
  /// data-dependent (a re-observation is nearer about half the time), so a branch on it is
  /// mispredicted about every other reading.
  std::size_t select_bin(bool take, std::size_t k) const {
    const std::size_t mask = std::size_t(0) - static_cast<std::size_t>(take);
    return bin_count_ ^ ((k ^ bin_count_) & mask);
  }

  std::size_t insert_one(Scalar x, Scalar y, Scalar z) {
    if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(z))) return 0;
    const Scalar r = std::sqrt(x * x + y * y);
    if (!(r > Scalar(0)) || !policy.admits(r, z, params_.max_range)) return 0;
    return place(x, y, z, r, detail::fast_atan2(y, x));
  }

  std::size_t place(Scalar x, Scalar y, Scalar z, Scalar r, Scalar bearing) {
    const std::size_t k = index_of((bearing - angle_min_) * inv_resolution_);
    if (k == bin_count_) return 0;
    return place_in(k, x, y, z, r, bearing);
  }

  /// place() for a known bin k < size().
  std::size_t place_in(std::size_t k, Scalar x, Scalar y, Scalar z, Scalar r, Scalar bearing) {
    bin_type& dst = bins_[k];
    // Whether the new reading wins is data-dependent (a re-observation is nearer about half the
    // time): select the destination instead of branching, a losing reading goes to the sink.
    const bool take = dst.dummy | static_cast<bool>(policy.prefers(r, dst.range));
    const bool seen_again = static_cast<bool>(detail::policy_refreshes(policy, r, dst.range));
    bins_[select_bin(take, k)] = bin_type{x, y, z, r, bearing, 0, false};
    // A re-observation restarts the age (§4.4.2); the mask keeps this free of branches too.
    dst.age &= std::uint32_t(0) - static_cast<std::uint32_t>(!(take | seen_again));
    return static_cast<std::size_t>(take);
  }

  void refresh() {  // within the reserved capacity: no allocation
    valid_points_.resize(bin_count_);
    valid_indices_.resize(bin_count_);
    std::size_t n = 0;
    for (std::size_t i = 0; i < bin_count_; ++i) {
      const bin_type& b = bins_[i];
      valid_indices_[n] = static_cast<std::uint32_t>(i);
      valid_points_[n] = point_type(b.x, b.y);
      n += b.dummy ? 0 : 1;
    }
    valid_points_.resize(n);
    valid_indices_.resize(n);
  }

  VirtualMapParams<Scalar> params_;
  std::size_t bin_count_{0};
  Scalar resolution_{0}, inv_resolution_{0}, angle_min_{0}, bin_count_f_{0};
  /// In bins: sqrt(machine epsilon), 1.5e-8 bins (1.3e-10 rad at 0.5 deg) in double, 3.5e-4 in
  /// float; bearings computed on a border are off by far less, real readings never matter at
  /// this scale.
  static constexpr Scalar border_tolerance_ =
      std::same_as<Scalar, float> ? Scalar(3.5e-4) : Scalar(1.5e-8);
  bool full_circle_{false};
  // bin_count_ + 1 entries each: the last one, the sink, receives the writes a policy rejects.
  std::vector<bin_type> bins_, scratch_, dummies_;
  /// A reading of a 2D scan between the two passes of insert_bins(scan, mount).
  struct StagedReading {
    Scalar x, y, range, bearing;
    std::size_t bin;
  };
  std::vector<StagedReading> staged_;
  std::vector<point_type> valid_points_;
  std::vector<std::uint32_t> valid_indices_;
};

/// The obstacle map of §4.2 (the nearest reading per bearing in the robot's height band).
template <std::floating_point Scalar = double>
using ObstacleMap = VirtualMap<ObstacleMapPolicy, Scalar>;
/// The structure map of §4.3 (the farthest reading per bearing).
template <std::floating_point Scalar = double>
using StructureMap = VirtualMap<StructureMapPolicy, Scalar>;

namespace traits {
/// A virtual map is a 2D PointCloud of its non-dummy points.
template <class P, class S>
struct cloud_access<VirtualMap<P, S>> {
  /// A virtual map is two-dimensional.
  static constexpr int dimension = 2;
  /// The coordinate type.
  using Scalar = S;
  /// Number of non-dummy points.
  static std::size_t size(const VirtualMap<P, S>& m) { return m.valid_count(); }
  /// The i-th non-dummy point (robot frame).
  static const Point<2, S>& point(const VirtualMap<P, S>& m, std::size_t i) {
    return m.valid_points()[i];
  }
};
}  // namespace traits

}  // namespace rangenav
