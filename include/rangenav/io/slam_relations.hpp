#pragma once
// Ground-truth relations of the Freiburg SLAM benchmark (Kümmerle et al., "On measuring the
// accuracy of SLAM algorithms", Autonomous Robots 27(4), 2009) and their error metric.
//
// A relations file has one relation per line, whitespace-separated:
//   timestamp1 timestamp2 x y z roll pitch yaw
// the true pose of the scan at timestamp2 in the frame of the scan at timestamp1 (m, rad); for
// 2D logs z, roll and pitch are 0. The metric compares each relation δ_ij with the estimate
// δ*_ij = x_i⁻¹ ⊕ x_j of a trajectory: the translational error is ‖trans(δ_ij ⊖ δ*_ij)‖, the
// rotational error |rot(δ_ij ⊖ δ*_ij)|; "absolute" figures are the mean and standard deviation of
// these over the relations.
//
// A malformed line raises io_error naming the file and the 1-based line, e.g.
//   rangenav: slam_relations: mit-csail.relations:3: expected 8 fields, found 7

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/io/line_reader.hpp"
#include "rangenav/io/reader_limits.hpp"

namespace rangenav::io {

/// One ground-truth relation: the pose of the scan at `second` in the frame of the scan at
/// `first`.
struct SlamRelation {
  double first{0.0};   ///< timestamp1 (s)
  double second{0.0};  ///< timestamp2 (s)
  Pose2d delta{};      ///< (x, y, yaw)
};

/// Reads a relations file (plain or gzip). Empty lines and lines starting with '#' are skipped.
/// Throws io_error naming file and line for a malformed line (a non-finite number included), a
/// line longer than limits.max_line_bytes or more than limits.max_points relations.
inline std::vector<SlamRelation> read_slam_relations(const std::filesystem::path& path,
                                                     const ReaderLimits& limits = {}) {
  limits.validate("read_slam_relations");
  LineReader reader(path, "slam_relations", limits.max_line_bytes);
  std::vector<SlamRelation> relations;
  std::vector<std::string_view> tokens;
  std::string_view line;
  while (reader.next(line)) {
    detail::split_whitespace(line, tokens);
    if (tokens.empty() || tokens.front().starts_with('#')) continue;
    if (relations.size() == limits.max_points)
      reader.fail_line(detail::exceeds_limit("relation count", relations.size() + 1, "max_points",
                                             limits.max_points));
    if (tokens.size() != 8)
      reader.fail_line("expected 8 fields, found " + std::to_string(tokens.size()));
    double v[8];
    for (std::size_t k = 0; k < 8; ++k)
      if (!detail::parse_double(tokens[k], v[k]) || !std::isfinite(v[k]))
        reader.fail_line("field " + std::to_string(k + 1) + " is not a finite number: '" +
                         std::string(tokens[k]) + "'");
    relations.push_back({v[0], v[1], {v[2], v[3], normalize_angle(v[7])}});
  }
  return relations;
}

/// Mean and standard deviation of the per-relation errors of one group of relations.
struct RelationErrors {
  std::size_t count{0};            ///< relations evaluated
  double translation_mean{0.0};    ///< mean ‖trans(e)‖ (m)
  double translation_stddev{0.0};  ///< (m)
  double rotation_mean{0.0};       ///< mean |rot(e)| (rad)
  double rotation_stddev{0.0};     ///< (rad)
};

/// The metric over all relations, and over the relations whose timestamps are less than
/// `local_gap` apart ("short": local accuracy) or not ("long": mostly loop closures).
struct RelationEvaluation {
  RelationErrors all;        ///< every relation matched to the trajectory
  RelationErrors short_gap;  ///< relations less than `local_gap` apart: local accuracy
  RelationErrors long_gap;   ///< the others: mostly loop closures, global consistency
  std::size_t missing{0};    ///< relations with a timestamp the trajectory has no pose for
};

/// The index of the entry of the increasing `timestamps` nearest `t` (the later one on a tie),
/// or nullopt when none lies within `max_time_offset` seconds: how evaluate_slam_relations()
/// matches a relation's timestamp to a trajectory.
[[nodiscard]] inline std::optional<std::size_t> nearest_timestamp(
    std::span<const double> timestamps, double t, double max_time_offset = 1e-3) {
  const auto it = std::lower_bound(timestamps.begin(), timestamps.end(), t);
  std::size_t best = timestamps.size();
  if (it != timestamps.end()) best = static_cast<std::size_t>(it - timestamps.begin());
  if (it != timestamps.begin()) {
    const auto before = static_cast<std::size_t>(it - timestamps.begin()) - 1;
    if (best == timestamps.size() || t - timestamps[before] < timestamps[best] - t) best = before;
  }
  if (best == timestamps.size() || std::abs(timestamps[best] - t) > max_time_offset)
    return std::nullopt;
  return best;
}

/// Evaluates a trajectory given as poses at `timestamps` (increasing) against `relations`. A
/// relation's timestamp is matched to the nearest trajectory timestamp within `max_time_offset`
/// seconds; relations without a match are counted as missing. Throws invalid_argument for
/// mismatched sizes, timestamps that do not increase, a non-finite pose or relation, or a
/// negative local_gap or max_time_offset.
inline RelationEvaluation evaluate_slam_relations(std::span<const SlamRelation> relations,
                                                  std::span<const double> timestamps,
                                                  std::span<const Pose2d> poses,
                                                  double local_gap = 2.0,
                                                  double max_time_offset = 1e-3) {
  constexpr std::string_view where = "evaluate_slam_relations";
  if (timestamps.size() != poses.size())
    ::rangenav::detail::throw_invalid_argument(
        where, "poses.size()", poses.size(),
        "must equal timestamps.size() = " + std::to_string(timestamps.size()));
  for (std::size_t i = 1; i < timestamps.size(); ++i)
    if (!(timestamps[i] > timestamps[i - 1]))
      ::rangenav::detail::throw_invalid_argument(where, "timestamps[" + std::to_string(i) + "]",
                                                 timestamps[i], "must exceed the one before");
  ::rangenav::detail::require_non_negative(where, "max_time_offset", max_time_offset);
  ::rangenav::detail::require_non_negative(where, "local_gap", local_gap);
  for (std::size_t i = 0; i < poses.size(); ++i)
    if (!(std::isfinite(poses[i].x) && std::isfinite(poses[i].y) && std::isfinite(poses[i].theta)))
      ::rangenav::detail::throw_invalid_argument(where, "poses[i]", i, "is not finite");
  for (std::size_t i = 0; i < relations.size(); ++i) {
    const SlamRelation& r = relations[i];
    if (!(std::isfinite(r.first) && std::isfinite(r.second) && std::isfinite(r.delta.x) &&
          std::isfinite(r.delta.y) && std::isfinite(r.delta.theta)))
      ::rangenav::detail::throw_invalid_argument(where, "relations[i]", i, "is not finite");
  }
  const auto find = [&](double t) -> const Pose2d* {
    const auto i = nearest_timestamp(timestamps, t, max_time_offset);
    return i ? &poses[*i] : nullptr;
  };
  struct Sums {
    std::size_t n{0};
    double t{0}, t_sq{0}, r{0}, r_sq{0};
    void add(double et, double er) {
      ++n;
      t += et;
      t_sq += et * et;
      r += er;
      r_sq += er * er;
    }
    [[nodiscard]] RelationErrors finish() const {
      RelationErrors e;
      e.count = n;
      if (n == 0) return e;
      const auto c = static_cast<double>(n);
      e.translation_mean = t / c;
      e.rotation_mean = r / c;
      e.translation_stddev =
          std::sqrt(std::max(t_sq / c - e.translation_mean * e.translation_mean, 0.0));
      e.rotation_stddev = std::sqrt(std::max(r_sq / c - e.rotation_mean * e.rotation_mean, 0.0));
      return e;
    }
  } all, near, far;
  RelationEvaluation result;
  for (const auto& rel : relations) {
    const Pose2d* a = find(rel.first);
    const Pose2d* b = find(rel.second);
    if (a == nullptr || b == nullptr) {
      ++result.missing;
      continue;
    }
    const Pose2d error = relative(relative(*a, *b), rel.delta);  // δ* ⁻¹ ⊕ δ
    const double et = std::hypot(error.x, error.y), er = std::abs(error.theta);
    all.add(et, er);
    (std::abs(rel.second - rel.first) < local_gap ? near : far).add(et, er);
  }
  result.all = all.finish();
  result.short_gap = near.finish();
  result.long_gap = far.finish();
  return result;
}

}  // namespace rangenav::io
