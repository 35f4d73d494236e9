#pragma once
// Incremental registration with a sparse point map (paper 000 §3.2-3.3, paper 002 §6.3,
// paper 004 §3.2), one code path for 2D scans (3-DOF) and 3D clouds (6-DOF):
//   - the first scan D_0 is the map M_0; its frame is the map frame;
//   - every later scan D_i is matched against M_{i-1} by ICP, with the initial guess
//     T^_i = (last correction) ∘ (odometry increment) = T_{i-1} ∘ (o_{i-1}^-1 o_i);
//   - a registration whose fitness (inlier fraction) is below `min_fitness` is rejected and the
//     odometry guess kept (paper 004 §3.2), as are registrations that stopped for too few pairs;
//   - every scan gets a pose (tracking); key frames (moved > 0.5 m or turned > 25°) are inserted
//     into the sparse map by Eq. (5) of paper 000.
// 3D clouds may be voxel-downsampled before matching (`voxel_size`, paper 004 §3.2).
//
// Beyond the papers, for real 2D laser logs (see laser_slam_params() and LaserSlamMapper):
//   - `match_previous_scan`: the scan is first aligned to the previous scan (dense, so the
//     decaying threshold can start wide without pairing with distant map structure), and that
//     result is the initial guess of the map registration; where the robot reverses from
//     where its scanner looks, the previous scan is aligned to the new one instead (the data
//     must be the scan whose view the other covers);
//   - with match_previous_scan, a constant-velocity guess is tried beside the odometry guess
//     when they disagree (odometry that froze, then jumped);
//   - an ICP whose solver takes model normals (PointToLineSolver) gets the map's normals;
//   - with an odometry noise model, the odometry decides between registrations that disagree
//     (the scan-to-scan and the map result; the map result and the map registration from the
//     odometry guess): see process();
//   - with an odometry noise model, an extended Kalman filter's prediction (the pose's
//     covariance relative to the map carried through each increment) completes the
//     registration along the directions the scan observes less than the prediction does;
//   - optionally (LoopClosingMapper's default), the noise model is calibrated online to the
//     robot at hand (covariance matching on the steps the scans measure better than the
//     odometry, see calibrate()): the same default serves wheel odometry that is several
//     times better or worse than it assumes.
// On the MIT CSAIL benchmark log these cut the mean relation error from 0.48 m to 0.08 m
// (figures and the command in docs/benchmarks.md).

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
#include <type_traits>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/voxel_grid.hpp"
#include "rangenav/mapping/key_frame.hpp"
#include "rangenav/mapping/pose_uncertainty.hpp"
#include "rangenav/mapping/sparse_point_map.hpp"
#include "rangenav/registration/icp.hpp"
#include "rangenav/registration/point_to_line_solver.hpp"
#include "rangenav/search/kd_tree.hpp"

namespace rangenav {

/// Settings of an IncrementalMapper; the defaults are the papers' (see laser_slam_params() for
/// real 2D laser logs).
template <std::floating_point Scalar = double>
struct IncrementalMapperParams {
  /// When a scan is inserted into the map (default: moved 0.5 m or turned 25°).
  KeyFrameParams<Scalar> key_frames{};
  /// The sparse point map's density bound eps_D (default 0.15 m), index and normals.
  SparsePointMapParams<Scalar> map{};
  /// Registrations with fitness (fraction of scan points matched within the final distance)
  /// below this are rejected (paper 004 §3.2).
  Scalar min_fitness = Scalar(0.3);
  /// Final distance of the ICP's DecayingDistanceRejector (when it has one). It must exceed
  /// eps_D: a scan point on a mapped wall is only guaranteed a map point within eps_D.
  Scalar final_match_distance = Scalar(0.2);
  /// Keep a registration the ICP reported degenerate (e.g. in a corridor): its constrained
  /// directions still correct the odometry. When false the odometry guess is kept instead.
  bool accept_degenerate = true;
  /// A registration that moves the pose farther than this from the odometry guess is rejected
  /// (a gross mismatch: between two scans odometry is off by centimetres, not metres). m, rad.
  Scalar max_correction_distance = std::numeric_limits<Scalar>::infinity();
  /// Angle limit of the same test (rad); default: no limit.
  Scalar max_correction_angle = std::numeric_limits<Scalar>::infinity();
  /// Edge of the voxel filter applied to each scan before matching; 0 = no filter.
  Scalar voxel_size = Scalar(0);
  /// With voxel_size > 0: key frames join the map voxel-filtered (paper 004 §4: "downsampling
  /// after registration reduces the size of the point map"), not at full resolution. The map
  /// then offers eps_D-thinned voxel centroids, and inserting a 640 x 480 frame costs a few
  /// thousand map queries instead of 300,000.
  bool insert_downsampled = false;
  /// First threshold of the map ICP's DecayingDistanceRejector; unset = the rejector's own.
  std::optional<Scalar> initial_match_distance{};
  /// The map ICP's DecayingDistanceRejector::skip_when_converged: once the registration has
  /// converged under a threshold still decaying, go straight to final_match_distance. Default
  /// false (the papers' schedule).
  bool skip_decay_when_converged = false;
  /// Align each scan to the previous one first (scan-to-scan ICP, `previous_scan_icp`) and
  /// start the map registration from that result. The max_correction_* limits then apply to
  /// the map registration's change of that result.
  bool match_previous_scan = false;
  /// With match_previous_scan: when the constant-velocity guess (the last scan's motion again)
  /// differs from the odometry guess by more than this, both are tried (m, rad).
  Scalar hypothesis_distance = Scalar(0.1);
  /// Angle threshold of the same test (rad, default 5°).
  Scalar hypothesis_angle = Scalar(5) * std::numbers::pi_v<Scalar> / 180;
  /// The odometry's noise model. When set, every accepted registration is completed by the
  /// odometry prediction (pose_uncertainty.hpp's complete()): along the directions the scan
  /// does not constrain (a corridor's axis) the odometry carries the pose; and every update
  /// reports the pose's information (MapperUpdate::information). The prediction's covariance
  /// is that of an extended Kalman filter's prediction step: the previous pose's covariance
  /// relative to the map, carried through the increment, plus the increment's own (see
  /// process()).
  std::optional<OdometryNoise<Scalar>> odometry_noise{};
  /// With odometry_noise: complete the registration by the odometry prediction along the
  /// directions the scan constrains less than the prediction does (pose_uncertainty.hpp's
  /// complete()). false: the noise model only sets the reported information.
  bool fuse_odometry = true;
  /// σ floor of the point-to-plane residuals in the registration's information (m): the range
  /// noise of the sensor (about 1 cm for the SICK / Hokuyo class of laser scanners).
  Scalar sensor_sigma = Scalar(0.01);
  /// The odometry prediction is not fused when it disagrees with the registration beyond this
  /// χ² (the prediction's and the registration's covariances summed; default the 99.9 %
  /// quantile for 3 DOF, 16.27; 22.46 suits 6 DOF): odometry that froze and jumped is then not
  /// averaged into a good match. The same χ² (the increment's covariance alone) says whether a
  /// registration agrees with the odometry when two registrations disagree (process()).
  Scalar odometry_gate_chi2 = Scalar(16.27);
  /// Where a map registration disagrees with the odometry and the registration run again from
  /// the odometry guess agrees, the former is kept only if it pairs more scan points than the
  /// latter beyond chance: McNemar's exact test on the points that one of the two pairs and the
  /// other does not, one-sided, at this significance level (default 5 %). A few more pairs are
  /// no evidence: in a corridor the registration that slid back pairs the scan's farthest
  /// points, which from the true pose lie beyond the mapped part (process()).
  Scalar witness_significance = Scalar(0.05);
  /// With odometry_noise: calibrate the model online (IncrementalMapper::odometry_noise()).
  /// Every accepted registration whose step the scan measures better than the odometry does is
  /// a sample of the odometry's error; the model's translation and rotation terms are scaled so
  /// that the median of the samples' normalised squared errors is the χ²(1) median.
  /// LoopClosingMapper (LaserSlam) turns it on with the default model it fills in: its front
  /// end tracks a local map, so the odometry gate has to allow for the odometry's error over a
  /// step only. Off by default here: a mapper that matches every scan against its whole map
  /// re-localises on parts it drifted from by corrections far beyond one step's odometry error
  /// (intel-corrected driven backwards, tests/mapping/slam.cpp: 10.9 m worst drift calibrated,
  /// 1.9 m with the default model as given), and the gate's slack is what lets it.
  bool calibrate_odometry_noise = false;
  /// The calibration's memory: the last this many samples of translation errors, and as many of
  /// rotation errors (older ones drop out, so the model follows a change of floor or load). The
  /// model is scaled once 30 samples are in (at least 30).
  std::size_t calibration_window = 256;
  /// The map ICP solver's degeneracy_ratio (when it has one): directions of its normal
  /// equations weaker than this fraction of the strongest stay at the start of the
  /// registration. Unset = the solver's own (transform_solver.hpp's default_degeneracy_ratio,
  /// 1 %: in 3D a view dominated by one plane constrains the in-plane motions only through the
  /// normals' errors, and sliding on them fails the registration).
  std::optional<Scalar> solver_degeneracy_ratio{};
  /// The map ICP solver's gauss_newton_steps (when it has them): Gauss-Newton steps per ICP
  /// iteration on the same pairs, which stop early once a step moves less than the solver's
  /// step_epsilon. Unset = the solver's own (3).
  std::optional<int> solver_gauss_newton_steps{};

  /// Throws invalid_argument naming the first parameter out of range.
  void validate() const {
    key_frames.validate();
    map.validate();
    if (!(min_fitness >= Scalar(0) && min_fitness <= Scalar(1)))
      detail::throw_invalid_argument("IncrementalMapperParams", "min_fitness", min_fitness,
                                     "must be in [0, 1]");
    detail::require_non_negative("IncrementalMapperParams", "voxel_size", voxel_size);
    detail::require_positive("IncrementalMapperParams", "final_match_distance",
                             final_match_distance);
    if (initial_match_distance)
      detail::require_positive("IncrementalMapperParams", "initial_match_distance",
                               *initial_match_distance);
    if (odometry_noise) odometry_noise->validate();
    detail::require_positive("IncrementalMapperParams", "sensor_sigma", sensor_sigma);
    detail::require_positive("IncrementalMapperParams", "odometry_gate_chi2", odometry_gate_chi2);
    if (!(witness_significance > Scalar(0) && witness_significance < Scalar(1)))
      detail::throw_invalid_argument("IncrementalMapperParams", "witness_significance",
                                     witness_significance, "must be in (0, 1)");
    if (calibration_window < std::size_t(30))
      detail::throw_invalid_argument("IncrementalMapperParams", "calibration_window",
                                     calibration_window, "must be >= 30");
    if (solver_degeneracy_ratio &&
        !(*solver_degeneracy_ratio >= Scalar(0) && *solver_degeneracy_ratio < Scalar(1)))
      detail::throw_invalid_argument("IncrementalMapperParams", "solver_degeneracy_ratio",
                                     *solver_degeneracy_ratio, "must be in [0, 1)");
    if (solver_gauss_newton_steps && *solver_gauss_newton_steps < 1)
      detail::throw_invalid_argument("IncrementalMapperParams", "solver_gauss_newton_steps",
                                     *solver_gauss_newton_steps, "must be >= 1");
  }
};

namespace detail {

/// P(X >= k) for X ~ Binomial(n, 1/2): the one-sided p-value of McNemar's exact test (McNemar
/// 1947, "Note on the sampling error of the difference between correlated proportions",
/// Psychometrika 12(2)) when k of the n discordant items favour one side. Summed in log space,
/// so that n in the thousands does not underflow 2^-n.
inline double binomial_half_tail(std::size_t k, std::size_t n) {
  if (k == 0) return 1.0;
  if (k > n) return 0.0;
  const double log_half_n = -static_cast<double>(n) * std::numbers::ln2;
  double log_choose = 0;  // log C(n, i)
  double tail = 0;
  for (std::size_t i = 0; i <= n; ++i) {
    if (i >= k) tail += std::exp(log_choose + log_half_n);
    if (i < n)
      log_choose += std::log(static_cast<double>(n - i)) - std::log(static_cast<double>(i + 1));
  }
  return std::min(tail, 1.0);
}

/// Whether the registration with the final pairs `a` pairs more of the `data_size` scan points
/// than the one with the pairs `b` beyond chance: of the points paired by exactly one of the
/// two, too many are a's for a fair coin (binomial_half_tail() at most `significance`).
template <int D, class Scalar>
bool pairs_more_beyond_chance(std::span<const Correspondence<D, Scalar>> a,
                              std::span<const Correspondence<D, Scalar>> b, std::size_t data_size,
                              double significance) {
  std::vector<std::int8_t> side(data_size, 0);  // +1 paired by a, -1 by b, 0 both or neither
  for (const auto& c : a)
    side[c.data_index] = 1;
  for (const auto& c : b)
    side[c.data_index] = static_cast<std::int8_t>(side[c.data_index] - 1);
  const auto a_only = static_cast<std::size_t>(std::count(side.begin(), side.end(), 1));
  const auto b_only = static_cast<std::size_t>(std::count(side.begin(), side.end(), -1));
  return a_only > b_only && binomial_half_tail(a_only, a_only + b_only) <= significance;
}

}  // namespace detail

/// What the mapper did with one scan.
template <int D, class Scalar = double>
struct MapperUpdate {
  Transform<D, Scalar> pose;           ///< the scan's pose in the map frame
  Transform<D, Scalar> initial_guess;  ///< the odometry-based guess it started from
  /// The scan-to-scan result the map registration started from (match_previous_scan only).
  std::optional<Transform<D, Scalar>> previous_scan_guess;
  std::optional<IcpResult<D, Scalar>> icp;  ///< absent for the first scan
  bool registration_accepted = false;       ///< false: the pose is the odometry guess
  bool key_frame = false;                   ///< the scan was inserted into the map
  /// What the key frame's insertion stored (zero when the scan was no key frame).
  SparseInsertStats inserted{};
  /// With IncrementalMapperParams::odometry_noise: the information of `pose` relative to the
  /// map (body-frame perturbation, pose_uncertainty.hpp): the registration's fused with the
  /// odometry's, or the odometry's alone when the registration was rejected or there was none.
  /// A scan without odometry counts as a step in place for the noise model: its floors keep
  /// the information finite, and nothing is fused into the pose.
  std::optional<lie::PoseMatrix<D, Scalar>> information;
  /// The odometry prediction completed the pose (it passed the χ² gate).
  bool odometry_fused = false;
};

/// Incremental registration of scans against a sparse point map (see the file comment): every
/// scan gets a pose, key frames extend the map. `IcpType` is the scan-to-map ICP (the papers'
/// by default); `Index` is the map's search structure (SparsePointMap's third parameter).
template <int D, std::floating_point Scalar = double, class IcpType = PaperIcp<D, Scalar>,
          class Index = DefaultMapIndex<D, Scalar>>
class IncrementalMapper {
 public:
  /// A scan's pose: scan (robot) frame -> map frame.
  using transform_type = Transform<D, Scalar>;
  /// A point of a scan or of the map.
  using point_type = Point<D, Scalar>;

  /// The scan-to-scan ICP of match_previous_scan.
  using previous_scan_icp_type = Icp<D, Scalar, DecayingDistanceRejector<Scalar>>;
  /// Whether IcpType's solver uses model normals (then the map keeps them).
  static constexpr bool uses_normals =
      ModelNormalSolver<std::remove_cvref_t<decltype(std::declval<IcpType&>().solver)>, D, Scalar>;

  /// The settings; validated by the constructor (later changes are not re-checked).
  IncrementalMapperParams<Scalar> params;
  IcpType icp{};  ///< public typed policy: configure its rejectors and parameters directly
  /// The scan-to-scan ICP of match_previous_scan (decaying threshold 1.0 -> 0.1 m).
  previous_scan_icp_type previous_scan_icp{};

  /// An empty map; the first scan will define the map frame. Throws invalid_argument for bad
  /// params (IncrementalMapperParams::validate()).
  explicit IncrementalMapper(IncrementalMapperParams<Scalar> p = {})
      : params(p), map_((p.validate(), with_normals(p.map))), key_frames_(p.key_frames) {
    if constexpr (requires { icp.template rejector<DecayingDistanceRejector<Scalar>>(); }) {
      auto& decaying = icp.template rejector<DecayingDistanceRejector<Scalar>>();
      decaying.final_distance = params.final_match_distance;
      if (params.initial_match_distance) decaying.initial_distance = *params.initial_match_distance;
      decaying.initial_distance = std::max(decaying.initial_distance, decaying.final_distance);
      decaying.skip_when_converged = params.skip_decay_when_converged;
    }
    previous_scan_icp.params.check_degeneracy = false;
    // The previous scan is dense (neighbouring beams centimetres apart), so its second-nearest
    // point is rarely far enough to prove the nearest still nearest after the estimate moves;
    // keeping 4 candidates lets BasicIcp::match skip more searches (the pairs are the same).
    previous_scan_icp.params.reuse_candidates = 4;
    if constexpr (requires { icp.solver.degeneracy_ratio; })
      if (params.solver_degeneracy_ratio)
        icp.solver.degeneracy_ratio = *params.solver_degeneracy_ratio;
    if constexpr (requires { icp.solver.gauss_newton_steps; })
      if (params.solver_gauss_newton_steps)
        icp.solver.gauss_newton_steps = *params.solver_gauss_newton_steps;
  }

  /// Processes one scan given in the robot frame, with the robot's odometry pose when known.
  /// Without odometry the last correction alone is the initial guess (constant pose).
  template <PointCloudOf<D> C>
  MapperUpdate<D, Scalar> process(const C& scan,
                                  const std::optional<transform_type>& odometry = std::nullopt) {
    constexpr std::string_view where = "IncrementalMapper::process";
    if (odometry && !is_rigid(*odometry, rigid_tolerance<Scalar>))
      detail::throw_invalid(where, "argument 'odometry' is not a finite rigid transform");
    MapperUpdate<D, Scalar> update;
    transform_type guess = pose_;
    transform_type increment = transform_type::Identity();
    const bool has_increment = odometry && last_odometry_;
    if (has_increment) {
      increment = last_odometry_->inverse(Eigen::Isometry) * *odometry;
      guess = pose_ * increment;
    }
    if (odometry) last_odometry_ = *odometry;
    update.initial_guess = guess;
    update.pose = guess;
    // The odometry prediction's information (no odometry: the noise model's floors, those of
    // a zero increment; they only keep the information finite, see below).
    std::optional<lie::PoseMatrix<D, Scalar>> odometry_covariance, odometry_information;
    if (const auto noise = odometry_noise()) {
      odometry_covariance = noise->template covariance<D>(increment);
      odometry_information = odometry_covariance->inverse().eval();
      update.information = odometry_information;
    }
    // The prediction's information: an extended Kalman filter's prediction step (Thrun,
    // Burgard & Fox, Probabilistic Robotics, Table 3.3, line 3) in the body frame,
    // Σ̄ = Ad(u⁻¹) Σ Ad(u⁻¹)ᵀ + Σ_u, with Σ the previous pose's covariance relative to the map
    // and Σ_u the increment u's. Where the scans leave a direction free for several steps (a
    // corridor's axis), Σ grows along it, and a registration that observes it at all, weakly
    // but scan after scan, takes it over from the odometry (see the completion below).
    std::optional<lie::PoseMatrix<D, Scalar>> prediction_information = odometry_information;
    if (odometry_information && has_increment && pose_covariance_) {
      const lie::PoseMatrix<D, Scalar> ad =
          lie::se_adjoint<D, Scalar>(increment.inverse(Eigen::Isometry));
      prediction_information =
          (ad * *pose_covariance_ * ad.transpose() + *odometry_covariance).inverse().eval();
    }
    // Without a registration the pose is the prediction, and so is its covariance.
    if (prediction_information) pose_covariance_ = prediction_information->inverse().eval();

    if (params.voxel_size > Scalar(0)) {
      const auto filtered =
          voxel_downsample(scan, static_cast<traits::scalar_t<C>>(params.voxel_size));
      finite_.clear();
      finite_.reserve(filtered.size());
      for (const auto& p : filtered)
        finite_.push_back(p.template cast<Scalar>());
    } else {
      finite_.clear();
      const std::size_t n = traits::size(scan);
      for (std::size_t i = 0; i < n; ++i) {
        const point_type p = traits::point(scan, i).template cast<Scalar>();
        if (p.allFinite()) finite_.push_back(p);
      }
    }
    // What a key frame adds to the map: the scan, or its voxel filter (insert_downsampled).
    const auto insert_into_map = [&](const transform_type& pose) {
      if (params.insert_downsampled && params.voxel_size > Scalar(0)) {
        // The map ICP's last pairs name, for most scan points, a map point within a few cm:
        // hints for Eq. (5)'s test (the map has not changed since; same points stored).
        hints_.assign(finite_.size(), map_type::no_hint);
        if constexpr (requires { icp.correspondences(); })
          if (update.icp)
            for (const auto& c : icp.correspondences())
              hints_[c.data_index] = c.model_index;
        return map_.insert(finite_, pose, hints_);
      }
      return map_.insert(scan, pose);
    };

    if (map_.empty()) {
      // D_0 is the model M_0 (its frame is the map frame unless odometry was given before).
      update.inserted = insert_into_map(guess);
      if (!map_.empty()) {
        key_frames_.accept(guess);
        update.key_frame = true;
        update.registration_accepted = true;
      }
      pose_ = guess;
      ++scans_;
      return update;
    }

    if (finite_.empty()) {
      pose_ = guess;
      previous_accepted_ = false;
      ++scans_;
      return update;
    }
    // Whether a pose lies within hypothesis_distance / hypothesis_angle of the constant-velocity
    // prediction (true before there is one).
    const auto near_velocity_guess = [&](const transform_type& pose) {
      if (!last_motion_) return true;
      const transform_type diff = pose.inverse(Eigen::Isometry) * (pose_ * *last_motion_);
      return diff.translation().norm() <= params.hypothesis_distance &&
             std::abs(rotation_angle(diff)) <= params.hypothesis_angle;
    };
    // Odometry that froze and then jumps (real logs have both) claims a motion the constant-
    // velocity prediction contradicts; the scan-to-scan alignment then tries both (below).
    const bool odometry_consistent = near_velocity_guess(guess);
    // Whether a pose agrees with the odometry prediction: its χ² under the noise model is within
    // odometry_gate_chi2 (always true without an odometry increment and a noise model).
    const auto agrees = [&](const transform_type& pose) {
      if (!has_increment || !odometry_information) return true;
      const lie::PoseTangent<D, Scalar> e =
          lie::se_log<D, Scalar>(update.initial_guess.inverse(Eigen::Isometry) * pose);
      return e.dot(*odometry_information * e) <= params.odometry_gate_chi2;
    };
    if (params.match_previous_scan) {
      if (previous_.size() >= std::size_t(10)) {
        const auto usable_s2s = [](const IcpResult<D, Scalar>& r) {
          return r.reason != IcpTermination::too_few_pairs &&
                 r.reason != IcpTermination::degenerate;
        };
        // ICP pairs every data point with a model point, so the data must be the scan whose
        // view the other one covers. Driving towards where the scanner looks (the mean
        // direction of the previous scan's returns), that is the new scan. Reversing, the new
        // scan sees beside the robot what the previous one had behind it, and those points
        // would pair with the ends of the same walls and pull the scan back along them: the
        // previous scan is aligned to the new one instead, and the result inverted. Reversing
        // means by more than the odometry's translation uncertainty (the distance its χ² gate
        // accepts): a robot standing still jitters either way.
        const Scalar backwards =
            has_increment && odometry_information
                ? std::sqrt(params.odometry_gate_chi2 / (*odometry_information)(0, 0))
                : Scalar(0);
        const bool reversing =
            (pose_.inverse(Eigen::Isometry) * guess).translation().dot(previous_facing_) <
            -backwards * previous_facing_.norm();
        const KdTree<D, Scalar> model(reversing ? finite_ : previous_);
        const auto align_to_previous = [&](const transform_type& at) {
          if (!reversing) return previous_scan_icp.align(model, finite_, at);
          auto r = previous_scan_icp.align(model, previous_, at.inverse(Eigen::Isometry));
          r.transform = r.transform.inverse(Eigen::Isometry);
          return r;
        };
        auto best = align_to_previous(guess);
        // Odometry that froze and then jumps (CSAIL has both) makes the odometry guess wrong
        // by the whole frozen motion: when the constant-velocity guess differs, try it too and
        // keep the alignment that matches more points.
        if (!odometry_consistent) {
          auto other = align_to_previous(pose_ * *last_motion_);
          if (usable_s2s(other) && (!usable_s2s(best) || other.fitness > best.fitness))
            best = other;
        }
        if (usable_s2s(best)) {
          guess = best.transform;
          update.previous_scan_guess = guess;
        }
      }
    }
    if constexpr (uses_normals) icp.solver.model_normals = map_.normals();
    update.icp = icp.align(map_.search(), finite_, guess);
    const auto usable = [&](const IcpResult<D, Scalar>& result) {
      return (result.reason == IcpTermination::converged ||
              result.reason == IcpTermination::max_iterations ||
              (result.reason == IcpTermination::degenerate && params.accept_degenerate &&
               result.smallest_eigenvalue.has_value())) &&
             result.fitness >= params.min_fitness;
    };
    {
      const auto& r = *update.icp;
      const transform_type correction = guess.inverse(Eigen::Isometry) * r.transform;
      bool plausible = correction.translation().norm() <= params.max_correction_distance &&
                       std::abs(rotation_angle(correction)) <= params.max_correction_angle;
      // After a large motion the scan-to-scan or the map registration can slide into a wrong
      // minimum; the odometry is an independent witness (its prediction agrees with a pose
      // when the χ² under the noise model is within odometry_gate_chi2):
      //  - a map result beyond the limits is kept when it agrees and the scan-to-scan one does
      //    not (that one slid);
      //  - a map result that disagrees is compared with the map registration run once more
      //    from the odometry guess, which replaces it when it agrees, unless the map result
      //    pairs more scan points beyond chance (witness_significance): odometry that froze
      //    agrees with neither a good match nor, at a clearly better fitness, a bad one. A
      //    few more pairs are no evidence: a registration that slid back along a corridor
      //    pairs the scan's farthest points, which from the true pose lie beyond the mapped
      //    part (tools/corridor_drift with boxes and 0.5 m steps: 160 vs 158 pairs, and the
      //    robot ended 2.9 m behind when the 160 won).
      if (has_increment && odometry_information) {
        if (agrees(r.transform)) {
          if (!plausible && update.previous_scan_guess && !agrees(*update.previous_scan_guess))
            plausible = true;
        } else {
          witness_icp_ = icp;  // the same settings; its pairs stay apart from icp's
          auto from_odometry = witness_icp_.align(map_.search(), finite_, update.initial_guess);
          if (usable(from_odometry) && agrees(from_odometry.transform) &&
              (!(usable(r) && plausible) || !pairs_more(r, from_odometry))) {
            update.icp = std::move(from_odometry);
            std::swap(icp, witness_icp_);  // information_of() reads icp's last pairs
            plausible = true;
          }
        }
      }
      update.registration_accepted = usable(*update.icp) && plausible;
    }
    const auto& r = *update.icp;
    if (update.registration_accepted) {
      update.pose = r.transform;
      if (odometry_information) {
        const lie::PoseMatrix<D, Scalar> info = information_of(r.transform);
        // The increment's covariance by the model as given (the one in use when uncalibrated).
        const lie::PoseMatrix<D, Scalar> given_covariance =
            params.calibrate_odometry_noise
                ? params.odometry_noise->template covariance<D>(increment)
                : *odometry_covariance;
        if (has_increment && previous_accepted_ && params.calibrate_odometry_noise)
          calibrate(increment, r.transform, info, *odometry_covariance, given_covariance);
        const auto fused =
            complete<D, Scalar>(r.transform, info, update.initial_guess, *prediction_information);
        // The reported information is the registration's plus the increment's either way:
        // along what the scan leaves free, the pose is no better known than the odometry says.
        // The increment's is the model's as given, not as calibrated: the calibration fits the
        // odometry's typical step (its median leaves out the registrations that slid), and
        // the pose graph's chain and the loop search's windows must not become that stiff
        // where a registration slid unnoticed. The filter's covariance (relative to the map)
        // is the posterior's, (Ω + Σ̄⁻¹)⁻¹.
        update.information = (info + given_covariance.inverse()).eval();
        pose_covariance_ = fused.information.inverse().eval();
        if (!has_increment) {
          // No odometry: no prediction to fuse with or to disagree with. The information is
          // the registration's plus the noise model's floors (those of a step in place). Taken
          // as a disagreement with "no motion", every step would widen the covariance by its
          // own length, and the loop search's windows with it.
        } else if (fused.chi2 <= params.odometry_gate_chi2) {
          // The gate alone decides: odometry that froze or jumped disagrees with the match
          // beyond it. (A veto by the constant-velocity prediction would be self-referential:
          // an estimate held back in a corridor predicts no motion and refuses the odometry
          // that would free it.)
          if (params.fuse_odometry) {
            update.pose = fused.pose;
            update.odometry_fused = true;
          }
        } else {
          // The registration and the odometry disagree, and one of them is wrong (a local
          // minimum of ICP after a large motion, or odometry that froze): the pose is the
          // registration's, and its covariance spans the disagreement e (Σ + e eᵀ, the spread
          // of the two hypotheses), so that the pose graph and the loop search allow for it.
          const lie::PoseTangent<D, Scalar> e =
              lie::se_log<D, Scalar>(r.transform.inverse(Eigen::Isometry) * update.initial_guess);
          const lie::PoseMatrix<D, Scalar> cov =
              update.information->ldlt().solve(lie::PoseMatrix<D, Scalar>::Identity()) +
              e * e.transpose();
          if (cov.allFinite()) update.information = cov.inverse().eval();
          pose_covariance_ = (*pose_covariance_ + e * e.transpose()).eval();
        }
      }
    } else if (update.previous_scan_guess &&
               (agrees(*update.previous_scan_guess) ||
                (!odometry_consistent && near_velocity_guess(*update.previous_scan_guess)))) {
      // The map registration failed: the scan-to-scan alignment stands in for it where a
      // motion prediction confirms it, the odometry's noise model or, where the odometry froze
      // or jumped, the constant-velocity prediction. Unconfirmed it is no evidence against the
      // odometry (a scan with a handful of returns pairs anywhere, tens of degrees off), and
      // the odometry prediction is kept.
      update.pose = *update.previous_scan_guess;
      // Confirmed by the odometry, it is completed by the prediction as the map registration
      // is above: along what the previous scan leaves free (a bare corridor's axis) its answer
      // is a slide, not a measurement (a scan that sees farther ahead pairs with the ends of
      // the previous scan's walls and is pulled back along them), and there the odometry
      // carries the pose. In tools/corridor_drift (bare walls, 0.5 m steps, 30 m range) the
      // slides added up to 1.2 m where the odometry was 0.24 m off.
      if (has_increment && odometry_information && params.fuse_odometry && agrees(update.pose)) {
        const auto completed =
            complete<D, Scalar>(update.pose, previous_scan_information(update.pose),
                                update.initial_guess, *prediction_information);
        if (completed.chi2 <= params.odometry_gate_chi2) update.pose = completed.pose;
      }
    }
    previous_accepted_ = update.registration_accepted;
    last_motion_ = pose_.inverse(Eigen::Isometry) * update.pose;
    pose_ = update.pose;
    if (params.match_previous_scan) {
      // The scan in the map frame, and the way the scanner looks: the mean direction of its
      // returns (robot frame).
      previous_.clear();
      previous_facing_.setZero();
      for (const auto& p : finite_) {
        previous_.push_back(pose_ * p);
        if (const Scalar range = p.norm(); range > Scalar(0)) previous_facing_ += p / range;
      }
    }
    if (update.registration_accepted && key_frames_.update(pose_)) {
      update.inserted = insert_into_map(pose_);
      update.key_frame = true;
    }
    ++scans_;
    return update;
  }

  /// The map built so far (the key frames' points, map frame).
  [[nodiscard]] const SparsePointMap<D, Scalar, Index>& map() const { return map_; }
  /// The last scan's pose in the map frame (identity before the first scan).
  [[nodiscard]] const transform_type& pose() const { return pose_; }
  /// The odometry noise model in use: IncrementalMapperParams::odometry_noise as calibrated so
  /// far (unset without one).
  [[nodiscard]] std::optional<OdometryNoise<Scalar>> odometry_noise() const {
    if (!params.odometry_noise) return std::nullopt;
    OdometryNoise<Scalar> n = *params.odometry_noise;
    n.translation_per_meter *= noise_root_[0];
    n.translation_floor *= noise_root_[0];
    n.rotation_per_radian *= noise_root_[1];
    n.rotation_per_meter *= noise_root_[1];
    n.rotation_floor *= noise_root_[1];
    return n;
  }
  /// Number of scans given to the mapper so far.
  [[nodiscard]] std::size_t scans_processed() const { return scans_; }
  /// The finite (voxel-filtered, with voxel_size) points of the last scan, in the robot frame:
  /// what a key frame inserts into the map.
  [[nodiscard]] const std::vector<point_type>& last_points() const { return finite_; }

  /// Empties the map (the next scan is matched against what add_to_map() puts back; with an
  /// empty map the next scan starts a new one). The pose and the odometry are kept.
  void clear_map() {
    map_ = map_type(with_normals(params.map));
    key_frames_ = KeyFrameSelector<D, Scalar>(params.key_frames);
  }
  /// Inserts `cloud` (robot frame) at `pose` into the map by Eq. (5), as a key frame would be.
  template <PointCloudOf<D> C>
  SparseInsertStats add_to_map(const C& cloud, const transform_type& pose) {
    const auto stats = map_.insert(cloud, pose);
    key_frames_.accept(pose);
    return stats;
  }
  /// Moves the map frame: the current pose becomes `pose` and what the mapper remembers in the
  /// map frame (the previous scan) moves with it. For a SLAM back end that re-anchors the
  /// trajectory after optimising it (call clear_map() / add_to_map() to move the map too).
  void set_pose(const transform_type& pose) {
    if (!is_rigid(pose, Scalar(std::is_same_v<Scalar, float> ? 1e-3 : 1e-6)))
      detail::throw_invalid("IncrementalMapper::set_pose",
                            "argument 'pose' is not a finite rigid transform");
    const transform_type correction = pose * pose_.inverse(Eigen::Isometry);
    for (auto& p : previous_)
      p = correction * p;
    pose_ = pose;
  }

 private:
  // The registration's information from the map ICP's final pairs and the map's normals (PCA
  // of the map's nearest points when the map keeps none), kept along the directions it
  // observes: those reaching icp.params.degeneracy_ratio of the strongest, as
  // IcpResult::information does. Below that the information comes from the normals' noise,
  // not from the geometry: on the bare walls of a simulated corridor it reached 4e-4 of the
  // strongest along the axis, as much as the odometry's there, while the match was 0.5 m off
  // along it (tools/corridor_drift, docs/mapping.md).
  lie::PoseMatrix<D, Scalar> information_of(const transform_type& transform) {
    if constexpr (requires { icp.correspondences(); }) {
      const auto pairs = icp.correspondences();
      return observed_information(full_information_of(pairs, transform), pairs);
    } else {
      return lie::PoseMatrix<D, Scalar>::Zero();
    }
  }

  // Whether the map registration `r` (icp's last pairs) pairs more scan points than `witness`
  // (witness_icp_'s) beyond chance, at witness_significance; by fitness alone when the ICP
  // does not keep its pairs.
  bool pairs_more([[maybe_unused]] const IcpResult<D, Scalar>& r,
                  [[maybe_unused]] const IcpResult<D, Scalar>& witness) const {
    if constexpr (requires { icp.correspondences(); }) {
      return detail::pairs_more_beyond_chance<D, Scalar>(
          icp.correspondences(), witness_icp_.correspondences(), finite_.size(),
          static_cast<double>(params.witness_significance));
    } else {
      return r.fitness > witness.fitness;
    }
  }

  // The information of the scan at `pose` against the previous scan (previous_, map frame):
  // each scan point paired with its nearest previous point within final_match_distance, the
  // normals from the PCA of the previous scan's points, kept along the directions it observes
  // as information_of() does.
  lie::PoseMatrix<D, Scalar> previous_scan_information(const transform_type& pose) {
    const KdTree<D, Scalar> previous(previous_);
    const Scalar bound_sq = params.final_match_distance * params.final_match_distance;
    previous_pairs_.clear();
    for (std::size_t i = 0; i < finite_.size(); ++i)
      if (const auto nb = previous.nearest(pose * finite_[i], bound_sq))
        previous_pairs_.push_back({finite_[i], previous.point(nb->index), nb->distance_sq,
                                   static_cast<std::uint32_t>(i), nb->index});
    const lie::PoseMatrix<D, Scalar> full = registration_information<D, Scalar>(
        previous_pairs_, pose,
        [&](const Correspondence<D, Scalar>& c) {
          return pca_normal<D, Scalar>(previous, c.model, normal_neighbors, knn_);
        },
        params.sensor_sigma);
    return observed_information(full, previous_pairs_);
  }

  // `full` kept along the directions it observes (icp.params.degeneracy_ratio, see
  // information_of()), when the ICP has that setting.
  lie::PoseMatrix<D, Scalar> observed_information(
      const lie::PoseMatrix<D, Scalar>& full, std::span<const Correspondence<D, Scalar>> pairs) {
    if constexpr (requires { icp.params.degeneracy_ratio; })
      if (const auto observed =
              detail::observed_part<D, Scalar>(full, pairs, icp.params.degeneracy_ratio))
        return *observed;
    return full;
  }

  // All of it (registration_information(), pose_uncertainty.hpp).
  lie::PoseMatrix<D, Scalar> full_information_of(std::span<const Correspondence<D, Scalar>> pairs,
                                                 const transform_type& transform) {
    if constexpr (uses_normals) {
      const auto& normals = map_.normals();
      return registration_information<D, Scalar>(
          pairs, transform,
          [&](const Correspondence<D, Scalar>& c) {
            return c.model_index < normals.size() ? normals[c.model_index]
                                                  : point_type::Zero().eval();
          },
          params.sensor_sigma);
    } else {
      return registration_information<D, Scalar>(
          pairs, transform,
          [&](const Correspondence<D, Scalar>& c) {
            return pca_normal<D, Scalar>(map_.search(), c.model, normal_neighbors, knn_);
          },
          params.sensor_sigma);
    }
  }

  // Online calibration of the odometry noise model by covariance matching (Mehra 1972,
  // "Approaches to adaptive filtering", IEEE TAC 17(5); Mohamed & Schwarz 1999, INS/GPS: the
  // noise covariance scaled so that the innovations' spread matches it). A sample is one
  // component k of the step error e = log((T_{i-1} u)⁻¹ T_i) between the odometry increment u
  // and an accepted registration T_i following an accepted one, where the registration's
  // variance of k (its information inverted; a direction the scan leaves free has none) is
  // below the model's: there e_k is mostly the odometry's error. Under the user's model Σ_u,
  // z = e_k² / Σ_u(k,k) is χ²(1)-distributed times the factor s by which the model is off, so
  // s = median(z) / 0.4549 (the χ²(1) median); the median ignores the registrations that slid.
  // Steps within the model's floors are left out: a robot standing still has exact odometry,
  // which says nothing of its error in motion. Translation and rotation get a factor each, and
  // every σ term of the model is scaled by its square root (the factor kept within 10⁻⁴..10⁴,
  // so that exact odometry cannot collapse the model to zero).
  // `model` and `prior` are the increment's covariances by the model in use and as given.
  void calibrate(const transform_type& increment, const transform_type& registered,
                 const lie::PoseMatrix<D, Scalar>& info, const lie::PoseMatrix<D, Scalar>& model,
                 const lie::PoseMatrix<D, Scalar>& prior) {
    const OdometryNoise<Scalar>& given = *params.odometry_noise;
    if (increment.translation().norm() <= given.translation_floor &&
        std::abs(rotation_angle(increment)) <= given.rotation_floor)
      return;
    const Eigen::LLT<lie::PoseMatrix<D, Scalar>> llt(info);
    if (llt.info() != Eigen::Success) return;
    const lie::PoseMatrix<D, Scalar> registration_covariance =
        llt.solve(lie::PoseMatrix<D, Scalar>::Identity());
    const lie::PoseTangent<D, Scalar> e =
        lie::se_log<D, Scalar>((pose_ * increment).inverse(Eigen::Isometry) * registered);
    std::array<bool, 2> changed{false, false};
    for (int k = 0; k < lie::pose_dof<D>; ++k) {
      if (!(registration_covariance(k, k) < model(k, k))) continue;
      const std::size_t g = k < D ? 0 : 1;  // translation, rotation
      auto& samples = calibration_[g];
      const Scalar z = e(k) * e(k) / prior(k, k);
      if (samples.size() < params.calibration_window)
        samples.push_back(z);
      else
        samples[next_sample_[g]] = z;
      next_sample_[g] = (next_sample_[g] + 1) % params.calibration_window;
      changed[g] = true;
    }
    for (std::size_t g = 0; g < 2; ++g) {
      if (!changed[g] || calibration_[g].size() < std::size_t(30)) continue;
      median_scratch_ = calibration_[g];
      const auto mid = median_scratch_.begin() + std::ptrdiff_t(median_scratch_.size() / 2);
      std::nth_element(median_scratch_.begin(), mid, median_scratch_.end());
      noise_root_[g] = std::sqrt(std::clamp(*mid / Scalar(0.4549), Scalar(1e-4), Scalar(1e4)));
    }
  }

  static SparsePointMapParams<Scalar> with_normals(SparsePointMapParams<Scalar> p) {
    if constexpr (uses_normals) p.normals = true;
    return p;
  }

  using map_type = SparsePointMap<D, Scalar, Index>;
  map_type map_;
  KeyFrameSelector<D, Scalar> key_frames_;
  transform_type pose_ = transform_type::Identity();
  std::optional<transform_type> last_odometry_;
  std::size_t scans_ = 0;
  std::vector<point_type> finite_;
  std::vector<std::uint32_t> hints_;                 ///< map point near each of finite_ (the ICP's)
  std::vector<point_type> previous_;                 ///< the previous scan in the map frame
  point_type previous_facing_ = point_type::Zero();  ///< its returns' summed directions
  std::optional<transform_type> last_motion_;        ///< pose change of the last scan
  /// With an odometry noise model: the pose's covariance relative to the map (the filter of
  /// process(); absent before the first registration).
  std::optional<lie::PoseMatrix<D, Scalar>> pose_covariance_;
  /// Neighbours of a PCA normal where the points keep none (the map's or the previous scan's).
  static constexpr std::size_t normal_neighbors = D == 2 ? 5 : 10;
  std::vector<Neighbor<Scalar>> knn_;                      ///< scratch of information_of()
  std::vector<Correspondence<D, Scalar>> previous_pairs_;  ///< previous_scan_information()
  IcpType witness_icp_{};  ///< the map registration from the odometry guess
  std::array<Scalar, 2> noise_root_{Scalar(1), Scalar(1)};  ///< calibrate()'s σ factors
  bool previous_accepted_ = false;                  ///< the last scan's registration was accepted
  std::array<std::vector<Scalar>, 2> calibration_;  ///< calibrate()'s samples (ring buffers)
  std::array<std::size_t, 2> next_sample_{0, 0};    ///< where each ring buffer writes next
  std::vector<Scalar> median_scratch_;
};

/// The map ICP of the 2D laser setup: point-to-line against the map's normals, decaying
/// distance threshold (no unique-pair rejection: with point-to-line it lost accuracy on CSAIL).
template <std::floating_point Scalar = double>
using LaserIcp = BasicIcp<2, Scalar, PointToLineSolver<Scalar>, DecayingDistanceRejector<Scalar>>;

/// The documented configuration for 2D laser SLAM (0.061 m mean relation error on the MIT CSAIL
/// benchmark log without loop closure; figures in docs/benchmarks.md): scan-to-scan
/// pre-alignment with the constant-velocity hypothesis, point-to-line map registration with a
/// 0.5 -> 0.2 m threshold (straight to 0.2 m once the registration has converged under a wider
/// one: skip_decay_when_converged) and up to 10 Gauss-Newton steps per ICP iteration (each solve
/// runs to convergence instead of stopping after the solver's default 3), key frames every 0.25 m /
/// 10°, eps_D = 0.15 m, and map corrections of the scan-to-scan result above 0.5 m / 3° rejected
/// (the scan-to-scan result is kept: in clutter the map registration's rotation is the less
/// reliable one).
template <std::floating_point Scalar = double>
[[nodiscard]] IncrementalMapperParams<Scalar> laser_slam_params() {
  IncrementalMapperParams<Scalar> p;
  p.match_previous_scan = true;
  p.initial_match_distance = Scalar(0.5);
  p.final_match_distance = Scalar(0.2);
  p.skip_decay_when_converged = true;
  p.key_frames.min_distance = Scalar(0.25);
  p.key_frames.min_angle = Scalar(10) * std::numbers::pi_v<Scalar> / 180;
  p.max_correction_distance = Scalar(0.5);
  p.max_correction_angle = Scalar(3) * std::numbers::pi_v<Scalar> / 180;
  // Only numerically singular directions stay at the start: the start is a relative estimate
  // (the scan-to-scan result), so holding a weakly observed direction there (a corridor with a
  // few door frames) adds its error at every scan, a random walk, while the map's weak
  // constraint is absolute. Where odometry is fused, complete() (pose_uncertainty.hpp) still
  // hands the odometry every direction the registration's information constrains less than
  // the odometry's does.
  p.solver_degeneracy_ratio = Scalar(1e-6);
  p.solver_gauss_newton_steps = 10;
  return p;
}

/// IncrementalMapper in the 2D laser setup: point-to-line registration (LaserIcp) and, when
/// default-constructed, laser_slam_params(). It tracks the whole log against one growing map
/// (LaserSlam adds submaps, loop closure and a pose graph).
template <std::floating_point Scalar = double>
class LaserSlamMapper : public IncrementalMapper<2, Scalar, LaserIcp<Scalar>> {
 public:
  /// The 2D laser configuration, laser_slam_params().
  LaserSlamMapper() : LaserSlamMapper(laser_slam_params<Scalar>()) {}
  /// A configuration of one's own (validated; throws invalid_argument for bad params).
  explicit LaserSlamMapper(IncrementalMapperParams<Scalar> p)
      : IncrementalMapper<2, Scalar, LaserIcp<Scalar>>(p) {}
};

}  // namespace rangenav
