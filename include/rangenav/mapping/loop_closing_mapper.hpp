#pragma once
// Loop-closing SLAM over an incremental front end, one code path for 2D scans and 3D clouds
// (paper 000 §3.4: "larger loops ... would require post-processing such as global relaxation
// using e.g. Lu-Milios-like approaches or graph-based optimization"; the structure follows Hess,
// Kohler, Rapp, Andor 2016, "Real-time loop closure in 2D LIDAR SLAM"):
//
//   front end    IncrementalMapper with an odometry noise model: every scan is registered and
//                fused with the odometry prediction by information (pose_uncertainty.hpp);
//   key frames   the front end's key frames are the pose-graph nodes; consecutive ones are
//                joined by an edge with the registration's covariance plus the front end's
//                drift over the step (LoopClosureParams::front_end_drift);
//   submaps      every `submap_key_frames` consecutive key frames form a submap: a sparse point
//                map (paper 000 Eq. (5)) in the frame of its first key frame (its anchor node).
//                The front end tracks against a local map of the last finished submap and the
//                current one (rebuilt when a submap finishes), so a revisit is never matched
//                implicitly against the drifted old map: it becomes an explicit loop closure;
//   loop search  a key frame is a loop candidate of a finished, non-adjacent submap when one of
//                the submap's key frames lies within the search window plus `overlap_distance`
//                of it; the window is `window_sigmas` standard deviations of the uncertainty
//                accumulated since the last loop constraint (the key-frame steps' covariances
//                propagated by the SE(D) adjoint), so it grows with the distance driven; the
//                2D matcher searches the bounding box of its ellipse in the submap's frame;
//   matching     2D: the branch-and-bound correlative matcher (correlative_scan_matcher.hpp)
//                searches the window for the best pose of the key frame's scan in the submap
//                (Hess et al. §V), rejected below `min_score` and when a second, distinct pose
//                scores nearly as well (an ambiguous, look-alike place; Olson 2009 §IV); then
//                ICP refines it against the submap's points. 3D: ICP from the predicted pose,
//                the result gated by the window's χ²;
//   acceptance   the ICP converged, is not degenerate, pairs at least `min_fitness` of the scan
//                and stays within a cell and an angular step of the matcher's pose;
//   back end     the accepted loop edge enters the pose graph from the submap's key frame
//                nearest the match (its pose in the submap as built) to the key frame, with the
//                ICP's information widened by the submap's drift relative to that key frame (the
//                chain from the anchor stays the graph's to bend; an edge from the anchor would
//                repeat that drift in every loop edge into the submap), and a Cauchy kernel whose
//                scale is the χ² quantile of an inlier, so a wrong closure that passed verification
//                is down-weighted instead of bending the map; the graph is optimised when a new
//                loop edge disagrees with the estimate, and the submaps, the trajectory and the
//                front end's local map are re-anchored to the optimised poses.
//
// Every scan's pose is kept relative to the key frame before it, so trajectory() returns the
// whole trajectory re-anchored to the optimised key frames. Nothing depends on timestamps.

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/robust_kernel.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/mapping/incremental_mapper.hpp"
#include "rangenav/mapping/pose_uncertainty.hpp"
#include "rangenav/mapping/sparse_point_map.hpp"
#include "rangenav/pose_graph/pose_graph.hpp"
#include "rangenav/registration/correlative_scan_matcher.hpp"

namespace rangenav {

/// Parameters of the loop closure (the reason of each default is given beside it).
template <std::floating_point Scalar = double>
struct LoopClosureParams {
  /// false: the front end alone (key frames and the pose graph's chain are still kept).
  bool enabled = true;
  /// Key frames per submap. Enough for a submap to show a place from several viewpoints (at
  /// key frames every 0.25 m, 5 m of travel), few enough that its own drift stays within the
  /// ICP's final pairing distance.
  std::size_t submap_key_frames = 20;
  /// The front end's error beyond the registration's own covariance, per key-frame step: a
  /// scan-to-map tracker drifts by about 1 % of the distance and of the angle turned plus
  /// ~0.5°/m (sequential scan matching on the Freiburg benchmark logs, Kümmerle et al. 2009,
  /// ~1 % relative error), with small floors for a step in place.
  OdometryNoise<Scalar> front_end_drift{Scalar(0.01), Scalar(0.002), Scalar(0.01),
                                        Scalar(0.5) * std::numbers::pi_v<Scalar> / 180,
                                        Scalar(0.05) * std::numbers::pi_v<Scalar> / 180};
  /// The search window is this many standard deviations of the accumulated uncertainty.
  Scalar window_sigmas = Scalar(3);
  /// Bounds of the linear half-window (m): at least the ICP's pairing basin; at most what the
  /// correlative search affords per candidate (the angular half-window is bounded by π).
  Scalar min_window_linear = Scalar(0.5);
  /// Upper bound of the linear half-window (m), see min_window_linear.
  Scalar max_window_linear = Scalar(10);
  /// Lower bound of the angular half-window (rad). The drift model is an average: in one stretch
  /// of turns on the spot the front end can lose several degrees more (11° on a freiburg-079
  /// run, docs/benchmarks.md), and a window narrower than the heading error never finds the
  /// place again. 15° covers that; Cartographer's constraint builder searches ±30° around
  /// every prediction. The wider floor costs a few per cent more matcher work where it applies
  /// (docs/mapping.md).
  Scalar min_window_angular = Scalar(15) * std::numbers::pi_v<Scalar> / 180;
  /// A submap is a candidate when one of its key frames lies within the window plus this of the
  /// key frame (m): from a few metres away indoors a scan sees most of what the submap saw.
  Scalar overlap_distance = Scalar(2);
  /// Candidates tried per key frame (nearest first).
  std::size_t max_candidates = 2;
  /// The correlative matcher's grid (2D).
  CorrelativeScanMatcherParams<Scalar> matcher{};
  /// Minimum correlative score (mean likelihood of the scan's points): about half of the scan
  /// must lie on the submap's structure (Cartographer's constraint builder uses 0.55).
  Scalar min_score = Scalar(0.55);
  /// A second pose farther than `ambiguity_distance` (m) from the best that scores at least
  /// this fraction of the best makes the match ambiguous (rejected).
  Scalar ambiguity_ratio = Scalar(0.9);
  /// Distance from the best pose beyond which a high-scoring second pose counts as a rival (m),
  /// see ambiguity_ratio.
  Scalar ambiguity_distance = Scalar(1);
  /// Minimum fraction of the scan the refining ICP pairs with the submap.
  Scalar min_fitness = Scalar(0.5);
  /// The ICP refinement may move the matcher's pose by at most this (m, rad); more means the
  /// two matchers disagree. 2D: two grid cells; the angle: two of the matcher's finest steps at
  /// 5 m, floored at 2°.
  Scalar max_refinement_distance = Scalar(0.3);
  /// Angle limit of the same test (rad), see max_refinement_distance.
  Scalar max_refinement_angle = Scalar(3) * std::numbers::pi_v<Scalar> / 180;
  /// Residual σ floor of a loop edge's information (m); see IncrementalMapperParams.
  Scalar sensor_sigma = Scalar(0.01);

  /// Throws invalid_argument naming the first parameter out of range.
  void validate() const {
    constexpr std::string_view where = "LoopClosureParams";
    if (submap_key_frames < 2)
      detail::throw_invalid_argument(where, "submap_key_frames", submap_key_frames, "must be >= 2");
    front_end_drift.validate();
    detail::require_positive(where, "window_sigmas", window_sigmas);
    detail::require_positive(where, "min_window_linear", min_window_linear);
    if (!(max_window_linear >= min_window_linear))
      detail::throw_invalid_argument(where, "max_window_linear", max_window_linear,
                                     "must be >= min_window_linear");
    detail::require_positive(where, "min_window_angular", min_window_angular);
    detail::require_non_negative(where, "overlap_distance", overlap_distance);
    matcher.validate();
    if (!(min_score >= 0 && min_score <= 1))
      detail::throw_invalid_argument(where, "min_score", min_score, "must be in [0, 1]");
    if (!(ambiguity_ratio > 0 && ambiguity_ratio <= 1))
      detail::throw_invalid_argument(where, "ambiguity_ratio", ambiguity_ratio,
                                     "must be in (0, 1]");
    detail::require_positive(where, "ambiguity_distance", ambiguity_distance);
    if (!(min_fitness >= 0 && min_fitness <= 1))
      detail::throw_invalid_argument(where, "min_fitness", min_fitness, "must be in [0, 1]");
    detail::require_positive(where, "max_refinement_distance", max_refinement_distance);
    detail::require_positive(where, "max_refinement_angle", max_refinement_angle);
    detail::require_positive(where, "sensor_sigma", sensor_sigma);
  }
};

/// A loop closure: the pose of key frame `node` in the frame of key frame `from`, the key frame
/// of submap `submap` nearest the matched pose.
template <int D, class Scalar = double>
struct LoopClosure {
  /// Index of the matched submap.
  std::size_t submap = 0;
  std::size_t from = 0;                                              ///< the submap's key frame
  std::size_t node = 0;                                              ///< the key frame's node
  Transform<D, Scalar> relative = Transform<D, Scalar>::Identity();  ///< from -> node
  /// Information of `relative` (body-frame perturbation, pose_uncertainty.hpp): the refining
  /// ICP's, widened by the submap's drift relative to `from`.
  lie::PoseMatrix<D, Scalar> information = lie::PoseMatrix<D, Scalar>::Identity();
  Scalar score = 0;    ///< correlative score (2D), 0 in 3D
  Scalar fitness = 0;  ///< the refining ICP's
};

/// Why loop candidates were rejected (counts over the run).
struct LoopStatistics {
  std::size_t candidates = 0;  ///< submaps matched against a key frame
  std::size_t low_score = 0;   ///< no pose reached min_score (2D)
  std::size_t ambiguous = 0;   ///< a distinct pose scored nearly as well (2D)
  std::size_t icp_failed = 0;  ///< the refining ICP did not converge or paired too little
  std::size_t disagreed = 0;   ///< the ICP moved too far from the matcher's pose / the window
  /// The submap spans more than the matcher's grids may (matcher.max_memory_bytes; 2D): it is
  /// not searched (a stray point hundreds of metres out, or a scanner of such range).
  std::size_t too_wide = 0;
  std::size_t accepted = 0;  ///< loop edges added
};

/// What the SLAM did with one scan.
template <int D, class Scalar = double>
struct SlamUpdate {
  MapperUpdate<D, Scalar> front_end;  ///< the front end's update (pose in its local frame)
  Transform<D, Scalar> pose = Transform<D, Scalar>::Identity();  ///< in the map frame
  std::optional<std::size_t> node;  ///< the key frame's node, when it became one
  std::size_t loop_closures = 0;    ///< loop edges accepted for this scan
  bool optimized = false;           ///< the pose graph was optimised after this scan
};

/// The loop-closing SLAM of the file comment over IncrementalMapper<D, Scalar, IcpType, Index>.
template <int D, std::floating_point Scalar = double, class IcpType = PaperIcp<D, Scalar>,
          class Index = DefaultMapIndex<D, Scalar>>
class LoopClosingMapper {
 public:
  using transform_type = Transform<D, Scalar>;                          ///< a pose
  using point_type = Point<D, Scalar>;                                  ///< a point
  using front_end_type = IncrementalMapper<D, Scalar, IcpType, Index>;  ///< the front end
  using map_type = SparsePointMap<D, Scalar, Index>;                    ///< a submap's map
  static constexpr int dof = lie::pose_dof<D>;                          ///< 3 or 6

  /// Front end and loop-closure parameters. The front end's odometry_noise is required (set to
  /// the default model, calibrated online, when absent): it is what the pose graph's edges are
  /// made of.
  LoopClosingMapper(IncrementalMapperParams<Scalar> front_end, LoopClosureParams<Scalar> loops)
      : loops_((loops.validate(), loops)), front_end_(with_noise(front_end)) {
    verify_icp_ = front_end_.icp;
  }

  /// Processes one scan (robot frame) with its odometry pose when known.
  template <PointCloudOf<D> C>
  SlamUpdate<D, Scalar> process(const C& scan,
                                const std::optional<transform_type>& odometry = std::nullopt) {
    SlamUpdate<D, Scalar> update;
    update.front_end = front_end_.process(scan, odometry);
    update.pose = update.front_end.pose;
    const auto& fe = update.front_end;
    if (fe.icp) failures_ = fe.registration_accepted ? 0 : failures_ + 1;
    // Lost: the registration failed twice in a row and the robot has moved a key frame's
    // distance since the last key frame. The scan becomes a key frame at the odometry's pose
    // (its edge carries the odometry's covariance) and starts a new submap and a fresh local
    // map, so tracking resumes from it; loop closure later ties the pieces together.
    const bool lost = !fe.key_frame && failures_ >= 2 && !nodes_.empty() &&
                      !front_end_.last_points().empty() && moved_a_key_frame(fe.pose);
    if (fe.key_frame || lost) {
      update.node = add_key_frame(update.front_end, lost);
      if (loops_.enabled) update.loop_closures = close_loops(*update.node);
      if (needs_optimization_) {
        optimize();
        update.optimized = true;
      }
      update.pose = nodes_[*update.node].pose;
    }
    // The scan's pose relative to the last key frame (re-anchored with it later).
    if (nodes_.empty())
      scans_.push_back({no_node, update.pose});
    else
      scans_.push_back(
          {nodes_.size() - 1, nodes_.back().pose.inverse(Eigen::Isometry) * update.pose});
    return update;
  }

  /// The χ² quantile (99 %) of an inlier loop edge's squared residual, 3 or 6 degrees of
  /// freedom: the scale² of the loop edges' Cauchy kernel, and the χ² beyond which a new loop
  /// edge triggers an optimisation.
  static constexpr Scalar inlier_chi2() { return D == 2 ? Scalar(11.34) : Scalar(16.81); }

  /// Optimises the pose graph once more if a loop edge was added since the last optimisation.
  void finish() {
    if (pending_loops_ > 0 || optimizations_ > 0) optimize(true);
  }

  /// The pose of every scan processed so far, re-anchored to the optimised key frames.
  [[nodiscard]] std::vector<transform_type> trajectory() const {
    std::vector<transform_type> out;
    out.reserve(scans_.size());
    for (const auto& s : scans_)
      out.push_back(s.node == no_node ? s.relative : nodes_[s.node].pose * s.relative);
    return out;
  }
  /// The key frames' (pose-graph nodes') poses.
  [[nodiscard]] std::vector<transform_type> key_frame_poses() const {
    std::vector<transform_type> out;
    for (const auto& n : nodes_)
      out.push_back(n.pose);
    return out;
  }
  /// The points of every submap (finished or not) in the map frame, at the optimised poses.
  [[nodiscard]] std::vector<point_type> map_points() const {
    std::vector<point_type> out;
    for (const auto& s : submaps_) {
      if (s.map) {
        const transform_type anchor = nodes_[s.anchor].pose;
        for (const auto& p : s.map->points())
          out.push_back(anchor * p);
      } else {
        for (std::size_t k = s.first; k < s.first + s.count; ++k)
          for (const auto& p : nodes_[k].points)
            out.push_back(nodes_[k].pose * p);
      }
    }
    return out;
  }
  /// The loop edges accepted so far.
  [[nodiscard]] const std::vector<LoopClosure<D, Scalar>>& loop_closures() const {
    return loop_closures_;
  }
  /// Loop candidates matched (each a correlative search in 2D, an ICP in 3D).
  [[nodiscard]] std::size_t loop_attempts() const { return stats_.candidates; }
  /// What became of the loop candidates.
  [[nodiscard]] const LoopStatistics& loop_statistics() const { return stats_; }
  /// Pose-graph optimisations run so far.
  [[nodiscard]] std::size_t optimizations() const { return optimizations_; }
  /// Key frames (pose-graph nodes) so far.
  [[nodiscard]] std::size_t key_frames() const { return nodes_.size(); }
  /// Submaps so far (the last one may be unfinished).
  [[nodiscard]] std::size_t submaps() const { return submaps_.size(); }
  /// The front end (its pose and map are in the map frame, re-anchored after optimisations).
  [[nodiscard]] const front_end_type& front_end() const { return front_end_; }
  /// The front end, to configure its ICP policies.
  [[nodiscard]] front_end_type& front_end() { return front_end_; }
  /// The loop-closure parameters.
  [[nodiscard]] const LoopClosureParams<Scalar>& params() const { return loops_; }
  /// The pose graph (key frames, chain and loop edges).
  [[nodiscard]] const PoseGraph<D, Scalar>& graph() const { return graph_; }
  /// The uncertainty accumulated since the last loop constraint (covariance of the last key
  /// frame's pose, body frame).
  [[nodiscard]] const lie::PoseMatrix<D, Scalar>& accumulated_covariance() const {
    return accumulated_;
  }

 private:
  static constexpr std::size_t no_node = std::numeric_limits<std::size_t>::max();

  struct Node {
    transform_type pose;
    std::vector<point_type> points;  ///< the key frame's scan (robot frame)
    std::size_t submap = 0;
    /// The chain edge from the key frame before: its step and covariance (in this frame).
    transform_type step = transform_type::Identity();
    lie::PoseMatrix<D, Scalar> step_covariance = lie::PoseMatrix<D, Scalar>::Zero();
  };
  struct Submap {
    std::size_t anchor = 0, first = 0, count = 0;
    std::unique_ptr<map_type> map;  ///< set when finished (anchor frame)
    /// The key frames' poses in the anchor's frame when the map was built (a loop edge's start).
    std::vector<transform_type> frames;
    /// Where a key frame last failed to close a loop with this submap (map frame).
    std::optional<point_type> failed_at;
    std::unique_ptr<CorrelativeScanMatcher<Scalar>> matcher;  ///< built on first use (2D)
    std::size_t last_used = 0;
  };
  struct ScanRecord {
    std::size_t node;         ///< the key frame before the scan (no_node: none yet)
    transform_type relative;  ///< the scan's pose in that key frame's frame (or the map's)
  };

  static IncrementalMapperParams<Scalar> with_noise(IncrementalMapperParams<Scalar> p) {
    if (!p.odometry_noise) {
      // The default model is a start only: calibrated to the robot's odometry as it drives.
      p.odometry_noise = OdometryNoise<Scalar>{};
      p.calibrate_odometry_noise = true;
    }
    return p;
  }

  bool moved_a_key_frame(const transform_type& pose) const {
    const auto& kf = front_end_.params.key_frames;
    const transform_type delta = nodes_.back().pose.inverse(Eigen::Isometry) * pose;
    return delta.translation().norm() > kf.min_distance ||
           std::abs(rotation_angle(delta)) > kf.min_angle;
  }

  std::size_t add_key_frame(const MapperUpdate<D, Scalar>& u, bool restart = false) {
    const std::size_t k = nodes_.size();
    if (restart) {
      if (!submaps_.empty() && !submaps_.back().map) finish_submap(submaps_.size() - 1, false);
      restarted_ = true;
      failures_ = 0;
    }
    const std::size_t submap =
        submaps_.empty() || submaps_.back().map ? submaps_.size() : submaps_.size() - 1;
    if (submap == submaps_.size()) {
      submaps_.push_back({});
      submaps_.back().anchor = k;
      submaps_.back().first = k;
    }
    nodes_.push_back({u.pose, front_end_.last_points(), submap});
    ++submaps_[submap].count;
    graph_.add_node(u.pose);
    const lie::PoseMatrix<D, Scalar> registration =
        u.information ? covariance_of(*u.information) : lie::PoseMatrix<D, Scalar>::Zero();
    if (k == 0) {
      accumulated_ = lie::PoseMatrix<D, Scalar>::Zero();
    } else {
      const transform_type step = nodes_[k - 1].pose.inverse(Eigen::Isometry) * u.pose;
      const lie::PoseMatrix<D, Scalar> cov =
          registration + loops_.front_end_drift.template covariance<D>(step);
      graph_.add_edge(k - 1, k, step, information_from_covariance<D, Scalar>(cov));
      nodes_[k].step = step;
      nodes_[k].step_covariance = cov;
      accumulated_ = propagate(accumulated_, step, cov);
    }
    if (restart) {
      front_end_.clear_map();
      front_end_.add_to_map(nodes_[k].points, nodes_[k].pose);
    }
    if (submaps_[submap].count >= loops_.submap_key_frames) finish_submap(submap);
    return k;
  }

  // Builds the finished submap's sparse map and makes the front end's local map that submap
  // (the current one is empty: it starts with the next key frame).
  void finish_submap(std::size_t index, bool track = true) {
    Submap& s = submaps_[index];
    auto params = front_end_.map().params();
    params.normals = true;
    s.map = std::make_unique<map_type>(params);
    const transform_type to_anchor = nodes_[s.anchor].pose.inverse(Eigen::Isometry);
    s.frames.clear();
    for (std::size_t k = s.first; k < s.first + s.count; ++k) {
      s.frames.push_back(to_anchor * nodes_[k].pose);
      s.map->insert(nodes_[k].points, s.frames.back());
    }
    if (!track) return;
    restarted_ = false;
    rebuild_local_map();
  }

  // The front end's map: the last finished submap and the current one, at the current poses.
  // After a restart (lost) the finished submap before it is left out until the next one
  // finishes: it is tied to the current one by odometry alone.
  void rebuild_local_map() {
    front_end_.clear_map();
    std::size_t first = nodes_.size();
    tracked_ = submaps_.size();
    for (std::size_t i = submaps_.size(); i-- > 0;) {
      if (submaps_[i].map && restarted_) break;
      first = submaps_[i].first;
      if (submaps_[i].map) {
        tracked_ = i;
        break;
      }
    }
    for (std::size_t k = first; k < nodes_.size(); ++k)
      front_end_.add_to_map(nodes_[k].points, nodes_[k].pose);
  }

  // Loop search and verification for key frame k (see the file comment); returns the number of
  // loop edges added.
  std::size_t close_loops(std::size_t k) {
    const Node& node = nodes_[k];
    const auto window = search_window();
    // Candidates: finished submaps, not the one the front end tracks against, with a key frame
    // near enough.
    std::vector<std::pair<Scalar, std::size_t>> candidates;
    for (std::size_t i = 0; i < submaps_.size(); ++i) {
      const Submap& s = submaps_[i];
      if (!s.map || i == tracked_ || i == node.submap) continue;
      Scalar nearest = std::numeric_limits<Scalar>::infinity();
      for (std::size_t j = s.first; j < s.first + s.count; ++j)
        nearest =
            std::min(nearest, (nodes_[j].pose.translation() - node.pose.translation()).norm());
      // A key frame close to one that just failed against this submap sees what that one saw:
      // it is skipped until the robot has moved half the overlap distance.
      if (s.failed_at &&
          (*s.failed_at - node.pose.translation()).norm() < loops_.overlap_distance / 2)
        continue;
      if (nearest <= window.linear + loops_.overlap_distance) candidates.push_back({nearest, i});
    }
    std::sort(candidates.begin(), candidates.end());
    if (candidates.size() > loops_.max_candidates) candidates.resize(loops_.max_candidates);
    std::size_t added = 0;
    for (const auto& [distance, i] : candidates) {
      ++stats_.candidates;
      auto closure = verify(i, k, window);
      submaps_[i].failed_at.reset();
      if (!closure) {
        submaps_[i].failed_at = node.pose.translation();
        continue;
      }
      const Scalar chi2 = add_loop_edge(*closure);
      loop_closures_.push_back(*closure);
      ++stats_.accepted;
      ++added;
      ++pending_loops_;
      // A constraint the estimate already satisfies changes nothing now; one it violates calls
      // for an optimisation (χ² beyond the 99 % quantile of an inlier).
      if (chi2 > inlier_chi2()) needs_optimization_ = true;
      // The key frame is now known relative to an old submap to the loop edge's accuracy.
      accumulated_ = covariance_of(closure->information);
    }
    return added;
  }

  // The search window from the accumulated covariance (translation: its largest σ).
  SearchWindow<Scalar> search_window() const {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<Scalar, D, D>> eig(
        accumulated_.template topLeftCorner<D, D>());
    const Scalar sigma_t = std::sqrt(std::max(Scalar(0), eig.eigenvalues()(D - 1)));
    Scalar sigma_r;
    if constexpr (D == 2)
      sigma_r = std::sqrt(std::max(Scalar(0), accumulated_(2, 2)));
    else
      sigma_r = std::sqrt(std::max(
          Scalar(0),
          accumulated_.template bottomRightCorner<3, 3>().eigenvalues().real().maxCoeff()));
    SearchWindow<Scalar> w;
    w.linear = std::clamp(loops_.window_sigmas * sigma_t, loops_.min_window_linear,
                          loops_.max_window_linear);
    w.angular = std::clamp(loops_.window_sigmas * sigma_r, loops_.min_window_angular,
                           std::numbers::pi_v<Scalar>);
    return w;
  }

  // The window's translations as the matcher searches them, in the submap's frame: the key
  // frame's position error is R δ_t (δ the body-frame perturbation, R its predicted rotation in
  // the submap), of covariance R Σ_tt Rᵀ there; the matcher searches the bounding box of its
  // ellipse (uncertainty_window), much narrower than search_window()'s square along a corridor.
  SearchWindow<Scalar> box_window(const SearchWindow<Scalar>& window,
                                  const transform_type& predicted) const {
    const Eigen::Matrix<Scalar, 2, 2> r = predicted.linear();
    return uncertainty_window<Scalar>(
        r * accumulated_.template topLeftCorner<2, 2>() * r.transpose(), loops_.window_sigmas,
        window.angular, loops_.min_window_linear, loops_.max_window_linear);
  }

  std::optional<LoopClosure<D, Scalar>> verify(std::size_t submap, std::size_t k,
                                               const SearchWindow<Scalar>& window) {
    Submap& s = submaps_[submap];
    s.last_used = ++clock_;
    const Node& node = nodes_[k];
    if (node.points.size() < 10) return std::nullopt;
    const transform_type predicted =
        nodes_[s.anchor].pose.inverse(Eigen::Isometry) * node.pose;  // key frame -> anchor
    transform_type start = predicted;
    LoopClosure<D, Scalar> closure;
    if constexpr (D == 2) {
      if (!s.matcher) {
        const std::span<const point_type> model(s.map->points());
        if (!CorrelativeScanMatcher<Scalar>::fits(model, loops_.matcher)) {
          ++stats_.too_wide;
          return std::nullopt;
        }
        s.matcher = std::make_unique<CorrelativeScanMatcher<Scalar>>(model, loops_.matcher);
        release_matchers();
      }
      // Olson's ambiguity test: no distinct pose may score nearly as well.
      const auto [best, second] = s.matcher->match_with_runner_up(
          node.points, predicted, box_window(window, predicted), loops_.min_score,
          loops_.ambiguity_ratio, loops_.ambiguity_distance);
      if (!best) {
        ++stats_.low_score;
        return std::nullopt;
      }
      if (second) {
        ++stats_.ambiguous;
        return std::nullopt;
      }
      start = best->pose;
      closure.score = best->score;
    }
    if constexpr (front_end_type::uses_normals) verify_icp_.solver.model_normals = s.map->normals();
    const auto r = verify_icp_.align(s.map->search(), node.points, start);
    if (!(r.reason == IcpTermination::converged || r.reason == IcpTermination::max_iterations) ||
        r.fitness < loops_.min_fitness) {
      ++stats_.icp_failed;
      return std::nullopt;
    }
    const transform_type moved = start.inverse(Eigen::Isometry) * r.transform;
    const lie::PoseMatrix<D, Scalar> info = loop_information(*s.map, r.transform);
    if constexpr (D == 2) {
      if (moved.translation().norm() > loops_.max_refinement_distance ||
          std::abs(rotation_angle(moved)) > loops_.max_refinement_angle) {
        ++stats_.disagreed;
        return std::nullopt;
      }
    } else {
      // No global search in 3D: the ICP's answer must lie within the window.
      const lie::PoseTangent<D, Scalar> e =
          lie::se_log<D, Scalar>(predicted.inverse(Eigen::Isometry) * r.transform);
      if (e.template head<D>().norm() > window.linear ||
          e.template tail<dof - D>().norm() > window.angular) {
        ++stats_.disagreed;
        return std::nullopt;
      }
    }
    // The edge starts at the submap's key frame nearest the matched pose, measured from that key
    // frame's pose in the submap as built: the chain between the anchor and it stays the graph's
    // to bend, instead of every loop edge into the submap repeating its drift with a lever arm.
    std::size_t from = 0;
    const point_type at = r.transform.translation();
    for (std::size_t j = 1; j < s.frames.size(); ++j)
      if ((s.frames[j].translation() - at).squaredNorm() <
          (s.frames[from].translation() - at).squaredNorm())
        from = j;
    closure.submap = submap;
    closure.from = s.first + from;
    closure.node = k;
    closure.relative = s.frames[from].inverse(Eigen::Isometry) * r.transform;
    // The submap's points are off relative to that key frame by up to its drift to either end.
    closure.information = covariance_of(covariance_of(info) + drift_within(s, s.first + from));
    closure.fitness = r.fitness;
    return closure;
  }

  // Σ' = Ad(u⁻¹) Σ Ad(u⁻¹)ᵀ + Σ_u: the covariance Σ of a pose relative to a fixed frame carried
  // one step u (covariance Σ_u) further, both in the end frame (the random walk of the chain).
  static lie::PoseMatrix<D, Scalar> propagate(const lie::PoseMatrix<D, Scalar>& sigma,
                                              const transform_type& u,
                                              const lie::PoseMatrix<D, Scalar>& sigma_u) {
    const lie::PoseMatrix<D, Scalar> ad = lie::se_adjoint<D, Scalar>(u.inverse(Eigen::Isometry));
    return ad * sigma * ad.transpose() + sigma_u;
  }

  // How far the submap's points may be off relative to its key frame j: the chain's steps
  // propagated from j to either end of the submap (the larger translational spread of the two).
  // Backwards, the step k-1 -> k is u⁻¹ with covariance Ad(u) Σ_u Ad(u)ᵀ in k-1's frame.
  lie::PoseMatrix<D, Scalar> drift_within(const Submap& s, std::size_t j) const {
    lie::PoseMatrix<D, Scalar> forward = lie::PoseMatrix<D, Scalar>::Zero();
    for (std::size_t k = j + 1; k < s.first + s.count; ++k)
      forward = propagate(forward, nodes_[k].step, nodes_[k].step_covariance);
    lie::PoseMatrix<D, Scalar> backward = lie::PoseMatrix<D, Scalar>::Zero();
    for (std::size_t k = j; k > s.first; --k) {
      const lie::PoseMatrix<D, Scalar> ad = lie::se_adjoint<D, Scalar>(nodes_[k].step);
      backward = propagate(backward, nodes_[k].step.inverse(Eigen::Isometry),
                           ad * nodes_[k].step_covariance * ad.transpose());
    }
    return forward.template topLeftCorner<D, D>().trace() >=
                   backward.template topLeftCorner<D, D>().trace()
               ? forward
               : backward;
  }

  lie::PoseMatrix<D, Scalar> loop_information(const map_type& map, const transform_type& t) {
    const auto& normals = map.normals();
    lie::PoseMatrix<D, Scalar> info = registration_information<D, Scalar>(
        verify_icp_.correspondences(), t,
        [&](const Correspondence<D, Scalar>& c) {
          return c.model_index < normals.size() ? normals[c.model_index]
                                                : point_type::Zero().eval();
        },
        loops_.sensor_sigma);
    // A loop edge is as uncertain as the front end's step across it at least: the same drift
    // floor as a key-frame step in place keeps the information finite along what the scan
    // leaves free.
    return info +
           loops_.front_end_drift.template covariance<D>(transform_type::Identity()).inverse();
  }

  // Adds the loop edge with its Cauchy kernel; returns its χ² at the current estimate.
  Scalar add_loop_edge(const LoopClosure<D, Scalar>& c) {
    const auto edge =
        graph_.add_edge(c.from, c.node, c.relative,
                        information_from_covariance<D, Scalar>(covariance_of(c.information)),
                        RobustKernel<Scalar>::cauchy(std::sqrt(inlier_chi2())));
    return graph_.edge_chi2(edge);
  }

  // Online, the graph is re-optimised from its last solution after every disagreeing loop: a
  // relative cost decrease of 1e-6 per step is far below what moves a pose by a millimetre.
  // finish() runs the optimiser's own tolerances.
  void optimize(bool final = false) {
    PoseGraphOptions<Scalar> options;
    if (!final) options.function_tolerance = Scalar(1e-6);
    graph_.optimize(options);
    ++optimizations_;
    for (std::size_t k = 0; k < nodes_.size(); ++k)
      nodes_[k].pose = graph_.pose(k);
    needs_optimization_ = false;
    pending_loops_ = 0;
    // Re-anchor the front end: its local map at the optimised poses, its pose the last key
    // frame's (the optimisation runs right after a key frame).
    rebuild_local_map();
    front_end_.set_pose(nodes_.back().pose);
  }

  // Keeps the grids of the most recently used submaps only (they are rebuilt on demand).
  void release_matchers() {
    constexpr std::size_t kept = 16;
    std::vector<std::size_t> with;
    for (std::size_t i = 0; i < submaps_.size(); ++i)
      if (submaps_[i].matcher) with.push_back(submaps_[i].last_used);
    if (with.size() <= kept) return;
    std::nth_element(with.begin(), with.end() - kept, with.end());
    const std::size_t oldest_kept = *(with.end() - kept);
    for (auto& s : submaps_)
      if (s.matcher && s.last_used < oldest_kept) s.matcher.reset();
  }

  static lie::PoseMatrix<D, Scalar> covariance_of(const lie::PoseMatrix<D, Scalar>& information) {
    const Eigen::LDLT<lie::PoseMatrix<D, Scalar>> ldlt(information);
    lie::PoseMatrix<D, Scalar> cov = ldlt.solve(lie::PoseMatrix<D, Scalar>::Identity());
    if (!cov.allFinite()) cov.setZero();
    return cov;
  }

  LoopClosureParams<Scalar> loops_;
  front_end_type front_end_;
  IcpType verify_icp_{};
  PoseGraph<D, Scalar> graph_;
  std::vector<Node> nodes_;
  std::vector<Submap> submaps_;
  std::vector<ScanRecord> scans_;
  std::vector<LoopClosure<D, Scalar>> loop_closures_;
  lie::PoseMatrix<D, Scalar> accumulated_ = lie::PoseMatrix<D, Scalar>::Zero();
  LoopStatistics stats_{};
  std::size_t failures_ = 0;  ///< consecutive failed registrations
  std::size_t tracked_ = std::numeric_limits<std::size_t>::max();  ///< submap in the local map
  bool restarted_ = false;  ///< lost since the last finished submap
  std::size_t optimizations_ = 0, pending_loops_ = 0, clock_ = 0;
  bool needs_optimization_ = false;
};

/// Loop-closing 2D laser SLAM in its one default configuration: the front end of
/// laser_slam_params() with the default OdometryNoise model calibrated online, and
/// LoopClosureParams' defaults.
template <std::floating_point Scalar = double>
class LaserSlam : public LoopClosingMapper<2, Scalar, LaserIcp<Scalar>> {
 public:
  /// The default configuration.
  LaserSlam() : LaserSlam(laser_slam_params<Scalar>(), LoopClosureParams<Scalar>{}) {}
  /// A configuration of one's own (an absent odometry noise model gets the default one, calibrated
  /// online).
  LaserSlam(IncrementalMapperParams<Scalar> front_end, LoopClosureParams<Scalar> loops)
      : LoopClosingMapper<2, Scalar, LaserIcp<Scalar>>(front_end, loops) {}
};

}  // namespace rangenav
