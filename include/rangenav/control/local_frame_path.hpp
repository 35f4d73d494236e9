#pragma once
// A path as a chain of local coordinate frames (paper 000 §5, Fig. 6b): one frame per straight
// segment, its origin at the segment's start and its x axis along the segment. In the frame of
// the tracked segment the robot's pose (x, y, theta) gives the path-following errors: y is the
// cross-track offset and theta the heading error of Indiveri's law (Eq. 7).

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/planning/a_star.hpp"

namespace rangenav {

/// One straight segment of a path and its local frame.
struct PathSegment {
  Point2d start;        ///< where the segment starts (map frame)
  Point2d end;          ///< where it ends
  double length{0.0};   ///< |end - start| (m)
  double heading{0.0};  ///< direction of the frame's x axis (rad)
  /// The graph edge the segment follows (VoronoiPathGraph::npos when none), so a blocked segment
  /// can be marked in the graph.
  std::uint32_t edge{std::numeric_limits<std::uint32_t>::max()};

  /// The segment's frame as a pose in the map frame.
  [[nodiscard]] Pose2d frame() const { return {start.x(), start.y(), heading}; }
  /// A map-frame pose in this segment's frame.
  [[nodiscard]] Pose2d to_local(const Pose2d& pose) const { return relative(frame(), pose); }
  /// A map-frame point in this segment's frame.
  [[nodiscard]] Point2d to_local(const Point2d& p) const {
    const double c = std::cos(heading), s = std::sin(heading);
    const Point2d d = p - start;
    return {c * d.x() + s * d.y(), -s * d.x() + c * d.y()};
  }
};

/// A path as a chain of local frames, one per straight segment with its x axis along it
/// (paper 000 Fig. 6b).
class LocalFramePath {
 public:
  /// The edge of a segment that follows no graph edge.
  static constexpr std::uint32_t no_edge = std::numeric_limits<std::uint32_t>::max();

  LocalFramePath() = default;

  /// A path through `waypoints` (at least two; consecutive duplicates are dropped). `edges`, when
  /// not empty, gives the graph edge of each segment (waypoints.size() - 1 entries). Throws
  /// invalid_argument for non-finite waypoints, fewer than two distinct ones, or a size mismatch.
  explicit LocalFramePath(std::span<const Point2d> waypoints,
                          std::span<const std::uint32_t> edges = {}) {
    constexpr std::string_view where = "LocalFramePath";
    if (!edges.empty() && edges.size() + 1 != waypoints.size())
      detail::throw_invalid_argument(
          where, "edges.size()", edges.size(),
          "must be 0 or waypoints.size() - 1 = " + std::to_string(waypoints.size() - 1));
    for (std::size_t i = 0; i < waypoints.size(); ++i)
      if (!waypoints[i].allFinite())
        detail::throw_invalid_argument(
            where, "waypoints[" + std::to_string(i) + "]",
            detail::format_value(waypoints[i].x()) + " " + detail::format_value(waypoints[i].y()),
            "must be finite");
    for (std::size_t i = 0; i + 1 < waypoints.size(); ++i) {
      const Point2d d = waypoints[i + 1] - waypoints[i];
      const double length = d.norm();
      if (length == 0.0) continue;
      segments_.push_back({waypoints[i], waypoints[i + 1], length, std::atan2(d.y(), d.x()),
                           edges.empty() ? no_edge : edges[i]});
      length_ += length;
    }
    if (segments_.empty())
      detail::throw_invalid_argument(where, "waypoints.size()", waypoints.size(),
                                     "must hold at least two distinct points");
  }

  /// The path A* planned.
  explicit LocalFramePath(const PlannedPath& path)
      : LocalFramePath(std::span<const Point2d>(path.waypoints),
                       std::span<const std::uint32_t>(path.edges)) {}

  /// The segments, in order.
  [[nodiscard]] const std::vector<PathSegment>& segments() const { return segments_; }
  /// Segment i.
  [[nodiscard]] const PathSegment& segment(std::size_t i) const { return segments_[i]; }
  /// Number of segments.
  [[nodiscard]] std::size_t size() const { return segments_.size(); }
  /// True for a path without segments.
  [[nodiscard]] bool empty() const { return segments_.empty(); }
  /// Total length (m).
  [[nodiscard]] double length() const { return length_; }
  /// The end of the last segment (the path must not be empty).
  [[nodiscard]] Point2d goal() const { return segments_.back().end; }

 private:
  std::vector<PathSegment> segments_;
  double length_{0.0};
};

}  // namespace rangenav
