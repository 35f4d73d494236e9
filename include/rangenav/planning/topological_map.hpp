#pragma once
// The topological layer of paper 000 §4 / Fig. 6: "a vector of learned and predefined objects
// with positions, orientations, shapes and names used to communicate with a human user", kept
// beside the metric map and queried by name ("drive to the refrigerator").

#include <cmath>
#include <cstddef>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// A named object: its pose in the map frame and its outline (a polygon in the object's frame,
/// may be empty for a mere place such as "kitchen").
struct TopologicalObject {
  std::string name;  ///< unique name, e.g. "refrigerator"
  Pose2d pose;       ///< the object's pose in the map frame; its x axis points out of its front
  std::vector<Point2d> shape;  ///< outline in the object's frame (may be empty)

  /// The outline in the map frame.
  [[nodiscard]] std::vector<Point2d> footprint() const {
    std::vector<Point2d> out;
    out.reserve(shape.size());
    for (const Point2d& p : shape)
      out.push_back(pose.transform_point(p));
    return out;
  }

  /// The pose `distance` in front of the object (along its x axis), facing it: where a robot
  /// stops to interact with the object.
  [[nodiscard]] Pose2d approach_pose(double distance) const {
    const Point2d p = pose.transform_point(Point2d(distance, 0.0));
    return {p.x(), p.y(), normalize_angle(pose.theta + std::numbers::pi)};
  }
};

/// Named objects beside the metric map (paper 000 §1: "go to the refrigerator").
class TopologicalMap {
 public:
  /// Adds an object. Throws invalid_argument for an empty name, a name already present, or a
  /// non-finite pose or shape point.
  void add(TopologicalObject object) {
    constexpr std::string_view where = "TopologicalMap::add";
    if (object.name.empty()) detail::throw_invalid(where, "argument 'object.name' is empty");
    if (find(object.name))
      detail::throw_invalid_argument(where, "object.name", object.name, "is already in the map");
    detail::require_finite(where, "object.pose.x", object.pose.x);
    detail::require_finite(where, "object.pose.y", object.pose.y);
    detail::require_finite(where, "object.pose.theta", object.pose.theta);
    for (std::size_t i = 0; i < object.shape.size(); ++i)
      if (!object.shape[i].allFinite())
        detail::throw_invalid_argument(where, "object.shape[" + std::to_string(i) + "]",
                                       detail::format_value(object.shape[i].x()) + " " +
                                           detail::format_value(object.shape[i].y()),
                                       "must be finite");
    object.pose.theta = normalize_angle(object.pose.theta);
    objects_.push_back(std::move(object));
  }

  /// The object called `name`, or nullptr.
  [[nodiscard]] const TopologicalObject* find(std::string_view name) const {
    for (const TopologicalObject& o : objects_)
      if (o.name == name) return &o;
    return nullptr;
  }

  /// The object called `name`; throws invalid_argument when there is none.
  [[nodiscard]] const TopologicalObject& at(std::string_view name) const {
    if (const TopologicalObject* o = find(name)) return *o;
    detail::throw_invalid_argument("TopologicalMap::at", "name", name, "is not in the map");
  }

  /// Removes the object called `name`; returns whether there was one.
  bool remove(std::string_view name) {
    for (auto it = objects_.begin(); it != objects_.end(); ++it)
      if (it->name == name) {
        objects_.erase(it);
        return true;
      }
    return false;
  }

  /// The object whose position is closest to `point`, or nullptr for an empty map.
  [[nodiscard]] const TopologicalObject* nearest(const Point2d& point) const {
    const TopologicalObject* best = nullptr;
    double best_sq = std::numeric_limits<double>::infinity();
    for (const TopologicalObject& o : objects_) {
      const double d_sq = (o.pose.position() - point).squaredNorm();
      if (d_sq < best_sq) {
        best_sq = d_sq;
        best = &o;
      }
    }
    return best;
  }

  /// All objects, in the order they were added.
  [[nodiscard]] const std::vector<TopologicalObject>& objects() const { return objects_; }
  /// Number of objects.
  [[nodiscard]] std::size_t size() const { return objects_.size(); }
  /// True when there are no objects.
  [[nodiscard]] bool empty() const { return objects_.empty(); }

 private:
  std::vector<TopologicalObject> objects_;
};

}  // namespace rangenav
