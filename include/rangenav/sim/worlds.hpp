#pragma once
// Built-in worlds with their ground truth as data, so tests can check what the toolkit perceives
// against what is really there.
//
//   apartment()          the domestic scene of Fig. 2 of paper 002: rooms and a corridor, a couch
//                        table whose top is above a 2D scanner's plane and whose legs are thin,
//                        chairs, an open drawer (overhang), small objects on the floor (3-10 cm),
//                        a descending stair and doors; with a scripted tour for the demo.
//   office_corridor(s)   a 20 m corridor with four doors on each side in settable states (the
//                        door paper 001's experiments).
//   kitchen()            a kitchen front, counter top, wall, floor and a table with objects, with
//                        its true planes (paper 004's evaluation scene).

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <iterator>
#include <numbers>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/sim/world.hpp"

namespace rangenav::sim {

/// A named object of a built-in world and where it truly is.
struct SceneObject {
  std::string name;      ///< unique, e.g. "couch_table"
  std::string type;      ///< "table", "chair", "drawer", "small_object", "stair", "door", ...
  Point3d min{0, 0, 0};  ///< axis-aligned 3D bounds (a stair's bounds reach below the floor)
  Point3d max{0, 0, 0};  ///< the upper corner of the bounds
  std::vector<PrimitiveRef> parts;  ///< the primitives it is made of (holes for a stair)

  /// The centre of its bounds.
  [[nodiscard]] Point3d center() const { return (min + max) / 2; }
  /// True when `p` is one of its parts.
  [[nodiscard]] bool contains(const PrimitiveRef& p) const {
    for (const auto& q : parts)
      if (q == p) return true;
    return false;
  }
};

/// A true plane n . p + d = 0 (unit normal) and the convex region of it that exists, as a
/// polygon of 3D vertices.
struct ScenePlane {
  std::string name;              ///< e.g. "counter_top"
  Point3d normal{0, 0, 1};       ///< unit normal
  double d{0};                   ///< n . p + d = 0 on the plane
  std::vector<Point3d> outline;  ///< the plane's labelled region, a convex outline

  /// The signed distance of `p` from the plane (m).
  [[nodiscard]] double signed_distance(const Point3d& p) const { return normal.dot(p) + d; }
};

/// A built-in world with its ground truth.
struct Scene {
  World world;                       ///< walls, objects, doors, ...
  std::vector<SceneObject> objects;  ///< the named objects and their true bounds
  std::vector<ScenePlane> planes;    ///< filled where a world defines them (kitchen)
  Pose2d start{0, 0, 0};             ///< a collision-free start pose for a robot of radius 0.3 m
  std::vector<Point2d> tour;         ///< collision-free waypoints from the start (may be empty)

  /// The object called `name`; throws invalid_argument when there is none.
  [[nodiscard]] const SceneObject& object(std::string_view name) const {
    for (const auto& o : objects)
      if (o.name == name) return o;
    detail::throw_invalid_argument("Scene::object", "name", name, "names no object");
  }
  /// The object a primitive belongs to, or nullptr.
  [[nodiscard]] const SceneObject* object_of(const PrimitiveRef& p) const {
    for (const auto& o : objects)
      if (o.contains(p)) return &o;
    return nullptr;
  }
};

namespace detail_worlds {

inline std::uint32_t u32(std::size_t i) {
  return static_cast<std::uint32_t>(i);
}

/// Walls from a to b leaving openings [from, to] (distances along a -> b).
inline void wall_with_openings(World& w, const Point2d& a, const Point2d& b,
                               std::span<const std::pair<double, double>> openings,
                               double height = 2.5) {
  const double length = (b - a).norm();
  const Point2d u = (b - a) / length;
  double s = 0;
  for (const auto& [from, to] : openings) {
    if (from > s) w.add_wall(a + s * u, a + from * u, height);
    s = to;
  }
  if (s < length) w.add_wall(a + s * u, b, height);
}
inline void wall_with_openings(World& w, const Point2d& a, const Point2d& b,
                               std::initializer_list<std::pair<double, double>> openings,
                               double height = 2.5) {
  wall_with_openings(w, a, b, std::span<const std::pair<double, double>>(openings), height);
}

inline SceneObject make_object(std::string name, std::string type) {
  SceneObject o;
  o.name = std::move(name);
  o.type = std::move(type);
  return o;
}

/// Widens the object's bounds (the first part sets them).
inline void grow(SceneObject& o, const Point3d& lo, const Point3d& hi) {
  if (o.parts.empty()) {
    o.min = lo;
    o.max = hi;
  } else {
    o.min = o.min.cwiseMin(lo);
    o.max = o.max.cwiseMax(hi);
  }
}

inline void add_box(Scene& s, SceneObject& o, const Box& b) {
  const std::size_t i = s.world.add_box(b);
  const double c = std::abs(std::cos(b.yaw)), n = std::abs(std::sin(b.yaw));
  const Point2d half(c * b.size.x() / 2 + n * b.size.y() / 2,
                     n * b.size.x() / 2 + c * b.size.y() / 2);
  grow(o, {b.center.x() - half.x(), b.center.y() - half.y(), b.z_min},
       {b.center.x() + half.x(), b.center.y() + half.y(), b.z_max});
  o.parts.push_back({SurfaceKind::box, u32(i)});
}

inline void add_cylinder(Scene& s, SceneObject& o, const Cylinder& c) {
  const std::size_t i = s.world.add_cylinder(c);
  grow(o, {c.center.x() - c.radius, c.center.y() - c.radius, c.z_min},
       {c.center.x() + c.radius, c.center.y() + c.radius, c.z_max});
  o.parts.push_back({SurfaceKind::cylinder, u32(i)});
}

/// A table: a top of `size` from top_z - thickness to top_z on four legs of leg_radius, inset.
inline SceneObject& add_table(Scene& s, std::string name, const Point2d& center,
                              const Point2d& size, double top_z, double leg_radius,
                              double thickness = 0.04, double inset = 0.06) {
  SceneObject o = make_object(std::move(name), "table");
  add_box(s, o, {center, size, 0, top_z - thickness, top_z});
  for (double sx : {-1.0, 1.0})
    for (double sy : {-1.0, 1.0})
      add_cylinder(s, o,
                   {center + Point2d(sx * (size.x() / 2 - inset), sy * (size.y() / 2 - inset)),
                    leg_radius, 0, top_z - thickness});
  s.objects.push_back(std::move(o));
  return s.objects.back();
}

/// A chair facing `facing` (rad): seat 0.42 m square at 0.46 m, thin legs, a backrest behind.
inline void add_chair(Scene& s, std::string name, const Point2d& center, double facing) {
  SceneObject o = make_object(std::move(name), "chair");
  const double seat = 0.42, seat_top = 0.46;
  const Eigen::Rotation2Dd r(facing);
  add_box(s, o, {center, {seat, seat}, facing, seat_top - 0.04, seat_top});
  for (double sx : {-1.0, 1.0})
    for (double sy : {-1.0, 1.0})
      add_cylinder(s, o, {center + r * Point2d(sx * 0.18, sy * 0.18), 0.012, 0, seat_top - 0.04});
  add_box(s, o, {center + r * Point2d(-seat / 2 + 0.02, 0), {0.04, seat}, facing, seat_top, 0.9});
  s.objects.push_back(std::move(o));
}

inline void add_small_box(Scene& s, std::string name, const Point2d& center, const Point2d& size,
                          double height, double yaw = 0) {
  SceneObject o = make_object(std::move(name), "small_object");
  add_box(s, o, {center, size, yaw, 0, height});
  s.objects.push_back(std::move(o));
}

inline void add_can(Scene& s, std::string name, const Point2d& center, double height) {
  SceneObject o = make_object(std::move(name), "small_object");
  add_cylinder(s, o, {center, 0.033, 0, height});
  s.objects.push_back(std::move(o));
}

inline void add_named_door(Scene& s, std::string name, const Door& d) {
  const std::size_t i = s.world.add_door(d);
  const double r = d.length;
  SceneObject o = make_object(std::move(name), "door");
  o.min = {d.hinge.x() - r, d.hinge.y() - r, 0};
  o.max = {d.hinge.x() + r, d.hinge.y() + r, d.height};
  o.parts.push_back({SurfaceKind::door, u32(i)});
  s.objects.push_back(std::move(o));
}

/// A descending stair going down in direction +y from `top_edge_y`: `steps` treads of `run`
/// depth, each `rise` lower; the last tread extends to last_y.
inline void add_stair(Scene& s, std::string name, double x0, double x1, double top_edge_y,
                      int steps, double run, double rise, double last_y) {
  SceneObject o = make_object(std::move(name), "stair");
  for (int k = 1; k <= steps; ++k) {
    const double y0 = top_edge_y + run * (k - 1);
    const double y1 = k == steps ? last_y : y0 + run;
    const std::size_t i =
        s.world.add_hole({{(x0 + x1) / 2, (y0 + y1) / 2}, {x1 - x0, y1 - y0}, 0, rise * k});
    grow(o, {x0, y0, -rise * k}, {x1, y1, 0});
    o.parts.push_back({SurfaceKind::hole, u32(i)});
  }
  s.objects.push_back(std::move(o));
}

}  // namespace detail_worlds

/// Default 2D-scanner height assumed by the built-in worlds' design: 0.30 m, below the couch
/// table's top (0.40-0.44 m) and the open drawer (0.55-0.70 m), above the small floor objects.
inline constexpr double apartment_scan_height = 0.30;

/// The apartment of paper 002 Fig. 2 (10 m x 10 m, walls 2.5 m, ceiling 2.5 m):
///   living room x in [0, 6], y in [0, 5]: couch, couch table (top 0.40-0.44 m on 2 cm legs),
///     sideboard, small floor objects (cans, a book, a toy block, a shoe: 3-10 cm), door to the
///     corridor;
///   kitchen x in [6, 10], y in [0, 5]: counter, dining table with three chairs, a dresser with an
///     open drawer overhanging by 30 cm at 0.55-0.70 m, passages to living room and corridor;
///   corridor y in [5, 6.2]; bedroom x in [0, 5] and bathroom x in [5, 7.5] north of it (doors);
///   stairwell x in [7.5, 10], y in [6.2, 10] with a stair descending in +y from y = 7.2 (rise
///     0.18 m, run 0.28 m) that a 2D scanner does not see.
/// objects names: couch, couch_table, sideboard, can_red, can_blue, book, toy_block, shoe,
/// counter, dining_table, chair_1..3, dresser, drawer, bed, wardrobe, bathtub, door_living,
/// door_bedroom, door_bathroom, stair. start = (1, 5.6, 0) in the corridor; the tour visits the
/// living room and kitchen and stops in front of the stair.
[[nodiscard]] inline Scene apartment() {
  using namespace detail_worlds;
  Scene s;
  World& w = s.world;
  w.set_ceiling_height(2.5);
  const std::vector<Point2d> outer{{0, 0}, {10, 0}, {10, 10}, {0, 10}};
  w.add_polygon(outer, 2.5);
  wall_with_openings(w, {0, 5}, {10, 5}, {{2.0, 2.9}, {7.0, 8.0}});  // corridor S
  wall_with_openings(w, {6, 0}, {6, 5}, {{1.5, 2.5}});               // living|kitchen
  wall_with_openings(w, {0, 6.2}, {10, 6.2}, {{2.0, 2.9}, {5.5, 6.4}, {8.2, 9.4}});  // corridor N
  w.add_wall({5, 6.2}, {5, 10});
  w.add_wall({7.5, 6.2}, {7.5, 10});
  const double half_pi = std::numbers::pi / 2;
  // Doors: leaf length 0.9, closed along +x from the hinge.
  add_named_door(s, "door_living", {{2.0, 5.0}, 0.0, 0.9, -half_pi});  // open into the living room
  add_named_door(s, "door_bedroom", {{2.0, 6.2}, 0.0, 0.9, half_pi});  // open into the bedroom
  add_named_door(s, "door_bathroom", {{5.5, 6.2}, 0.0, 0.9, 0.0});     // closed

  // Living room.
  {
    SceneObject couch = make_object("couch", "couch");
    add_box(s, couch, {{3, 0.5}, {2.0, 0.9}, 0, 0, 0.42});
    add_box(s, couch, {{3, 0.1}, {2.0, 0.2}, 0, 0.42, 0.85});
    s.objects.push_back(std::move(couch));
  }
  add_table(s, "couch_table", {3, 1.8}, {1.2, 0.6}, 0.44, 0.02);
  {
    SceneObject sideboard = make_object("sideboard", "cabinet");
    add_box(s, sideboard, {{4.5, 4.75}, {1.6, 0.4}, 0, 0, 0.5});
    s.objects.push_back(std::move(sideboard));
  }
  add_can(s, "can_red", {1.0, 3.0}, 0.10);
  add_can(s, "can_blue", {5.5, 0.6}, 0.10);
  add_small_box(s, "book", {0.8, 1.5}, {0.22, 0.15}, 0.03, 0.4);
  add_small_box(s, "toy_block", {4.9, 0.8}, {0.06, 0.06}, 0.06);
  add_small_box(s, "shoe", {0.5, 5.5}, {0.28, 0.1}, 0.1, 0.2);

  // Kitchen.
  {
    SceneObject counter = make_object("counter", "cabinet");
    add_box(s, counter, {{8, 0.3}, {4.0, 0.6}, 0, 0, 0.9});
    s.objects.push_back(std::move(counter));
  }
  add_table(s, "dining_table", {7.8, 2.6}, {1.4, 0.8}, 0.76, 0.025);
  add_chair(s, "chair_1", {7.4, 1.95}, half_pi);
  add_chair(s, "chair_2", {8.2, 1.95}, half_pi);
  add_chair(s, "chair_3", {7.8, 3.35}, -half_pi);
  {
    SceneObject dresser = make_object("dresser", "cabinet");
    add_box(s, dresser, {{9.75, 3.5}, {0.5, 1.2}, 0, 0, 0.85});
    s.objects.push_back(std::move(dresser));
    SceneObject drawer = make_object("drawer", "drawer");
    add_box(s, drawer, {{9.35, 3.5}, {0.3, 0.6}, 0, 0.55, 0.70});  // pulled out by 30 cm
    s.objects.push_back(std::move(drawer));
  }

  // Bedroom, bathroom, stairwell.
  {
    SceneObject bed = make_object("bed", "bed");
    add_box(s, bed, {{1.1, 8.6}, {2.0, 1.6}, half_pi, 0, 0.5});
    s.objects.push_back(std::move(bed));
    SceneObject wardrobe = make_object("wardrobe", "cabinet");
    add_box(s, wardrobe, {{4.0, 9.7}, {1.2, 0.6}, 0, 0, 2.0});
    s.objects.push_back(std::move(wardrobe));
    SceneObject tub = make_object("bathtub", "bathtub");
    add_box(s, tub, {{6.25, 9.2}, {1.7, 0.75}, 0, 0, 0.55});
    s.objects.push_back(std::move(tub));
  }
  add_stair(s, "stair", 8.2, 9.4, 7.2, 6, 0.28, 0.18, 10.0);

  w.build_index();
  s.start = {1.0, 5.6, 0.0};
  s.tour = {{2.45, 5.6}, {2.45, 3.4}, {4.9, 3.0}, {5.5, 2.0}, {6.5, 2.0}, {6.6, 1.2},
            {8.85, 1.2}, {8.85, 4.3}, {7.5, 4.3}, {7.5, 5.6}, {8.8, 5.6}, {8.8, 6.7}};
  return s;
}

/// Number of doors of office_corridor(): 4 on the south side (indices 0-3, west to east), then
/// 4 on the north side (4-7).
inline constexpr std::size_t office_corridor_door_count = 8;

/// A 20 m x 2 m corridor (x in [0, 20], y in [0, 2]) with offices 4 m deep on both sides, each
/// 5 m wide with a 0.9 m door centred at x = 2.5 + 5 k. door_openings (rad in [-pi, pi]; > 0 opens
/// into the office, < 0 into the corridor; empty = all closed) sets the 8 doors in the order of
/// office_corridor_door_count. A door opened into the corridor by more than about 40 deg blocks
/// a robot of radius 0.3 m on the centre line.
/// `door_centers` (empty: 2.5 + 5 k) moves the doors along their walls, each within its own
/// office (at least 0.5 m from its partitions, and clear of the alcove): a real corridor's doors
/// are not evenly spaced, and with evenly spaced doors every office looks like the next one.
/// Objects: door_s0..door_s3, door_n0..door_n3. start = (1, 1, 0); tour along the corridor.
/// With closed doors this corridor is symmetric under a half turn about (10, 1): a robot in it
/// cannot tell x from 20 - x. `copier_alcove` adds what a real office corridor has and breaks
/// that symmetry: a 1.2 m wide, 0.5 m deep alcove in the north wall at x in [8.4, 9.6] (object
/// "copier_alcove", taken from the north office between the doors n1 and n2).
[[nodiscard]] inline Scene office_corridor(const std::vector<double>& door_openings = {},
                                           bool copier_alcove = false,
                                           const std::vector<double>& door_centers = {}) {
  using namespace detail_worlds;
  if (!door_openings.empty() && door_openings.size() != office_corridor_door_count)
    detail::throw_invalid_argument("office_corridor", "door_openings.size()", door_openings.size(),
                                   "must be 0 or 8");
  for (const double a : door_openings)
    if (!(std::isfinite(a) && std::abs(a) <= std::numbers::pi))
      detail::throw_invalid_argument("office_corridor", "door_openings[i]", a,
                                     "must be in [-pi, pi]");
  if (!door_centers.empty() && door_centers.size() != office_corridor_door_count)
    detail::throw_invalid_argument("office_corridor", "door_centers.size()", door_centers.size(),
                                   "must be 0 or 8");
  const double length = 20, width = 2, depth = 4, door = 0.9;
  const auto center = [&](std::size_t i) {
    return door_centers.empty() ? 2.5 + 5.0 * static_cast<double>(i % 4) : door_centers[i];
  };
  for (std::size_t i = 0; i < door_centers.size(); ++i) {
    const double lo = 5.0 * static_cast<double>(i % 4) + 0.5, c = door_centers[i];
    const bool in_alcove = copier_alcove && i >= 4 && c + door / 2 > 8.4 && c - door / 2 < 9.6;
    if (!(c >= lo && c <= lo + 4.0) || in_alcove)
      detail::throw_invalid_argument(
          "office_corridor", "door_centers[" + std::to_string(i) + "]", c,
          "must be in [" + detail::format_value(lo) + ", " + detail::format_value(lo + 4.0) +
              "] (its office)" + (copier_alcove && i >= 4 ? " and clear of the alcove" : ""));
  }
  Scene s;
  World& w = s.world;
  w.set_ceiling_height(2.6);
  for (int side = 0; side < 2; ++side) {
    const double y = side == 0 ? 0.0 : width;
    const double y_far = side == 0 ? -depth : width + depth;
    std::vector<std::pair<double, double>> openings;
    for (std::size_t k = 0; k < 4; ++k) {
      const double c = center(static_cast<std::size_t>(side) * 4 + k);
      openings.emplace_back(c - door / 2, c + door / 2);
    }
    if (side == 1 && copier_alcove) openings.emplace_back(8.4, 9.6);
    std::sort(openings.begin(), openings.end());
    wall_with_openings(w, {0, y}, {length, y}, openings);
    w.add_wall({0, y_far}, {length, y_far});
    for (int k = 0; k <= 4; ++k)
      w.add_wall({5.0 * k, y}, {5.0 * k, y_far});
    for (int k = 0; k < 4; ++k) {
      const std::size_t i = static_cast<std::size_t>(side * 4 + k);
      const double open = door_openings.empty() ? 0.0 : door_openings[i];
      std::string name = side == 0 ? "door_s" : "door_n";
      name.append(std::to_string(k));
      add_named_door(s, std::move(name),
                     {{center(i) - door / 2, y}, 0.0, door, side == 0 ? -open : open});
    }
  }
  if (copier_alcove) {
    SceneObject alcove = make_object("copier_alcove", "alcove");
    for (const auto& [a, b] : {std::pair<Point2d, Point2d>{{8.4, width}, {8.4, width + 0.5}},
                               {{8.4, width + 0.5}, {9.6, width + 0.5}},
                               {{9.6, width + 0.5}, {9.6, width}}})
      alcove.parts.push_back({SurfaceKind::wall, u32(w.add_wall(a, b))});
    alcove.min = {8.4, width, 0};
    alcove.max = {9.6, width + 0.5, 2.5};
    s.objects.push_back(std::move(alcove));
  }
  w.add_wall({0, 0}, {0, width});
  w.add_wall({length, 0}, {length, width});
  w.build_index();
  s.start = {1.0, 1.0, 0.0};
  s.tour = {{19.0, 1.0}};
  return s;
}

/// A 5 m x 4 m kitchen (x in [0, 5], y in [0, 4], walls 2.5 m): cabinets against the wall x = 0
/// with their front at x = 0.6 (y in [0.5, 3.5], up to 0.9 m), a counter top 0.90-0.94 m
/// overhanging by 5 cm, a table (top at 0.75 m) at (2.6, 2) with a cereal box and a bottle on it.
/// planes: floor, wall, kitchen_front, counter_top, table_top. start = (4.2, 2, pi) looking at
/// the kitchen front.
[[nodiscard]] inline Scene kitchen() {
  using namespace detail_worlds;
  Scene s;
  World& w = s.world;
  const std::vector<Point2d> outer{{0, 0}, {5, 0}, {5, 4}, {0, 4}};
  w.add_polygon(outer, 2.5);
  {
    SceneObject cabinets = make_object("cabinets", "cabinet");
    add_box(s, cabinets, {{0.3, 2.0}, {0.6, 3.0}, 0, 0, 0.9});
    s.objects.push_back(std::move(cabinets));
    SceneObject counter = make_object("counter_top", "counter");
    add_box(s, counter, {{0.325, 2.0}, {0.65, 3.0}, 0, 0.9, 0.94});
    s.objects.push_back(std::move(counter));
  }
  add_table(s, "table", {2.6, 2.0}, {1.2, 0.8}, 0.75, 0.025, 0.03);
  {
    SceneObject cereal = make_object("cereal_box", "object");
    add_box(s, cereal, {{2.4, 1.9}, {0.2, 0.07}, 0.3, 0.75, 1.05});
    s.objects.push_back(std::move(cereal));
    SceneObject bottle = make_object("bottle", "object");
    add_cylinder(s, bottle, {{2.85, 2.15}, 0.04, 0.75, 1.0});
    s.objects.push_back(std::move(bottle));
  }
  w.build_index();
  const auto rect_z = [](double x0, double y0, double x1, double y1, double z) {
    return std::vector<Point3d>{{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
  };
  const auto rect_x = [](double x, double y0, double y1, double z0, double z1) {
    return std::vector<Point3d>{{x, y0, z0}, {x, y1, z0}, {x, y1, z1}, {x, y0, z1}};
  };
  s.planes.push_back({"floor", {0, 0, 1}, 0.0, rect_z(0, 0, 5, 4, 0)});
  s.planes.push_back({"wall", {1, 0, 0}, 0.0, rect_x(0, 0, 4, 0, 2.5)});
  s.planes.push_back({"kitchen_front", {1, 0, 0}, -0.6, rect_x(0.6, 0.5, 3.5, 0, 0.9)});
  s.planes.push_back({"counter_top", {0, 0, 1}, -0.94, rect_z(0, 0.5, 0.65, 3.5, 0.94)});
  s.planes.push_back({"table_top", {0, 0, 1}, -0.75, rect_z(2.0, 1.6, 3.2, 2.4, 0.75)});
  s.start = {4.2, 2.0, std::numbers::pi};
  return s;
}

/// A straight corridor 2 m wide and 83 m long (x in [-3, 80], y in [-1, 1], walls 2.5 m), where
/// scans fix the lateral position and the heading but hardly the position along the axis: the
/// case in which a SLAM front end must let the odometry carry that direction. With `boxes`, nine
/// 0.3 m boxes 1 m high stand unevenly spaced against alternate walls (objects box_0..box_8,
/// centred at x = 2.3, 7.9, 15.2, 21.7, 30.4, 38.8, 47.1, 55.6, 63.0 and y = -0.85, +0.85, ...);
/// bare, only the far end wall at x = 80 ends the corridor. start = (0, 0, 0); the tour runs
/// along the axis to (75, 0).
[[nodiscard]] inline Scene long_corridor(bool boxes = true) {
  using namespace detail_worlds;
  Scene s;
  s.world.add_polygon(std::vector<Point2d>{{-3, -1}, {80, -1}, {80, 1}, {-3, 1}});
  if (boxes) {
    const double xs[] = {2.3, 7.9, 15.2, 21.7, 30.4, 38.8, 47.1, 55.6, 63.0};
    for (std::size_t i = 0; i < std::size(xs); ++i) {
      SceneObject box = make_object("box_" + std::to_string(i), "box");
      add_box(s, box, {{xs[i], i % 2 ? 0.85 : -0.85}, {0.3, 0.3}, 0.0, 0.0, 1.0});
      s.objects.push_back(std::move(box));
    }
  }
  s.world.build_index();
  s.start = {0, 0, 0};
  s.tour = {{75, 0}};
  return s;
}

}  // namespace rangenav::sim
