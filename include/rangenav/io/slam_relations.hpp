#pragma once
// The Freiburg SLAM benchmark's relations (Kümmerle et al. 2009, "On measuring the accuracy of
// SLAM algorithms"): reading a relations file and evaluating a trajectory against it.
//
// A relations line is `timestamp1 timestamp2 x y z roll pitch yaw` (whitespace-separated): the
// true relative pose from the pose at timestamp1 to the pose at timestamp2 in the first pose's
// frame. For every relation δ and the estimate δ* = x1^-1 ⊕ x2 the error is e = δ ⊖ δ*; the
// benchmark reports the mean and standard deviation of |trans(e)| (m) and |rot(e)| (deg).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/io/trajectory.hpp"

namespace rangenav::io {

struct SlamRelation {
  double timestamp1 = 0;
  double timestamp2 = 0;
  Pose2d delta;  ///< true relative pose (x, y, yaw)
};

/// Reads a relations file. Throws io_error naming file and line for malformed lines.
[[nodiscard]] inline std::vector<SlamRelation> read_slam_relations(
    const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw io_error("rangenav: read_slam_relations: cannot open '" + path.string() + "'");
  std::vector<SlamRelation> out;
  std::string line;
  std::size_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream s(line);
    double t1, t2, x, y, z, roll, pitch, yaw;
    if (!(s >> t1 >> t2 >> x >> y >> z >> roll >> pitch >> yaw))
      throw io_error("rangenav: read_slam_relations: " + path.string() + ":" +
                     std::to_string(number) +
                     ": expected 8 numbers 'timestamp1 timestamp2 x y z roll pitch yaw'");
    out.push_back({t1, t2, {x, y, yaw}});
  }
  return out;
}

/// Mean and standard deviation of one error kind over a set of relations.
struct ErrorStats {
  std::size_t count = 0;
  double mean = 0;
  double stddev = 0;
};

struct RelationsEvaluation {
  ErrorStats translation;   ///< m
  ErrorStats rotation;      ///< deg
  std::size_t missing = 0;  ///< relations with no trajectory pose within max_time_gap
};

namespace detail {
inline ErrorStats stats_of(const std::vector<double>& v) {
  ErrorStats s;
  s.count = v.size();
  if (v.empty()) return s;
  double sum = 0;
  for (double x : v)
    sum += x;
  s.mean = sum / static_cast<double>(v.size());
  double var = 0;
  for (double x : v)
    var += (x - s.mean) * (x - s.mean);
  s.stddev = std::sqrt(var / static_cast<double>(v.size()));
  return s;
}
}  // namespace detail

/// Evaluates a trajectory (sorted by timestamp; io/trajectory.hpp reads and writes them) against
/// relations; a relation is used when both timestamps have a trajectory pose within `max_time_gap`
/// seconds (the evaluator's 0.1 s). `filter(relation)` selects a subset (e.g. the short relations).
template <class Filter>
[[nodiscard]] RelationsEvaluation evaluate_slam_relations(
    const std::vector<StampedPose2d>& trajectory, const std::vector<SlamRelation>& relations,
    Filter filter, double max_time_gap = 0.1) {
  const auto find = [&](double t) -> const StampedPose2d* {
    const auto it =
        std::lower_bound(trajectory.begin(), trajectory.end(), t,
                         [](const StampedPose2d& p, double value) { return p.timestamp < value; });
    const StampedPose2d* best = nullptr;
    if (it != trajectory.end()) best = &*it;
    if (it != trajectory.begin()) {
      const StampedPose2d* prev = &*(it - 1);
      if (!best || std::abs(prev->timestamp - t) < std::abs(best->timestamp - t)) best = prev;
    }
    return best && std::abs(best->timestamp - t) <= max_time_gap ? best : nullptr;
  };
  RelationsEvaluation eval;
  std::vector<double> trans, rot;
  for (const auto& r : relations) {
    if (!filter(r)) continue;
    const StampedPose2d* a = find(r.timestamp1);
    const StampedPose2d* b = find(r.timestamp2);
    if (!a || !b) {
      ++eval.missing;
      continue;
    }
    const Pose2d estimate = relative(a->pose, b->pose);
    const Pose2d e = relative(estimate, r.delta);  // δ ⊖ δ*
    trans.push_back(std::hypot(e.x, e.y));
    rot.push_back(std::abs(normalize_angle(e.theta)) * 180.0 / std::numbers::pi);
  }
  eval.translation = detail::stats_of(trans);
  eval.rotation = detail::stats_of(rot);
  return eval;
}

[[nodiscard]] inline RelationsEvaluation evaluate_slam_relations(
    const std::vector<StampedPose2d>& trajectory, const std::vector<SlamRelation>& relations,
    double max_time_gap = 0.1) {
  return evaluate_slam_relations(
      trajectory, relations, [](const SlamRelation&) { return true; }, max_time_gap);
}

}  // namespace rangenav::io
