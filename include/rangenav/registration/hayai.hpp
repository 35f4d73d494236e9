#pragma once
// HAYAI ("Highspeed And Yet Accurate Indoor/outdoor-tracking"): feature-based pose tracking of a
// robot from consecutive ordered 2D laser scans, after §3 of paper 003 (Lingemann, Nüchter,
// Hertzberg, Surmann, ECMR 2005).
//
// The scheme of §3, per scan:
//   1. detect features in the reference scan R (model set M) and in the current scan S (data D):
//      extrema of the polar range signal r(i), found with the linear filters Ψ1 (sharpen),
//      Ψ2 (gradient) and Ψ3 (soften) and classified as maximum, minimum or inflection point;
//      they lie at corners and jump edges in Cartesian space;
//   2. match them with the matrix of Eq. (4) (weighted polar + Cartesian distance, type inhibition
//      Θ), simplified until the matching is unique;
//   3. compute the pose shift Δp mapping the matched D onto M in closed form (Eq. 5-6);
//   4. update the pose with Eq. (3); optionally fuse Δp with odometry in a small EKF (Fig. 5);
//   5. keep S as the new reference scan.
//
// What the paper leaves open, and what is chosen here (all in HayaiParams):
//   - candidates: the beams where the softened gradient turns fastest (Ψ2 applied once more);
//   - the significance of an extremum: a candidate must be a real corner, i.e. the beams on its
//     left and on its right must each lie on a straight line (total least squares, RMS below
//     max_line_rms) and the two lines must meet at min_corner_angle or more, by more than
//     corner_significance standard deviations of their directions. This rejects the smooth
//     minimum of a wall (its foot point moves with the robot: not a landmark) and the random
//     turns of short noisy fits, so a featureless corridor yields no features instead of a wrong
//     pose. The corner is then placed at the lines' intersection, which is exact on noise-free
//     polygonal scenes;
//   - jump edges: the near (occluding) end point of a range jump is a minimum of the sharpened
//     signal and is a feature, placed half a beam towards the jump; the far (shadow) end point
//     moves with the viewpoint and is used only when use_shadow_edges is set. Invalid beams split
//     the signal and are never features; a scan covering a full turn is read as a ring;
//   - every feature carries a σ (line-fit noise for corners, beam spacing for jump edges) that
//     weights its pair in E(R, t) of §3.2 and gives the pose covariance;
//   - the weights ω1, ω2, ω3 of Eq. (4) and the gate on it (the paper gives no values);
//   - "simplified until unique": the candidate pairs are taken greedily by increasing Eq. (4)
//     distance (one partner per feature), then, for scans that do not cover a full turn, only the
//     longest run of pairs whose order is the same in both scans is kept (the features' order
//     cannot change fundamentally between consecutive scans); pairs whose residual after Eq. (5-6)
//     exceeds max_pair_residual are dropped one by one and the pose is solved again;
//   - two pairs suffice for a pose (a corridor often shows only two door frames), but nothing
//     checks them: such a pose must agree with the prediction (odometry or constant velocity)
//     within gates, else it is reported as `unconfirmed`;
//   - the tracker (not in the paper): it predicts with the odometry increment (constant velocity
//     without it), retries turned hypotheses when that matches too few features, and falls back
//     on the prediction through scans it cannot register; with odometry it fuses the two
//     increments in an EKF (HayaiOdometryNoise) and, where they disagree, keeps HAYAI's only when
//     redundant pairs checked it.
//
// Thread safety: the free functions are reentrant; a HayaiFeatureExtractor, HayaiMatcher or
// HayaiTracker object must not be used by two threads at once (each keeps scratch buffers, so the
// per-scan work allocates nothing once the buffers have grown).

#include <Eigen/Core>
#include <Eigen/LU>
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

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/pca.hpp"
#include "rangenav/scan/laser_scan.hpp"

namespace rangenav {

/// The classification function Γ of §3.1: the kind of extremum of the polar signal.
enum class HayaiFeatureType : std::uint8_t {
  maximum,    ///< the range peaks: a concave corner, or the far (shadow) side of a jump edge
  minimum,    ///< the range dips: a convex corner, or the near (occluding) side of a jump edge
  inflection  ///< the range keeps rising or falling through the corner: a corner seen obliquely
};

/// The enumerator's name: "maximum", "minimum" or "inflection".
[[nodiscard]] constexpr std::string_view to_string(HayaiFeatureType type) {
  switch (type) {
    case HayaiFeatureType::maximum:
      return "maximum";
    case HayaiFeatureType::minimum:
      return "minimum";
    case HayaiFeatureType::inflection:
      return "inflection";
  }
  return "unknown";
}

/// A feature of one scan, in the scan's frame, in Cartesian and polar form (Eq. 4 uses both).
template <std::floating_point Scalar = double>
struct HayaiFeature {
  Point<2, Scalar> position{Point<2, Scalar>::Zero()};  ///< (x, y) in the scan frame (m)
  Scalar bearing{0};                                    ///< φ of position (rad)
  Scalar range{0};                                      ///< r of position (m)
  HayaiFeatureType type{HayaiFeatureType::maximum};     ///< Γ(feature)
  std::uint32_t beam{0};                                ///< index of the beam it was found at
  bool jump_edge{false};  ///< found at a range jump (not refined to a line intersection)
  Scalar sigma{0};        ///< standard deviation of `position` (m), weights the pose (Eq. 5-6)
};

/// Parameters of HAYAI. The filters are the paper's; the thresholds and weights, which the paper
/// does not give, are chosen for SICK-class scanners (σ ≈ 1 cm, 0.5°-1° resolution) indoors.
template <std::floating_point Scalar = double>
struct HayaiParams {
  /// Ψ1 = [-1, 4, -1]: sharpen filter (§3.1). Fixed by the paper; documented here.
  static constexpr std::array<Scalar, 3> sharpen{Scalar(-1), Scalar(4), Scalar(-1)};
  /// Ψ2 = [-1/2, 0, 1/2]: gradient filter (§3.1).
  static constexpr std::array<Scalar, 3> gradient{Scalar(-0.5), Scalar(0), Scalar(0.5)};
  /// Ψ3 = [1, 1, 1]: soften filter (§3.1).
  static constexpr std::array<Scalar, 3> soften{Scalar(1), Scalar(1), Scalar(1)};

  // ---- feature extraction ----
  /// A beam is a corner candidate when the curvature of the filtered polar signal (Ψ2 applied to
  /// the softened gradient) exceeds this many times r·Δφ (the beam spacing at that range). A 90°
  /// corner seen head-on scores about 5, a 25° bend about 1.
  Scalar corner_response_min{Scalar(0.8)};
  /// Beams fitted on each side of a corner candidate (after skipping one beam next to it).
  std::size_t line_fit_beams{5};
  /// Largest RMS distance of those beams from their fitted line (m).
  Scalar max_line_rms{Scalar(0.02)};
  /// Smallest angle between the two fitted lines for a corner (rad).
  Scalar min_corner_angle{deg_to_rad(Scalar(30))};
  /// ... and the sine of that angle must exceed this many standard deviations of the lines'
  /// directions (short, noisy fits near the scanner turn at random).
  Scalar corner_significance{Scalar(3)};
  /// Largest distance between the corner candidate's beam point and the lines' intersection (m).
  Scalar max_corner_shift{Scalar(0.3)};
  /// Place corners at the lines' intersection (true) or at the candidate's beam point (false, as
  /// in the paper).
  bool refine_corners{true};
  /// A range jump between neighbouring valid beams is a jump edge when it exceeds
  /// jump_distance_min + jump_distance_ratio · (nearer range) (m, -).
  Scalar jump_distance_min{Scalar(0.15)};
  Scalar jump_distance_ratio{Scalar(0.1)};  ///< the range-proportional part of that threshold (-)
  /// ... and when it exceeds this many times the range steps next to it (a wall seen at a
  /// grazing angle has large but smoothly growing steps, a jump edge stands out).
  Scalar jump_smoothness_ratio{Scalar(3)};
  /// Fewest consecutive valid beams on the near side of a jump edge (rejects mixed pixels, noise).
  std::size_t min_segment_beams{3};
  /// Also use the far (shadow) side of jump edges as features (moves with the viewpoint).
  bool use_shadow_edges{false};
  /// Features located worse than this σ are dropped (m): the end of a wall seen at a grazing
  /// angle, where the beams lie far apart, slides along the wall from scan to scan.
  Scalar max_feature_sigma{Scalar(0.1)};

  // ---- matching, Eq. (4) ----
  /// ω1: weight of the bearing difference (m/rad), inside the polar root.
  Scalar omega_bearing{Scalar(1)};
  /// ω2: weight of the squared range difference (-), inside the polar root.
  Scalar omega_range{Scalar(1)};
  /// ω3: weight of the Cartesian distance (-).
  Scalar omega_cartesian{Scalar(1)};
  /// Pairs whose Eq. (4) distance exceeds this are not candidates (m). Measured after the
  /// prediction (odometry) has been applied to the data features.
  Scalar max_match_distance{Scalar(0.6)};
  /// Keep only pairs whose order agrees in both scans (scans narrower than a full turn).
  bool enforce_order{true};
  /// Pairs farther apart than this after the closed-form pose are dropped, and the pose is solved
  /// again (m).
  Scalar max_pair_residual{Scalar(0.1)};
  /// Fewest matched features for a pose (two determine it).
  std::size_t min_matched_features{2};
  /// A pose resting on fewer pairs than this has no redundant pair to check it (two pairs fit
  /// any rigid motion that keeps their distance): it is accepted only when it lies within
  /// unverified_rotation_gate and unverified_translation_gate (plus three standard deviations
  /// of its own translation) of the prediction (odometry, or the tracker's constant-velocity
  /// motion), and reported as `unconfirmed` otherwise. A feature-poor scene (a corridor with
  /// two door frames in view) needs such poses.
  std::size_t verified_matches{3};
  Scalar unverified_translation_gate{Scalar(0.05)};        ///< (m)
  Scalar unverified_rotation_gate{deg_to_rad(Scalar(2))};  ///< (rad)
  /// When the tracker's prediction (odometry, or constant velocity without it) matches too few
  /// features, it retries with the predicted heading turned by ±step, ±2·step, ... up to ±max
  /// (rad; 0 disables) and keeps the verified pose with the most pairs: for turns faster than
  /// predicted, and odometry that misses part of a turn (not in the paper, whose 75 Hz scans turn
  /// little between scans).
  Scalar recovery_rotation_max{deg_to_rad(Scalar(12))};
  /// The step of those retries (rad); 0, or a step larger than recovery_rotation_max, disables
  /// them.
  Scalar recovery_rotation_step{deg_to_rad(Scalar(3))};
  /// Without odometry, a scan HAYAI cannot register moves the pose by the constant-velocity
  /// prediction (the failure is still reported); false keeps the pose instead.
  bool coast_on_failure{true};
  /// Range noise of the scanner (m): the smallest σ of a feature's position, which weights the
  /// pairs in Eq. (5-6) and scales the pose covariance.
  Scalar min_feature_sigma{Scalar(0.01)};

  /// Throws invalid_argument naming the first violated contract.
  void validate(std::string_view where = "HayaiParams") const {
    detail::require_non_negative(where, "corner_response_min", corner_response_min);
    if (line_fit_beams < 2)
      detail::throw_invalid_argument(where, "line_fit_beams", line_fit_beams, "must be >= 2");
    detail::require_positive(where, "max_line_rms", max_line_rms);
    if (!(std::isfinite(min_corner_angle) && min_corner_angle > 0 &&
          min_corner_angle <= std::numbers::pi_v<Scalar> / 2))
      detail::throw_invalid_argument(where, "min_corner_angle", min_corner_angle,
                                     "must be in (0, pi/2]");
    detail::require_non_negative(where, "corner_significance", corner_significance);
    detail::require_positive(where, "max_corner_shift", max_corner_shift);
    detail::require_positive(where, "jump_distance_min", jump_distance_min);
    detail::require_non_negative(where, "jump_distance_ratio", jump_distance_ratio);
    detail::require_non_negative(where, "jump_smoothness_ratio", jump_smoothness_ratio);
    if (min_segment_beams < 1)
      detail::throw_invalid_argument(where, "min_segment_beams", min_segment_beams, "must be >= 1");
    detail::require_non_negative(where, "omega_bearing", omega_bearing);
    detail::require_non_negative(where, "omega_range", omega_range);
    detail::require_non_negative(where, "omega_cartesian", omega_cartesian);
    if (!(omega_bearing > 0 || omega_range > 0 || omega_cartesian > 0))
      detail::throw_invalid(where, "at least one of the weights omega_* must be > 0");
    detail::require_positive(where, "max_match_distance", max_match_distance);
    detail::require_positive(where, "max_pair_residual", max_pair_residual);
    if (min_matched_features < 2)
      detail::throw_invalid_argument(where, "min_matched_features", min_matched_features,
                                     "must be >= 2");
    detail::require_non_negative(where, "unverified_translation_gate", unverified_translation_gate);
    detail::require_non_negative(where, "unverified_rotation_gate", unverified_rotation_gate);
    detail::require_positive(where, "min_feature_sigma", min_feature_sigma);
    detail::require_positive(where, "max_feature_sigma", max_feature_sigma);
    detail::require_non_negative(where, "recovery_rotation_max", recovery_rotation_max);
    detail::require_non_negative(where, "recovery_rotation_step", recovery_rotation_step);
  }
};

/// Why a registration produced no pose. A failure never comes with a pose to be trusted.
enum class HayaiStatus : std::uint8_t {
  success,          ///< Δp computed from enough uniquely matched features
  featureless,      ///< the reference or the current scan has fewer features than needed
  too_few_matches,  ///< fewer than min_matched_features pairs survived matching and checks
  degenerate,       ///< the matched features are (nearly) coincident: rotation undetermined
  unconfirmed  ///< fewer than verified_matches pairs, and their pose disagrees with the prediction
};

/// The enumerator's name, e.g. "success" or "too_few_matches".
[[nodiscard]] constexpr std::string_view to_string(HayaiStatus status) {
  switch (status) {
    case HayaiStatus::success:
      return "success";
    case HayaiStatus::featureless:
      return "featureless";
    case HayaiStatus::too_few_matches:
      return "too_few_matches";
    case HayaiStatus::degenerate:
      return "degenerate";
    case HayaiStatus::unconfirmed:
      return "unconfirmed";
  }
  return "unknown";
}

/// One unique correspondence: model feature `model` (reference scan) ↔ data feature `data`
/// (current scan), with its Eq. (4) distance.
template <std::floating_point Scalar = double>
struct HayaiPair {
  std::uint32_t model{0};  ///< index of the feature in the model (reference scan) feature list
  std::uint32_t data{0};   ///< index of the feature in the data (current scan) feature list
  Scalar distance{0};      ///< Eq. (4) distance (m), the data feature moved by the prediction
};

/// The outcome of registering a scan against a reference scan.
template <std::floating_point Scalar = double>
struct HayaiMatchResult {
  HayaiStatus status{HayaiStatus::featureless};  ///< success, or why there is no pose
  /// Δp: the current scan's pose in the reference scan's frame (maps data onto model, Eq. 5-6).
  /// Identity unless status == success.
  Pose2<Scalar> shift{};
  /// Covariance of (Δx, Δy, Δθ) from the residuals (zero unless status == success).
  Eigen::Matrix<Scalar, 3, 3> covariance{Eigen::Matrix<Scalar, 3, 3>::Zero()};
  std::size_t model_features{0};  ///< |M|
  std::size_t data_features{0};   ///< |D|
  std::size_t matched{0};         ///< pairs used for the pose
  Scalar rms_residual{0};         ///< RMS of ‖m_i − (R d_i + t)‖ over the used pairs (m)

  /// True when status == success: `shift` and `covariance` hold the registration.
  [[nodiscard]] bool ok() const { return status == HayaiStatus::success; }
};

namespace detail {

/// Total-least-squares line through points[first, first + count): centroid, unit direction and
/// RMS orthogonal distance.
template <class Scalar>
struct HayaiLine {
  Point<2, Scalar> centroid;
  Point<2, Scalar> direction;
  Scalar rms;     ///< RMS distance of the points from the line
  Scalar spread;  ///< standard deviation of the points along the line
};

template <class Scalar>
HayaiLine<Scalar> fit_hayai_line(std::span<const Point<2, Scalar>> points, std::size_t first,
                                 std::size_t count) {
  const PcaFit<2, Scalar> fit = fit_pca<2, Scalar>(points.subspan(first, count));
  return {fit.mean, fit.principal_direction(), fit.normal_rms(),
          std::sqrt(std::max(fit.eigenvalues(1), Scalar(0)))};
}

}  // namespace detail

/// Whether a scan's beams cover a full turn (its features' order is then cyclic).
template <std::floating_point Scalar>
[[nodiscard]] bool covers_full_turn(const LaserScan<Scalar>& scan) {
  return static_cast<Scalar>(scan.size()) * scan.angle_increment() >=
         2 * std::numbers::pi_v<Scalar> - scan.angle_increment() / 2;
}

/// Finds the features of §3.1 in ordered scans. Keeps its buffers between calls.
template <std::floating_point Scalar = double>
class HayaiFeatureExtractor {
 public:
  using feature_type = HayaiFeature<Scalar>;  ///< a feature found

  /// Throws invalid_argument for invalid `params` (see HayaiParams::validate).
  explicit HayaiFeatureExtractor(const HayaiParams<Scalar>& params = {}) : params_(params) {
    params_.validate("HayaiFeatureExtractor");
  }

  /// The parameters.
  [[nodiscard]] const HayaiParams<Scalar>& params() const { return params_; }

  /// Replaces `features` by the features of `scan`, in beam order. Invalid beams split the polar
  /// signal into segments and never become features. The first and last beam are ends of the
  /// signal, unless the scan covers a full turn: its signal is then read as a ring.
  void extract(const LaserScan<Scalar>& scan, std::vector<feature_type>& features) {
    features.clear();
    const std::size_t n = scan.size();
    if (n < 3) return;
    full_turn_ = covers_full_turn(scan);
    dphi_ = scan.angle_increment();
    load_signal(scan);
    const std::size_t m = r_.size();
    // Segments: runs of valid beams without a jump edge between neighbours.
    segments_.clear();
    for (std::size_t i = 0; i < m;) {
      if (!valid_[i]) {
        ++i;
        continue;
      }
      const std::size_t begin = i;
      while (i + 1 < m && valid_[i + 1] && !is_jump(i))
        ++i;
      segments_.push_back({begin, ++i});
    }
    // A full turn that starts at a jump edge: the jump joins the last segment to the first.
    const bool jump_at_seam = full_turn_ && pad_ == 0 && segments_.size() > 1 &&
                              segments_.front().first == 0 && segments_.back().second == m;
    for (std::size_t k = 0; k < segments_.size(); ++k) {
      const auto [begin, end] = segments_[k];
      const bool jump_before = k > 0 ? segments_[k - 1].second == begin : jump_at_seam;
      const bool jump_after =
          k + 1 < segments_.size() ? segments_[k + 1].first == end : jump_at_seam;
      if (jump_before) add_jump_end(begin, begin == 0 ? m - 1 : begin - 1, begin, end, features);
      find_corners(begin, end, features);
      if (jump_after && end - 1 != begin)
        add_jump_end(end - 1, end == m ? 0 : end, begin, end, features);
    }
    // A ring was read from a rotated start: restore beam order.
    const auto wrap = std::is_sorted_until(
        features.begin(), features.end(),
        [](const feature_type& a, const feature_type& b) { return a.beam < b.beam; });
    std::rotate(features.begin(), wrap, features.end());
  }

  /// The features of `scan`, in beam order, in a new vector (as the overload above).
  [[nodiscard]] std::vector<feature_type> extract(const LaserScan<Scalar>& scan) {
    std::vector<feature_type> features;
    extract(scan, features);
    return features;
  }

 private:
  // A range step is a jump edge when it is large, and much larger than the steps next to it (a
  // wall seen at a grazing angle has large but smoothly growing steps). NaN marks a missing step.
  [[nodiscard]] bool step_is_jump(Scalar before, Scalar a, Scalar b, Scalar after) const {
    const Scalar step = std::abs(b - a);
    if (!(step > params_.jump_distance_min + params_.jump_distance_ratio * std::min(a, b)))
      return false;
    const Scalar left = std::isnan(before) ? Scalar(0) : std::abs(a - before);
    const Scalar right = std::isnan(after) ? Scalar(0) : std::abs(after - b);
    return step > params_.jump_smoothness_ratio * std::max(left, right);
  }

  // Between virtual beams i and i + 1, both valid.
  [[nodiscard]] bool is_jump(std::size_t i) const {
    constexpr Scalar none = std::numeric_limits<Scalar>::quiet_NaN();
    const Scalar before = i > 0 && valid_[i - 1] ? r_[i - 1] : none;
    const Scalar after = i + 2 < r_.size() && valid_[i + 2] ? r_[i + 2] : none;
    return step_is_jump(before, r_[i], r_[i + 1], after);
  }

  // Copies the polar signal into the working buffers. A full turn is read as a ring: from just
  // after a segment boundary when there is one, else with the ring's ends padded by wrapped beams
  // so that the filters and line fits see across the seam.
  void load_signal(const LaserScan<Scalar>& scan) {
    const std::size_t n = scan.size();
    std::size_t start = 0;
    pad_ = 0;
    if (full_turn_) {
      constexpr Scalar none = std::numeric_limits<Scalar>::quiet_NaN();
      const auto range_at = [&scan, n](std::size_t i) {
        return scan.is_valid(i % n) ? scan.range(i % n) : none;
      };
      std::size_t boundary = n;
      for (std::size_t i = 0; i < n && boundary == n; ++i) {
        const std::size_t j = (i + 1) % n;
        if (!scan.is_valid(i) || !scan.is_valid(j) ||
            step_is_jump(range_at(i + n - 1), scan.range(i), scan.range(j), range_at(i + 2)))
          boundary = i;
      }
      if (boundary < n)
        start = (boundary + 1) % n;
      else
        pad_ = params_.line_fit_beams + 6;  // the filter chain reaches 4 beams, the fits fit + 1
    }
    const std::size_t m = n + 2 * pad_;
    r_.resize(m);
    points_.resize(m);
    valid_.resize(m);
    beam_.resize(m);
    for (std::size_t p = 0; p < m; ++p) {
      const std::size_t i = (start + p + n * 2 - pad_) % n;
      r_[p] = scan.range(i);
      points_[p] = scan.point(i);
      valid_[p] = scan.is_valid(i) ? 1 : 0;
      beam_[p] = static_cast<std::uint32_t>(i);
    }
    s_.resize(m);
    g_.resize(m);
    softened_.resize(m);
    curvature_.resize(m);
  }

  feature_type make_feature(const Point<2, Scalar>& p, HayaiFeatureType type, std::size_t at,
                            bool jump_edge, Scalar sigma) const {
    return {p, std::atan2(p.y(), p.x()), p.norm(), type, beam_[at], jump_edge, sigma};
  }

  // `end_beam` ends the segment [begin, end); `other` is its neighbour across the jump. The near
  // end is a minimum of the sharpened signal (Ψ1 pushes it down), the far end a maximum; only the
  // near (occluding) end is a landmark unless use_shadow_edges is set. The edge itself lies
  // somewhere between the two beams: it is placed on the segment's line at half a beam towards
  // the jump, and its σ includes that beam quantisation.
  void add_jump_end(std::size_t end_beam, std::size_t other, std::size_t begin, std::size_t end,
                    std::vector<feature_type>& features) const {
    if (end - begin < params_.min_segment_beams) return;
    const bool near = r_[end_beam] < r_[other];
    if (!near && !params_.use_shadow_edges) return;
    const HayaiFeatureType type = near ? HayaiFeatureType::minimum : HayaiFeatureType::maximum;
    // The edge lies uniformly within the spacing of the beams on the near surface (large where
    // the surface is seen at a grazing angle).
    const bool at_end = end_beam + 1 == end;
    const Scalar spacing =
        (points_[end_beam] - points_[at_end ? end_beam - 1 : end_beam + 1]).norm();
    const Scalar sigma = std::hypot(params_.min_feature_sigma, spacing / std::sqrt(Scalar(12)));
    Point<2, Scalar> position = points_[end_beam];
    const std::size_t fit = params_.line_fit_beams;
    if (params_.refine_corners && end - begin >= fit) {
      const auto line = detail::fit_hayai_line<Scalar>(points_, at_end ? end - fit : begin, fit);
      // Ray at the bearing half a beam towards the jump, met with the line.
      const Scalar sign = (at_end ? Scalar(1) : Scalar(-1));
      const Scalar phi = std::atan2(position.y(), position.x()) + sign * dphi_ / 2;
      const Point<2, Scalar> ray(std::cos(phi), std::sin(phi));
      const Scalar denom = ray.x() * line.direction.y() - ray.y() * line.direction.x();
      if (line.rms <= params_.max_line_rms && std::abs(denom) > Scalar(0.1)) {
        const Scalar t =
            (line.centroid.x() * line.direction.y() - line.centroid.y() * line.direction.x()) /
            denom;
        const Point<2, Scalar> moved = t * ray;
        if (t > 0 && (moved - position).norm() <= spacing) position = moved;
      }
    }
    if (sigma <= params_.max_feature_sigma)
      features.push_back(make_feature(position, type, end_beam, true, sigma));
  }

  // Corners inside the segment [begin, end): the filter chain of §3.1 on the polar signal, then
  // the line-fit check and refinement.
  void find_corners(std::size_t begin, std::size_t end, std::vector<feature_type>& features) {
    const std::size_t fit = params_.line_fit_beams;
    if (end - begin < 2 * fit + 5) return;
    const auto at = [begin, end](const std::vector<Scalar>& v, std::size_t i, int offset) {
      // Clamped to the segment: the signal is continued flat beyond its ends.
      const auto j = static_cast<std::ptrdiff_t>(i) + offset;
      const auto lo = static_cast<std::ptrdiff_t>(begin);
      const auto hi = static_cast<std::ptrdiff_t>(end) - 1;
      return v[static_cast<std::size_t>(std::clamp(j, lo, hi))];
    };
    constexpr auto& psi1 = HayaiParams<Scalar>::sharpen;
    constexpr auto& psi2 = HayaiParams<Scalar>::gradient;
    constexpr auto& psi3 = HayaiParams<Scalar>::soften;
    // r^Ψ_i = Σ_k ψ_k r_{i+k} (§3.1), applied as Ψ1, then Ψ2, then Ψ3.
    for (std::size_t i = begin; i < end; ++i)
      s_[i] = psi1[0] * at(r_, i, -1) + psi1[1] * r_[i] + psi1[2] * at(r_, i, 1);
    for (std::size_t i = begin; i < end; ++i)
      g_[i] = psi2[0] * at(s_, i, -1) + psi2[1] * s_[i] + psi2[2] * at(s_, i, 1);
    for (std::size_t i = begin; i < end; ++i)
      softened_[i] = psi3[0] * at(g_, i, -1) + psi3[1] * g_[i] + psi3[2] * at(g_, i, 1);
    // The softened gradient turns at extrema and corners of the polar signal: its own gradient
    // (Ψ2 once more) peaks there.
    for (std::size_t i = begin; i < end; ++i)
      curvature_[i] = std::abs(psi2[0] * at(softened_, i, -1) + psi2[2] * at(softened_, i, 1));

    const Scalar sin_min_angle = std::sin(params_.min_corner_angle);
    const Scalar fit_factor = std::sqrt(Scalar(2) / static_cast<Scalar>(fit));
    const Scalar sqrt_fit = std::sqrt(static_cast<Scalar>(fit));
    // In a padded ring only the middle copy of each beam may become a feature.
    const std::size_t first = std::max(begin + fit + 1, pad_);
    const std::size_t last = std::min(end - fit - 2, r_.size() - pad_ - 1);
    for (std::size_t i = first; i <= last; ++i) {
      const Scalar response = curvature_[i];
      if (response < params_.corner_response_min * r_[i] * dphi_) continue;
      // Non-maximum suppression over ±2 beams (ties go to the first beam).
      if (!(response > curvature_[i - 1] && response > curvature_[i - 2] &&
            response >= at(curvature_, i, 1) && response >= at(curvature_, i, 2)))
        continue;
      // Both sides must be straight and meet at a corner; the beam next to the candidate on each
      // side is skipped, so the true corner may lie anywhere within ±2 beams.
      const auto left = detail::fit_hayai_line<Scalar>(points_, i - fit - 1, fit);
      const auto right = detail::fit_hayai_line<Scalar>(points_, i + 2, fit);
      if (left.rms > params_.max_line_rms || right.rms > params_.max_line_rms) continue;
      const Scalar cross =
          left.direction.x() * right.direction.y() - left.direction.y() * right.direction.x();
      if (std::abs(cross) < sin_min_angle) continue;
      // σ of a fitted direction: the noise across the line over its length (spread · √fit).
      const Scalar noise = std::max({left.rms, right.rms, params_.min_feature_sigma});
      const Scalar sigma_left = noise / (left.spread * sqrt_fit);
      const Scalar sigma_right = noise / (right.spread * sqrt_fit);
      if (!(std::abs(cross) >= params_.corner_significance * std::hypot(sigma_left, sigma_right)))
        continue;
      // left.centroid + t·left.direction = right.centroid + u·right.direction.
      const Point<2, Scalar> diff = right.centroid - left.centroid;
      const Scalar t = (diff.x() * right.direction.y() - diff.y() * right.direction.x()) / cross;
      const Point<2, Scalar> corner = left.centroid + t * left.direction;
      if ((corner - points_[i]).squaredNorm() > params_.max_corner_shift * params_.max_corner_shift)
        continue;
      // Γ: the sign of the softened gradient on both sides decides the kind of extremum.
      const Scalar before = at(softened_, i, -3), after = at(softened_, i, 3);
      const HayaiFeatureType type = before > 0 && after < 0   ? HayaiFeatureType::maximum
                                    : before < 0 && after > 0 ? HayaiFeatureType::minimum
                                                              : HayaiFeatureType::inflection;
      // σ of two fitted lines' intersection: the fits' noise over √(fit/2), over sin(angle).
      const Scalar sigma = noise * fit_factor / std::abs(cross);
      if (params_.refine_corners)
        features.push_back(make_feature(corner, type, i, false, sigma));
      else
        features.push_back(make_feature(
            points_[i], type, i, false,
            std::hypot(params_.min_feature_sigma, r_[i] * dphi_ / std::sqrt(Scalar(12)))));
    }
  }

  HayaiParams<Scalar> params_;
  bool full_turn_{false};
  std::size_t pad_{0};
  Scalar dphi_{0};
  std::vector<Scalar> r_, s_, g_, softened_, curvature_;
  std::vector<Point<2, Scalar>> points_;
  std::vector<std::uint8_t> valid_;
  std::vector<std::uint32_t> beam_;
  std::vector<std::pair<std::size_t, std::size_t>> segments_;
};

/// The matching of §3.1 and the pose of §3.2: registers a data feature set D (current scan) onto a
/// model feature set M (reference scan). Keeps its buffers between calls.
template <std::floating_point Scalar = double>
class HayaiMatcher {
 public:
  using feature_type = HayaiFeature<Scalar>;  ///< a feature of M or D
  using pair_type = HayaiPair<Scalar>;        ///< a pair of M and D

  /// Throws invalid_argument for invalid `params` (see HayaiParams::validate).
  explicit HayaiMatcher(const HayaiParams<Scalar>& params = {}) : params_(params) {
    params_.validate("HayaiMatcher");
  }

  /// The parameters.
  [[nodiscard]] const HayaiParams<Scalar>& params() const { return params_; }

  /// Eq. (4): weighted polar + Cartesian distance, with Θ = ∞ for features of different types.
  [[nodiscard]] Scalar distance(const feature_type& m, const feature_type& d) const {
    if (m.type != d.type) return std::numeric_limits<Scalar>::infinity();  // Θ
    const Scalar dphi = params_.omega_bearing * angle_difference(m.bearing, d.bearing);
    const Scalar dr = m.range - d.range;
    return std::sqrt(dphi * dphi + params_.omega_range * dr * dr) +
           params_.omega_cartesian * (m.position - d.position).norm();
  }

  /// The unique pairs of M and D. `predicted` is the expected pose of the current scan in the
  /// reference frame (identity, odometry, ...): D is moved by it before Eq. (4) is evaluated.
  /// `full_turn` disables the order check for scans covering 360°, whose order is cyclic.
  void match(std::span<const feature_type> model, std::span<const feature_type> data,
             const Pose2<Scalar>& predicted, bool full_turn, std::vector<pair_type>& pairs) {
    pairs.clear();
    moved_.resize(data.size());
    for (std::size_t j = 0; j < data.size(); ++j) {
      moved_[j] = data[j];
      moved_[j].position = predicted.transform_point(data[j].position);
      moved_[j].bearing = std::atan2(moved_[j].position.y(), moved_[j].position.x());
      moved_[j].range = moved_[j].position.norm();
    }
    // The matrix w_ij, stored sparsely: only pairs within the gate are candidates.
    candidates_.clear();
    const Scalar gate = params_.max_match_distance;
    const Scalar cartesian_gate_sq =
        params_.omega_cartesian > 0
            ? gate * gate / (params_.omega_cartesian * params_.omega_cartesian)
            : std::numeric_limits<Scalar>::infinity();
    for (std::size_t i = 0; i < model.size(); ++i) {
      for (std::size_t j = 0; j < moved_.size(); ++j) {
        if (model[i].type != moved_[j].type) continue;  // Θ = ∞
        if ((model[i].position - moved_[j].position).squaredNorm() > cartesian_gate_sq) continue;
        const Scalar dist = distance(model[i], moved_[j]);
        if (dist <= gate)
          candidates_.push_back(
              {static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j), dist});
      }
    }
    // Simplified until unique: the closest remaining pair wins its row and column.
    std::sort(candidates_.begin(), candidates_.end(),
              [](const pair_type& a, const pair_type& b) { return a.distance < b.distance; });
    model_used_.assign(model.size(), 0);
    data_used_.assign(data.size(), 0);
    for (const auto& c : candidates_) {
      if (model_used_[c.model] || data_used_[c.data]) continue;
      model_used_[c.model] = data_used_[c.data] = 1;
      pairs.push_back(c);
    }
    std::sort(pairs.begin(), pairs.end(),
              [](const pair_type& a, const pair_type& b) { return a.model < b.model; });
    if (params_.enforce_order && !full_turn) keep_longest_ordered_run(pairs);
  }

  /// Registers D onto M: matching, Eq. (5-6), dropping pairs whose residual exceeds
  /// max_pair_residual. `pairs` receives the pairs used.
  HayaiMatchResult<Scalar> register_features(std::span<const feature_type> model,
                                             std::span<const feature_type> data,
                                             const Pose2<Scalar>& predicted, bool full_turn,
                                             std::vector<pair_type>& pairs) {
    HayaiMatchResult<Scalar> result;
    result.model_features = model.size();
    result.data_features = data.size();
    const std::size_t needed = params_.min_matched_features;
    if (model.size() < needed || data.size() < needed) {
      result.status = HayaiStatus::featureless;
      return result;
    }
    match(model, data, predicted, full_turn, pairs);
    Pose2<Scalar> shift{};
    for (;;) {
      if (pairs.size() < needed) {
        result.status = HayaiStatus::too_few_matches;
        result.matched = pairs.size();
        return result;
      }
      if (!solve(model, data, pairs, shift)) {
        result.status = HayaiStatus::degenerate;
        result.matched = pairs.size();
        return result;
      }
      // Drop the worst pair while it is too far off, and solve again.
      std::size_t worst = 0;
      Scalar worst_sq = -1;
      for (std::size_t k = 0; k < pairs.size(); ++k) {
        const Scalar e_sq = residual_sq(model, data, pairs[k], shift);
        if (e_sq > worst_sq) {
          worst_sq = e_sq;
          worst = k;
        }
      }
      if (worst_sq <= params_.max_pair_residual * params_.max_pair_residual) break;
      pairs.erase(pairs.begin() + static_cast<std::ptrdiff_t>(worst));
    }
    result.matched = pairs.size();
    result.shift = shift;
    fill_covariance(model, data, pairs, result);
    if (pairs.size() < params_.verified_matches) {
      // Unchecked pairs: the pose must agree with the prediction, within the gates plus three
      // standard deviations of its translation (jump edges seen at a grazing angle slide along
      // their wall by up to a beam spacing; two close features leave the rotation loose).
      const Scalar sigma_t = std::sqrt(std::max(
          result.covariance.template topLeftCorner<2, 2>().trace() / Scalar(2), Scalar(0)));
      const Scalar gate_t = params_.unverified_translation_gate + Scalar(3) * sigma_t;
      if (std::hypot(shift.x - predicted.x, shift.y - predicted.y) > gate_t ||
          std::abs(angle_difference(shift.theta, predicted.theta)) >
              params_.unverified_rotation_gate) {
        result.status = HayaiStatus::unconfirmed;
        result.shift = {};
        result.covariance.setZero();
        result.rms_residual = 0;
        return result;
      }
    }
    result.status = HayaiStatus::success;
    return result;
  }

  /// Eq. (5-6): the closed-form least-squares pose mapping the paired data features onto the
  /// model features, each pair weighted by w_ij = 1 / (σ_i² + σ_j²) in E(R, t) of §3.2. Returns
  /// false when they are (nearly) coincident.
  [[nodiscard]] bool solve(std::span<const feature_type> model, std::span<const feature_type> data,
                           std::span<const pair_type> pairs, Pose2<Scalar>& shift) const {
    if (pairs.size() < 2) return false;
    Point<2, Scalar> cm = Point<2, Scalar>::Zero(), cd = Point<2, Scalar>::Zero();
    Scalar total = 0;
    for (const auto& p : pairs) {
      const Scalar w = weight(model[p.model], data[p.data]);
      cm += w * model[p.model].position;
      cd += w * data[p.data].position;
      total += w;
    }
    cm /= total;
    cd /= total;
    Scalar dot = 0, cross = 0, spread_sq = 0;
    for (const auto& p : pairs) {
      const Scalar w = weight(model[p.model], data[p.data]);
      const Point<2, Scalar> m = model[p.model].position - cm;  // m'_i
      const Point<2, Scalar> d = data[p.data].position - cd;    // d'_i
      dot += w * (m.x() * d.x() + m.y() * d.y());
      cross += w * (m.y() * d.x() - m.x() * d.y());
      spread_sq += w * d.squaredNorm();
    }
    if (spread_sq <= total * params_.min_feature_sigma * params_.min_feature_sigma) return false;
    // Eq. (5). The paper measures θ clockwise, so its rotation matrices in Eq. (3) and (6) are
    // R(-θ); with θ counter-clockwise (this library) the same least-squares optimum reads
    // Δθ = atan2(Σ m'^y d'^x − m'^x d'^y, Σ m'^x d'^x + m'^y d'^y). (The text copy of paper 003
    // prints the numerator and denominator garbled; this is the minimiser of E(R, t).)
    const Scalar dtheta = std::atan2(cross, dot);
    const Eigen::Rotation2D<Scalar> rot(dtheta);
    const Point<2, Scalar> t = cm - rot * cd;  // Eq. (6)
    shift = {t.x(), t.y(), normalize_angle(dtheta)};
    return true;
  }

 private:
  [[nodiscard]] static Scalar residual_sq(std::span<const feature_type> model,
                                          std::span<const feature_type> data, const pair_type& p,
                                          const Pose2<Scalar>& shift) {
    return (model[p.model].position - shift.transform_point(data[p.data].position)).squaredNorm();
  }

  // The features' order cannot change fundamentally between consecutive scans: among the pairs
  // sorted by model index keep the longest run whose data indices also increase (patience sort).
  void keep_longest_ordered_run(std::vector<pair_type>& pairs) {
    const std::size_t n = pairs.size();
    if (n < 2) return;
    tails_.clear();
    previous_.assign(n, n);
    for (std::size_t k = 0; k < n; ++k) {
      const auto pos = std::lower_bound(
          tails_.begin(), tails_.end(), pairs[k].data,
          [&pairs](std::size_t t, std::uint32_t value) { return pairs[t].data < value; });
      if (pos != tails_.begin()) previous_[k] = *(pos - 1);
      if (pos == tails_.end())
        tails_.push_back(k);
      else
        *pos = k;
    }
    keep_.assign(n, 0);
    for (std::size_t k = tails_.back(); k != n; k = previous_[k])
      keep_[k] = 1;
    std::size_t out = 0;
    for (std::size_t k = 0; k < n; ++k)
      if (keep_[k]) pairs[out++] = pairs[k];
    pairs.resize(out);
  }

  [[nodiscard]] Scalar weight(const feature_type& m, const feature_type& d) const {
    const Scalar floor_sq = params_.min_feature_sigma * params_.min_feature_sigma;
    return Scalar(1) / std::max(m.sigma * m.sigma + d.sigma * d.sigma, floor_sq);
  }

  // Covariance of (Δx, Δy, Δθ): s² (Σ w_i J_iᵀ J_i)⁻¹ with J_i the Jacobian of the residual
  // m_i − (R d_i + t) and s² the a-posteriori variance factor (at least 1, so noise-free scans
  // keep the features' prior σ).
  void fill_covariance(std::span<const feature_type> model, std::span<const feature_type> data,
                       std::span<const pair_type> pairs, HayaiMatchResult<Scalar>& result) const {
    Eigen::Matrix<Scalar, 3, 3> info = Eigen::Matrix<Scalar, 3, 3>::Zero();
    Scalar sum_sq = 0, weighted_sq = 0;
    const Eigen::Rotation2D<Scalar> rot(result.shift.theta);
    for (const auto& p : pairs) {
      const Scalar w = weight(model[p.model], data[p.data]);
      const Point<2, Scalar> rd = rot * data[p.data].position;
      Eigen::Matrix<Scalar, 2, 3> j;
      j << Scalar(1), Scalar(0), -rd.y(), Scalar(0), Scalar(1), rd.x();
      info.noalias() += w * j.transpose() * j;
      const Scalar e_sq = residual_sq(model, data, p, result.shift);
      sum_sq += e_sq;
      weighted_sq += w * e_sq;
    }
    const auto count = static_cast<Scalar>(pairs.size());
    result.rms_residual = std::sqrt(sum_sq / count);
    const Scalar dof = std::max(Scalar(2) * count - Scalar(3), Scalar(1));
    result.covariance = std::max(weighted_sq / dof, Scalar(1)) * info.inverse();
  }

  HayaiParams<Scalar> params_;
  std::vector<feature_type> moved_;
  std::vector<pair_type> candidates_;
  std::vector<std::uint8_t> model_used_, data_used_, keep_;
  std::vector<std::size_t> tails_, previous_;
};

/// The features of one scan (convenience; HayaiFeatureExtractor reuses its buffers).
template <std::floating_point Scalar>
[[nodiscard]] std::vector<HayaiFeature<Scalar>> extract_hayai_features(
    const LaserScan<Scalar>& scan, const HayaiParams<Scalar>& params = {}) {
  return HayaiFeatureExtractor<Scalar>(params).extract(scan);
}

/// Registers `current` onto `reference` with HAYAI (steps 1-3 of §3): the result's shift is the
/// pose of the current scan in the reference scan's frame. `predicted` is a guess of that pose
/// (e.g. the odometry increment) used to match the features.
template <std::floating_point Scalar>
[[nodiscard]] HayaiMatchResult<Scalar> register_hayai(const LaserScan<Scalar>& reference,
                                                      const LaserScan<Scalar>& current,
                                                      const HayaiParams<Scalar>& params = {},
                                                      const Pose2<Scalar>& predicted = {}) {
  HayaiFeatureExtractor<Scalar> extractor(params);
  const auto model = extractor.extract(reference);
  const auto data = extractor.extract(current);
  HayaiMatcher<Scalar> matcher(params);
  std::vector<HayaiPair<Scalar>> pairs;
  return matcher.register_features(model, data, predicted, covers_full_turn(current), pairs);
}

/// Odometry noise of the tracker's EKF: standard deviations of the odometry increment grow with
/// the distance driven and the angle turned (the usual odometry motion model; paper 003 names
/// the EKF of [6] without its constants, these are ours).
template <std::floating_point Scalar = double>
struct HayaiOdometryNoise {
  Scalar translation_per_metre{Scalar(0.05)};   ///< σ_xy per metre driven (m/m)
  Scalar translation_per_radian{Scalar(0.02)};  ///< σ_xy per radian turned (m/rad)
  /// σ_θ per radian turned (rad/rad): the MIT CSAIL log's odometry misses about 12 % of its
  /// turns against scan matching.
  Scalar rotation_per_radian{Scalar(0.15)};
  Scalar rotation_per_metre{deg_to_rad(Scalar(2))};  ///< σ_θ per metre driven (rad/m)
  Scalar translation_floor{Scalar(0.005)};           ///< σ_xy of any increment (m)
  Scalar rotation_floor{deg_to_rad(Scalar(0.25))};   ///< σ_θ of any increment (rad)
  /// HAYAI's increment and the odometry's disagree when the Mahalanobis distance² between them
  /// exceeds this (χ² with 3 degrees of freedom, 99.9 %); they are then not fused.
  Scalar innovation_gate{Scalar(16.27)};
  /// On such a disagreement HAYAI's increment is kept alone when it rests on at least this many
  /// pairs (a registration checked by redundant pairs: the odometry slipped or lagged), and the
  /// odometry's increment otherwise (HAYAI found a wrong match). 0: odometry always wins.
  std::size_t trusted_matches{4};

  /// Throws invalid_argument naming the first violated contract: the four growth rates must be
  /// finite and >= 0, the two floors and innovation_gate finite and > 0.
  void validate(std::string_view where = "HayaiOdometryNoise") const {
    detail::require_non_negative(where, "translation_per_metre", translation_per_metre);
    detail::require_non_negative(where, "translation_per_radian", translation_per_radian);
    detail::require_non_negative(where, "rotation_per_radian", rotation_per_radian);
    detail::require_non_negative(where, "rotation_per_metre", rotation_per_metre);
    detail::require_positive(where, "translation_floor", translation_floor);
    detail::require_positive(where, "rotation_floor", rotation_floor);
    detail::require_positive(where, "innovation_gate", innovation_gate);
  }

  /// Covariance of an odometry increment u = (Δx, Δy, Δθ) in the frame it starts from.
  [[nodiscard]] Eigen::Matrix<Scalar, 3, 3> covariance(const Pose2<Scalar>& u) const {
    const Scalar dist = std::hypot(u.x, u.y), turn = std::abs(u.theta);
    const Scalar sxy =
        translation_floor + translation_per_metre * dist + translation_per_radian * turn;
    const Scalar sth = rotation_floor + rotation_per_radian * turn + rotation_per_metre * dist;
    return Eigen::Matrix<Scalar, 3, 1>(sxy * sxy, sxy * sxy, sth * sth).asDiagonal();
  }
};

/// Where a tracking step's pose increment came from.
enum class HayaiIncrementSource : std::uint8_t {
  first_scan,  ///< the first scan: it became the reference, the pose is unchanged
  hayai,       ///< HAYAI's Δp alone (no odometry given)
  fused,       ///< HAYAI's Δp fused with the odometry increment by the EKF
  odometry,    ///< odometry alone: HAYAI failed or its Δp was rejected by the innovation gate
  constant_velocity,  ///< HAYAI failed, no odometry: the previous increment was repeated
  none                ///< HAYAI failed, no odometry, coast_on_failure off: the pose is unchanged
};

/// The enumerator's name, e.g. "fused" or "constant_velocity".
[[nodiscard]] constexpr std::string_view to_string(HayaiIncrementSource source) {
  switch (source) {
    case HayaiIncrementSource::first_scan:
      return "first_scan";
    case HayaiIncrementSource::hayai:
      return "hayai";
    case HayaiIncrementSource::fused:
      return "fused";
    case HayaiIncrementSource::odometry:
      return "odometry";
    case HayaiIncrementSource::constant_velocity:
      return "constant_velocity";
    case HayaiIncrementSource::none:
      return "none";
  }
  return "unknown";
}

/// The outcome of one tracking step.
template <std::floating_point Scalar = double>
struct HayaiTrackResult {
  HayaiMatchResult<Scalar> match;  ///< HAYAI's registration of the scan onto the reference
  /// Where `increment` came from.
  HayaiIncrementSource source{HayaiIncrementSource::first_scan};
  Pose2<Scalar> increment{};        ///< Δp applied by Eq. (3)
  Pose2<Scalar> pose{};             ///< p_{n+1}
  bool innovation_rejected{false};  ///< HAYAI succeeded but disagreed with odometry beyond the gate
};

/// Pose tracking with HAYAI (§3): registers every scan onto the previous one and accumulates the
/// pose with Eq. (3); when odometry increments are given they are fused with HAYAI's by an EKF on
/// the increment (predict with odometry, correct with HAYAI, Fig. 5 of paper 003), and the pose
/// covariance is propagated. Failures are reported in the result, never turned into a pose.
template <std::floating_point Scalar = double>
class HayaiTracker {
 public:
  using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;  ///< a covariance of (x, y, θ)

  /// Starts at `initial_pose` (the pose of the first scan) with zero covariance. Throws
  /// invalid_argument for invalid `params` or `odometry_noise`.
  explicit HayaiTracker(const HayaiParams<Scalar>& params = {},
                        const HayaiOdometryNoise<Scalar>& odometry_noise = {},
                        const Pose2<Scalar>& initial_pose = {})
      : extractor_(params), matcher_(params), noise_(odometry_noise), pose_(initial_pose) {
    noise_.validate("HayaiTracker");
  }

  /// Tracks one scan without odometry. The previous step's increment predicts the motion
  /// (constant velocity) for matching.
  HayaiTrackResult<Scalar> track(const LaserScan<Scalar>& scan) { return step(scan, std::nullopt); }

  /// Tracks one scan, with the odometry increment since the previous scan (its pose in the
  /// previous scan's frame, e.g. relative(odom_prev, odom_now)).
  HayaiTrackResult<Scalar> track(const LaserScan<Scalar>& scan,
                                 const Pose2<Scalar>& odometry_increment) {
    detail::require_finite("HayaiTracker::track", "odometry_increment.x", odometry_increment.x);
    detail::require_finite("HayaiTracker::track", "odometry_increment.y", odometry_increment.y);
    detail::require_finite("HayaiTracker::track", "odometry_increment.theta",
                           odometry_increment.theta);
    return step(scan, odometry_increment);
  }

  /// The pose of the last scan tracked (the last result's `pose`), in the frame `initial_pose`
  /// is given in.
  [[nodiscard]] const Pose2<Scalar>& pose() const { return pose_; }
  /// Covariance of (x, y, θ) accumulated since the initial pose (grows without loop closure).
  [[nodiscard]] const Matrix3& covariance() const { return covariance_; }
  /// Features of the current reference scan (M of the next step).
  [[nodiscard]] const std::vector<HayaiFeature<Scalar>>& reference_features() const {
    return reference_;
  }
  /// Pairs used by the last successful or failed registration (indices into the features).
  [[nodiscard]] const std::vector<HayaiPair<Scalar>>& last_pairs() const { return pairs_; }
  /// The HAYAI parameters.
  [[nodiscard]] const HayaiParams<Scalar>& params() const { return matcher_.params(); }

  /// Forgets the reference scan and restarts at `pose` with zero covariance.
  void reset(const Pose2<Scalar>& pose = {}) {
    pose_ = pose;
    covariance_.setZero();
    has_reference_ = false;
    velocity_ = {};
  }

 private:
  // Covariance of p ⊕ u (Eq. 3) from the covariances of p and u, through the Jacobians. (The
  // paper's clockwise θ makes its matrix in Eq. (3) R(-θ_n); here θ is counter-clockwise.)
  [[nodiscard]] static Matrix3 compose_covariance(const Pose2<Scalar>& p, const Matrix3& p_cov,
                                                  const Pose2<Scalar>& u, const Matrix3& u_cov) {
    const Scalar c = std::cos(p.theta), s = std::sin(p.theta);
    Matrix3 jp = Matrix3::Identity();
    jp(0, 2) = -s * u.x - c * u.y;
    jp(1, 2) = c * u.x - s * u.y;
    Matrix3 ju = Matrix3::Identity();
    ju.template topLeftCorner<2, 2>() << c, -s, s, c;
    return jp * p_cov * jp.transpose() + ju * u_cov * ju.transpose();
  }

  HayaiTrackResult<Scalar> step(const LaserScan<Scalar>& scan,
                                const std::optional<Pose2<Scalar>>& odometry) {
    HayaiTrackResult<Scalar> result;
    extractor_.extract(scan, current_);
    if (!has_reference_) {
      std::swap(reference_, current_);
      has_reference_ = true;
      result.match.data_features = reference_.size();
      result.pose = pose_;
      return result;
    }
    // The motion since the previous scan is predicted by the odometry, or at constant velocity
    // without it; the prediction guides the matching, confirms two-pair poses and is retried
    // turned when it misses.
    const Pose2<Scalar> predicted = odometry ? *odometry : velocity_;
    const Matrix3 predicted_covariance = noise_.covariance(predicted);
    const bool full_turn = covers_full_turn(scan);
    result.match = matcher_.register_features(reference_, current_, predicted, full_turn, pairs_);
    if (!result.match.ok() && result.match.status != HayaiStatus::featureless)
      recover(predicted, full_turn, result.match);
    Matrix3 increment_covariance = predicted_covariance;
    if (result.match.ok()) {
      result.source = HayaiIncrementSource::hayai;
      result.increment = result.match.shift;
      increment_covariance = result.match.covariance;
      if (odometry) fuse(*odometry, predicted_covariance, result, increment_covariance);
    } else if (odometry) {
      result.source = HayaiIncrementSource::odometry;
      result.increment = *odometry;
    } else if (matcher_.params().coast_on_failure) {
      result.source = HayaiIncrementSource::constant_velocity;
      result.increment = velocity_;
    } else {
      // Nothing to move by: the pose stays, the failure is reported, and the scan becomes the
      // reference all the same (step 5; an older reference would only drift further away).
      result.source = HayaiIncrementSource::none;
      result.pose = pose_;
      std::swap(reference_, current_);
      return result;
    }
    // Eq. (3): p_{n+1} = p_n ⊕ Δp, with the covariance propagated.
    covariance_ = compose_covariance(pose_, covariance_, result.increment, increment_covariance);
    pose_ = compose(pose_, result.increment);
    result.pose = pose_;
    velocity_ = result.increment;
    std::swap(reference_, current_);  // step 5: R <- S
    return result;
  }

  // The prediction missed (a turn faster than predicted): try it turned by ±k · step up to the
  // recovery limit, and keep the hypothesis that matched the most features.
  void recover(const Pose2<Scalar>& predicted, bool full_turn, HayaiMatchResult<Scalar>& best) {
    const Scalar step = matcher_.params().recovery_rotation_step;
    const Scalar limit = matcher_.params().recovery_rotation_max;
    if (!(step > 0) || !(limit >= step)) return;
    for (Scalar turn = step; turn <= limit + step / 2; turn += step) {
      for (const Scalar sign : {Scalar(1), Scalar(-1)}) {
        Pose2<Scalar> hypothesis = predicted;
        hypothesis.theta = normalize_angle(predicted.theta + sign * turn);
        const auto r =
            matcher_.register_features(reference_, current_, hypothesis, full_turn, scratch_pairs_);
        // A turned hypothesis is no prediction to confirm two pairs by: only verified poses.
        if (r.ok() && r.matched >= matcher_.params().verified_matches &&
            (!best.ok() || r.matched > best.matched ||
             (r.matched == best.matched && r.rms_residual < best.rms_residual))) {
          best = r;
          std::swap(pairs_, scratch_pairs_);
        }
      }
    }
  }

  // EKF on the increment: the prediction is the odometry increment u with covariance Q, the
  // measurement HAYAI's Δp with covariance R; x = u + K (Δp − u), K = Q (Q + R)⁻¹. On entry
  // result.increment / cov hold Δp and R, on return the increment to apply and its covariance.
  void fuse(const Pose2<Scalar>& u, const Matrix3& q, HayaiTrackResult<Scalar>& result,
            Matrix3& cov) const {
    const Pose2<Scalar>& shift = result.increment;
    const Matrix3 s_inv = (q + cov).inverse();
    const Eigen::Matrix<Scalar, 3, 1> innovation(shift.x - u.x, shift.y - u.y,
                                                 angle_difference(shift.theta, u.theta));
    if (innovation.dot(s_inv * innovation) > noise_.innovation_gate) {
      // They disagree: HAYAI's Δp stands alone when redundant pairs checked it, else odometry.
      result.innovation_rejected = true;
      if (noise_.trusted_matches == 0 || result.match.matched < noise_.trusted_matches) {
        result.source = HayaiIncrementSource::odometry;
        result.increment = u;
        cov = q;
      }
      return;
    }
    const Matrix3 k = q * s_inv;
    const Eigen::Matrix<Scalar, 3, 1> x = k * innovation;
    result.source = HayaiIncrementSource::fused;
    result.increment = {u.x + x(0), u.y + x(1), normalize_angle(u.theta + x(2))};
    cov = (Matrix3::Identity() - k) * q;
  }

  HayaiFeatureExtractor<Scalar> extractor_;
  HayaiMatcher<Scalar> matcher_;
  HayaiOdometryNoise<Scalar> noise_;
  Pose2<Scalar> pose_{};
  Matrix3 covariance_{Matrix3::Zero()};
  Pose2<Scalar> velocity_{};
  bool has_reference_{false};
  std::vector<HayaiFeature<Scalar>> reference_, current_;
  std::vector<HayaiPair<Scalar>> pairs_, scratch_pairs_;
};

}  // namespace rangenav
