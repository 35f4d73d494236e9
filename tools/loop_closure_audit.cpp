// loop_closure_audit: which loop closures of the 2D SLAM are wrong, on a log with ground truth.
// It maps a CARMEN log with LaserSlam (the defaults of example 03) and checks every accepted loop
// closure against the true poses: the edge says where key frame `node` lies relative to key
// frame `from`; the truth says where it does. A closure off by more than --max-error-m or
// --max-error-deg is printed with what the SLAM believed when it accepted it:
//
//   estimate     the pose graph's estimate before the scan, from `from` to the key frame before
//                `node` (the new key frame has no estimate yet), against the truth: how far the
//                SLAM had drifted from the place it was closing on;
//   window σ     the uncertainty accumulated since the last loop constraint (the larger of
//                the x and y σ, and the heading's σ): what the loop search allowed for;
//   χ²           the closure's error against the truth under the edge's own information
//                (body-frame perturbation δ = log(relative_true⁻¹ relative), χ² = δᵀ Ω δ),
//                with the edge's claimed σ (x, y, heading).
//
// Whether the edges' information is calibrated, over every checked closure: a calibrated 3-DOF
// edge has a median χ² of 2.37 and exceeds the 99 % quantile 11.34 once in a hundred. A lower
// median means cautious edges; more beyond 11.34 than 1 % means outliers the Cauchy kernel of
// the back end has to down-weight (LoopClosingMapper, "back end").
//
// Meant for the hold-out inputs of benchmarks/slam_logs.sh, which ../shared/tools/noisy_log.py
// writes as a log and its truth ("timestamp x y theta", matched to the scans by timestamp to
// 0.1 ms); `benchmarks/slam_logs.sh build/release --keep DIR` keeps them in DIR, e.g.
//
//   loop_closure_audit DIR/freiburg-079.2.2.log DIR/freiburg-079.2.2.truth
//
//   loop_closure_audit LOG TRUTH [--max-error-m M] [--max-error-deg D]
//
//   --max-error-m M    translation error that makes a closure wrong (default 0.15 m)
//   --max-error-deg D  rotation error that makes a closure wrong (default 2°)
//
// Prints one line per wrong closure and, last, one JSON line with the counts.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "rangenav/io/carmen.hpp"
#include "rangenav/io/trajectory.hpp"
#include "rangenav/mapping/loop_closing_mapper.hpp"

namespace {

using rangenav::Transform2d;

double angle_deg(const Transform2d& t) {
  return std::abs(rangenav::rotation_angle(t)) * 180 / std::numbers::pi;
}

long long stamp_key(double t) {
  return std::llround(t * 1e4);
}

}  // namespace

int main(int argc, char** argv) try {
  constexpr const char* usage =
      "usage: loop_closure_audit LOG TRUTH [--max-error-m M] [--max-error-deg D]\n";
  if (argc < 3 || argc % 2 == 0) {
    std::fputs(usage, stderr);
    return 2;
  }
  double max_error_m = 0.15, max_error_deg = 2;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string arg = argv[i];
    double* target = arg == "--max-error-m"     ? &max_error_m
                     : arg == "--max-error-deg" ? &max_error_deg
                                                : nullptr;
    char* end = nullptr;
    const double value = std::strtod(argv[i + 1], &end);
    if (target == nullptr || end == argv[i + 1] || *end != '\0' || !(value >= 0)) {
      std::fprintf(stderr, "loop_closure_audit: bad option %s %s (a threshold >= 0)\n%s", argv[i],
                   argv[i + 1], usage);
      return 2;
    }
    *target = value;
  }

  auto log = rangenav::io::read_carmen_scan_log(argv[1]);
  std::map<long long, rangenav::Pose2d> truth_at;
  for (const auto& p : rangenav::io::read_xytheta(argv[2]))
    truth_at[stamp_key(p.timestamp)] = p.pose;

  rangenav::LaserSlam<double> slam;
  std::vector<std::optional<Transform2d>> truth_of_node;  // the true pose of each key frame
  std::size_t checked = 0, wrong = 0, without_truth = 0;
  std::vector<double> chi2;  // of every checked closure against the truth
  // The key frames' estimate before the scan: it changes only with a new key frame or an
  // optimisation, so it is copied then, not at every scan.
  std::vector<Transform2d> estimate, before;
  for (std::size_t i = 0; i < log.records.size(); ++i) {
    std::optional<Transform2d> odometry;
    if (log.odometry[i]) odometry = log.odometry[i]->to_isometry();
    const auto window = slam.accumulated_covariance();
    const std::size_t closures_before = slam.loop_closures().size();
    const auto update = slam.process(log.records[i].scan, odometry);
    if (update.node || update.optimized) {
      before.swap(estimate);
      estimate = slam.key_frame_poses();
    }
    if (!update.node) continue;
    const auto truth = truth_at.find(stamp_key(log.records[i].timestamp));
    if (truth == truth_at.end()) {
      ++without_truth;
      truth_of_node.emplace_back();
      continue;
    }
    truth_of_node.emplace_back(truth->second.to_isometry());
    const auto& closures = slam.loop_closures();
    for (std::size_t c = closures_before; c < closures.size(); ++c) {
      const auto& closure = closures[c];
      const std::size_t previous = closure.node - 1;
      if (!truth_of_node[closure.from] || !truth_of_node[previous]) continue;
      ++checked;
      const Transform2d from = truth_of_node[closure.from]->inverse(Eigen::Isometry);
      const Transform2d error =
          (from * *truth_of_node[closure.node]).inverse(Eigen::Isometry) * closure.relative;
      const Eigen::Vector3d delta = rangenav::lie::se_log<2, double>(error);
      chi2.push_back(delta.dot(closure.information * delta));
      if (error.translation().norm() <= max_error_m && angle_deg(error) <= max_error_deg) continue;
      ++wrong;
      const Eigen::Matrix3d edge = closure.information.inverse();
      const Transform2d estimate_error =
          (from * *truth_of_node[previous]).inverse(Eigen::Isometry) *
          (before[closure.from].inverse(Eigen::Isometry) * before[previous]);
      std::printf(
          "scan %zu: key frame %zu on submap %zu at key frame %zu: off %.3f m %.2f deg "
          "(score %.3f, fitness %.3f); estimate off %.3f m %.2f deg; window sigma %.3f m "
          "%.2f deg; chi2 %.1f, edge sigma %.3f %.3f m %.2f deg\n",
          i, closure.node, closure.submap, closure.from, error.translation().norm(),
          angle_deg(error), closure.score, closure.fitness, estimate_error.translation().norm(),
          angle_deg(estimate_error), std::sqrt(std::max(window(0, 0), window(1, 1))),
          std::sqrt(window(2, 2)) * 180 / std::numbers::pi, chi2.back(), std::sqrt(edge(0, 0)),
          std::sqrt(edge(1, 1)), std::sqrt(edge(2, 2)) * 180 / std::numbers::pi);
    }
  }
  slam.finish();
  // The calibration of the edges' information (see the file comment).
  double chi2_median = 0, beyond = 0;
  if (!chi2.empty()) {
    std::sort(chi2.begin(), chi2.end());
    const std::size_t n = chi2.size();
    chi2_median = n % 2 ? chi2[n / 2] : (chi2[n / 2 - 1] + chi2[n / 2]) / 2;
    const double chi2_99 = rangenav::LaserSlam<double>::inlier_chi2();
    beyond = double(chi2.end() - std::upper_bound(chi2.begin(), chi2.end(), chi2_99)) / double(n);
  }
  std::printf(
      "{\"scans\":%zu,\"key_frames\":%zu,\"loop_closures_checked\":%zu,\"wrong\":%zu,"
      "\"key_frames_without_truth\":%zu,\"chi2_median\":%.3f,\"chi2_beyond_99\":%.4f}\n",
      log.records.size(), slam.key_frames(), checked, wrong, without_truth, chi2_median, beyond);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "loop_closure_audit: %s\n", e.what());
  return 1;
}
