#pragma once
// World: the simulated environment the sensors of rangenav::sim look at.
//
// A world is made of
//   - walls: vertical planes over a 2D segment, from the floor (z = 0) up to a settable height;
//   - boxes: rotated (about z) rectangular blocks with a z-range (table tops, drawers, cans);
//   - cylinders: vertical round blocks with a z-range (table and chair legs, bottles);
//   - hinged doors: a thin box from the floor to the door height that turns about its hinge by
//     a settable opening angle (0 = closed; positive turns counter-clockwise);
//   - floor holes: rotated rectangles where the floor lies `depth` below z = 0 (a descending stair
//     is a row of adjoining holes of increasing depth, paper 002 §4.2);
//   - an optional ceiling.
// These are the obstacle types of Fig. 2 of paper 002 (small objects on the floor, table tops
// above the scan plane, overhanging drawers, descending stairs).
//
// Rays are cast in 2D (a horizontal beam at height z sees walls, doors and solids whose z-range
// contains z) and in 3D (any ray; it also sees the floor, the holes and the ceiling). Both walk a
// uniform grid over the world with a DDA (Amanatides & Woo) and stop at the first cell behind the
// nearest hit, so the cost depends on the free space in front of the sensor, not on the world's
// size. Call build_index() after adding primitives (the built-in worlds and load_world() do);
// without an index the casts test every primitive (same answers, slower). Opening or closing a
// door needs no rebuild: the grid holds the disk the leaf sweeps.
//
// A ray that starts inside a solid does not see that solid (only surfaces facing the origin count).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav::sim {

/// A vertical wall over the segment a-b, from the floor up to `height`.
struct Wall {
  Point2d a{0, 0};     ///< one end (m)
  Point2d b{0, 0};     ///< the other end (m)
  double height{2.5};  ///< m above the floor
};

/// A block rotated by `yaw` about z: footprint centred at `center` with full side lengths
/// `size` along its own x and y axes, occupying z_min <= z <= z_max.
struct Box {
  Point2d center{0, 0};  ///< footprint centre (m)
  Point2d size{0, 0};    ///< full side lengths along its own axes (m)
  double yaw{0};         ///< rad about z
  double z_min{0};       ///< m, bottom
  double z_max{0};       ///< m, top
};

/// A vertical cylinder of `radius` about `center`, occupying z_min <= z <= z_max.
struct Cylinder {
  Point2d center{0, 0};  ///< axis position (m)
  double radius{0};      ///< m
  double z_min{0};       ///< m, bottom
  double z_max{0};       ///< m, top
};

/// A hinged door leaf. Closed, the leaf extends `length` from the hinge in direction
/// `closed_yaw`; the leaf direction is closed_yaw + opening.
struct Door {
  Point2d hinge{0, 0};     ///< the hinge (m)
  double closed_yaw{0};    ///< rad, direction of the closed leaf
  double length{0.9};      ///< m, leaf length
  double opening{0};       ///< rad, 0 = closed, positive turns counter-clockwise
  double thickness{0.04};  ///< m
  double height{2.0};      ///< m

  /// The leaf as a box: from the hinge along closed_yaw + opening, centred across its thickness.
  [[nodiscard]] Box leaf() const {
    const double yaw = closed_yaw + opening;
    const Point2d dir(std::cos(yaw), std::sin(yaw));
    return {hinge + dir * (length / 2), {length, thickness}, yaw, 0.0, height};
  }
};

/// A region where the floor lies `depth` below z = 0 (a rotated rectangle as for Box).
struct FloorHole {
  Point2d center{0, 0};  ///< centre (m)
  Point2d size{0, 0};    ///< full side lengths along its own axes (m)
  double yaw{0};         ///< rad about z
  double depth{0};       ///< m below z = 0
};

/// What a ray hit.
enum class SurfaceKind : std::uint8_t {
  none,      ///< nothing within the maximum range
  wall,      ///< walls()[index]
  box,       ///< boxes()[index]
  cylinder,  ///< cylinders()[index]
  door,      ///< doors()[index]
  floor,     ///< the floor at z = 0
  hole,      ///< the lowered floor or a side (stair riser) of holes()[index]
  ceiling,   ///< the ceiling
};

/// The nearest surface along a ray: its distance from the origin (along the unit direction),
/// what it is and which one. range is +inf when nothing was hit.
struct RayHit {
  /// m along the ray, +inf when nothing was hit
  double range{std::numeric_limits<double>::infinity()};
  SurfaceKind kind{SurfaceKind::none};  ///< what was hit
  std::uint32_t index{0};               ///< which one, for primitives

  /// True when something was hit.
  [[nodiscard]] bool hit() const { return kind != SurfaceKind::none; }
};

/// A primitive of a World: its kind (wall, box, cylinder, door, hole) and index.
struct PrimitiveRef {
  SurfaceKind kind{SurfaceKind::none};  ///< its kind
  std::uint32_t index{0};               ///< its index in the World's list of that kind
  friend bool operator==(const PrimitiveRef&, const PrimitiveRef&) = default;
  friend bool operator<(const PrimitiveRef& a, const PrimitiveRef& b) {
    return a.kind != b.kind ? a.kind < b.kind : a.index < b.index;
  }
};

/// A simulated world of walls, boxes, cylinders, doors, floor holes and an optional ceiling,
/// with ray casting in 2D and 3D through a uniform grid (call build_index() after adding).
class World {
 public:
  // ---- building ----------------------------------------------------------------------------

  /// Adds a wall; returns its index. Throws invalid_argument for a non-finite or degenerate one.
  std::size_t add_wall(const Wall& wall) {
    constexpr std::string_view where = "World::add_wall";
    require_finite_point(where, "a", wall.a);
    require_finite_point(where, "b", wall.b);
    detail::require_positive(where, "height", wall.height);
    if (wall.a == wall.b) detail::throw_invalid(where, "wall end points a and b coincide");
    walls_.push_back(wall);
    index_built_ = false;
    return walls_.size() - 1;
  }

  /// Adds the wall a-b of `height`; returns its index.
  std::size_t add_wall(const Point2d& a, const Point2d& b, double height = 2.5) {
    return add_wall(Wall{a, b, height});
  }

  /// Walls along a closed polygon (the last vertex joins the first). Needs at least 3 vertices.
  void add_polygon(std::span<const Point2d> vertices, double height = 2.5) {
    if (vertices.size() < 3)
      detail::throw_invalid_argument("World::add_polygon", "vertices.size()", vertices.size(),
                                     "must be >= 3");
    for (std::size_t i = 0; i < vertices.size(); ++i)
      add_wall(vertices[i], vertices[(i + 1) % vertices.size()], height);
  }

  /// Adds a box; returns its index. Throws invalid_argument for an invalid one.
  std::size_t add_box(const Box& box) {
    constexpr std::string_view where = "World::add_box";
    require_finite_point(where, "center", box.center);
    detail::require_positive(where, "size.x", box.size.x());
    detail::require_positive(where, "size.y", box.size.y());
    detail::require_finite(where, "yaw", box.yaw);
    require_z_range(where, box.z_min, box.z_max);
    boxes_.push_back(box);
    box_cache_.push_back(CachedBox::from(box));
    index_built_ = false;
    return boxes_.size() - 1;
  }

  /// Adds a cylinder; returns its index. Throws invalid_argument for an invalid one.
  std::size_t add_cylinder(const Cylinder& cylinder) {
    constexpr std::string_view where = "World::add_cylinder";
    require_finite_point(where, "center", cylinder.center);
    detail::require_positive(where, "radius", cylinder.radius);
    require_z_range(where, cylinder.z_min, cylinder.z_max);
    cylinders_.push_back(cylinder);
    index_built_ = false;
    return cylinders_.size() - 1;
  }

  /// Adds a door; returns its index. Throws invalid_argument for an invalid one.
  std::size_t add_door(const Door& door) {
    constexpr std::string_view where = "World::add_door";
    require_finite_point(where, "hinge", door.hinge);
    detail::require_finite(where, "closed_yaw", door.closed_yaw);
    detail::require_positive(where, "length", door.length);
    detail::require_finite(where, "opening", door.opening);
    detail::require_positive(where, "thickness", door.thickness);
    detail::require_positive(where, "height", door.height);
    doors_.push_back(door);
    door_cache_.push_back(CachedBox::from(door.leaf()));
    index_built_ = false;
    return doors_.size() - 1;
  }

  /// Adds a floor hole; returns its index. Throws invalid_argument for an invalid one.
  std::size_t add_hole(const FloorHole& hole) {
    constexpr std::string_view where = "World::add_hole";
    require_finite_point(where, "center", hole.center);
    detail::require_positive(where, "size.x", hole.size.x());
    detail::require_positive(where, "size.y", hole.size.y());
    detail::require_finite(where, "yaw", hole.yaw);
    detail::require_positive(where, "depth", hole.depth);
    holes_.push_back(hole);
    hole_cache_.push_back(CachedBox::from(Box{hole.center, hole.size, hole.yaw, -hole.depth, 0}));
    return holes_.size() - 1;
  }

  /// The ceiling height (> 0), or 0 for no ceiling (the default).
  void set_ceiling_height(double height) {
    detail::require_non_negative("World::set_ceiling_height", "height", height);
    ceiling_height_ = height;
  }
  /// The ceiling's height (m); 0 = no ceiling.
  [[nodiscard]] double ceiling_height() const { return ceiling_height_; }

  /// Turns door i to `opening` rad (0 = closed). Needs no index rebuild.
  void set_door_opening(std::size_t i, double opening) {
    if (i >= doors_.size())
      detail::throw_invalid_argument("World::set_door_opening", "i", i,
                                     "must be < door count " + std::to_string(doors_.size()));
    detail::require_finite("World::set_door_opening", "opening", opening);
    doors_[i].opening = opening;
    door_cache_[i] = CachedBox::from(doors_[i].leaf());
  }

  /// The walls.
  [[nodiscard]] const std::vector<Wall>& walls() const { return walls_; }
  /// The boxes.
  [[nodiscard]] const std::vector<Box>& boxes() const { return boxes_; }
  /// The cylinders.
  [[nodiscard]] const std::vector<Cylinder>& cylinders() const { return cylinders_; }
  /// The doors.
  [[nodiscard]] const std::vector<Door>& doors() const { return doors_; }
  /// The floor holes.
  [[nodiscard]] const std::vector<FloorHole>& holes() const { return holes_; }
  /// Number of primitives of every kind.
  [[nodiscard]] std::size_t primitive_count() const {
    return walls_.size() + boxes_.size() + cylinders_.size() + doors_.size();
  }

  // ---- spatial index -----------------------------------------------------------------------

  /// Builds the uniform grid. cell_size <= 0 picks one from the primitives' density.
  void build_index(double cell_size = 0) {
    if (!std::isfinite(cell_size))
      detail::throw_invalid_argument("World::build_index", "cell_size", cell_size,
                                     "must be finite");
    grid_min_ = Point2d::Constant(std::numeric_limits<double>::infinity());
    grid_max_ = Point2d::Constant(-std::numeric_limits<double>::infinity());
    for_each_bounds([&](std::uint32_t, const Point2d& lo, const Point2d& hi) {
      grid_min_ = grid_min_.cwiseMin(lo);
      grid_max_ = grid_max_.cwiseMax(hi);
    });
    cell_offsets_.clear();
    cell_items_.clear();
    nx_ = ny_ = 0;
    index_built_ = true;
    if (primitive_count() == 0) return;
    grid_min_ -= Point2d::Constant(1e-6);
    grid_max_ += Point2d::Constant(1e-6);
    const Point2d extent = grid_max_ - grid_min_;
    if (cell_size <= 0) {
      // About four cells per primitive, but not finer than 0.25 m or coarser than 2 m.
      const double area = extent.x() * extent.y();
      cell_size =
          std::clamp(std::sqrt(area / (4.0 * static_cast<double>(primitive_count()))), 0.25, 2.0);
    }
    constexpr double max_cells_per_axis = 4096;
    cell_size =
        std::max({cell_size, extent.x() / max_cells_per_axis, extent.y() / max_cells_per_axis});
    cell_size_ = cell_size;
    nx_ = static_cast<std::size_t>(std::ceil(extent.x() / cell_size));
    ny_ = static_cast<std::size_t>(std::ceil(extent.y() / cell_size));
    nx_ = std::max<std::size_t>(nx_, 1);
    ny_ = std::max<std::size_t>(ny_, 1);
    std::vector<std::uint32_t> counts(nx_ * ny_ + 1, 0);
    for (int pass = 0; pass < 2; ++pass) {
      std::vector<std::uint32_t> fill;
      if (pass == 1) {
        cell_offsets_.assign(nx_ * ny_ + 1, 0);
        for (std::size_t c = 0; c < nx_ * ny_; ++c)
          cell_offsets_[c + 1] = cell_offsets_[c] + counts[c];
        cell_items_.resize(cell_offsets_.back());
        fill.assign(cell_offsets_.begin(), cell_offsets_.end() - 1);
      }
      for_each_bounds([&](std::uint32_t item, const Point2d& lo, const Point2d& hi) {
        const auto [x0, y0] = cell_of(lo);
        const auto [x1, y1] = cell_of(hi);
        for (std::size_t iy = y0; iy <= y1; ++iy)
          for (std::size_t ix = x0; ix <= x1; ++ix) {
            if (kind_of(item) == wall_tag && !segment_touches_cell(item, ix, iy)) continue;
            const std::size_t c = iy * nx_ + ix;
            if (pass == 0)
              ++counts[c];
            else
              cell_items_[fill[c]++] = item;
          }
      });
    }
  }

  /// True once build_index() has run since the last change.
  [[nodiscard]] bool has_index() const { return index_built_; }
  /// The ray-casting grid's cell edge (m).
  [[nodiscard]] double cell_size() const { return cell_size_; }

  // ---- ray casting -------------------------------------------------------------------------

  /// The nearest wall, door, box or cylinder hit by a horizontal beam at height z from `origin`
  /// along the unit `direction`, within max_range.
  [[nodiscard]] RayHit cast_ray_2d(const Point2d& origin, const Point2d& direction, double z,
                                   double max_range) const {
    RayHit best;
    best.range = max_range;
    const Point3d o(origin.x(), origin.y(), z), d(direction.x(), direction.y(), 0);
    if (!index_built_) {
      for_each_item([&](std::uint32_t item) { test_item_2d(item, o, d, best); });
    } else {
      traverse(o, d, max_range, best,
               [&](std::uint32_t item, RayHit& b) { test_item_2d(item, o, d, b); });
    }
    return finish(best);
  }

  /// The nearest surface (including floor, holes and ceiling) hit by the ray from `origin` along
  /// the unit `direction`, within max_range.
  [[nodiscard]] RayHit cast_ray(const Point3d& origin, const Point3d& direction,
                                double max_range) const {
    RayHit best;
    best.range = max_range;
    floor_and_ceiling(origin, direction, best);
    if (!index_built_) {
      for_each_item([&](std::uint32_t item) { test_item_3d(item, origin, direction, best); });
    } else {
      traverse(origin, direction, best.range, best,
               [&](std::uint32_t item, RayHit& b) { test_item_3d(item, origin, direction, b); });
    }
    return finish(best);
  }

  /// cast_ray_2d testing every primitive, ignoring the index (a reference for tests).
  [[nodiscard]] RayHit cast_ray_2d_exhaustive(const Point2d& origin, const Point2d& direction,
                                              double z, double max_range) const {
    RayHit best;
    best.range = max_range;
    const Point3d o(origin.x(), origin.y(), z), d(direction.x(), direction.y(), 0);
    for_each_item([&](std::uint32_t item) { test_item_2d(item, o, d, best); });
    return finish(best);
  }

  /// cast_ray testing every primitive, ignoring the index (a reference for tests).
  [[nodiscard]] RayHit cast_ray_exhaustive(const Point3d& origin, const Point3d& direction,
                                           double max_range) const {
    RayHit best;
    best.range = max_range;
    floor_and_ceiling(origin, direction, best);
    for_each_item([&](std::uint32_t item) { test_item_3d(item, origin, direction, best); });
    return finish(best);
  }

  /// The walls, boxes, cylinders and doors whose 2D bounds (a door's: its sweep) may overlap the
  /// axis-aligned box [lo, hi], each once, sorted; then the holes that overlap it. A superset:
  /// callers test the exact shapes.
  void primitives_near(const Point2d& lo, const Point2d& hi, std::vector<PrimitiveRef>& out) const {
    out.clear();
    const auto overlaps = [&](const Point2d& a, const Point2d& b) {
      return a.x() <= hi.x() && b.x() >= lo.x() && a.y() <= hi.y() && b.y() >= lo.y();
    };
    const auto push = [&](std::uint32_t item) {
      constexpr SurfaceKind kinds[] = {SurfaceKind::wall, SurfaceKind::box, SurfaceKind::cylinder,
                                       SurfaceKind::door};
      out.push_back({kinds[kind_of(item)], index_of(item)});
    };
    if (!index_built_ || nx_ == 0) {
      for_each_bounds([&](std::uint32_t item, const Point2d& a, const Point2d& b) {
        if (overlaps(a, b)) push(item);
      });
    } else {
      const auto [x0, y0] = cell_of(lo);
      const auto [x1, y1] = cell_of(hi);
      for (std::size_t iy = y0; iy <= y1; ++iy)
        for (std::size_t ix = x0; ix <= x1; ++ix) {
          const std::size_t c = iy * nx_ + ix;
          for (std::uint32_t k = cell_offsets_[c]; k < cell_offsets_[c + 1]; ++k)
            push(cell_items_[k]);
        }
      std::sort(out.begin(), out.end());
      out.erase(std::unique(out.begin(), out.end()), out.end());
    }
    for (std::size_t i = 0; i < hole_cache_.size(); ++i)
      if (overlaps(hole_cache_[i].center - hole_cache_[i].bound_half,
                   hole_cache_[i].center + hole_cache_[i].bound_half))
        out.push_back({SurfaceKind::hole, static_cast<std::uint32_t>(i)});
  }

  /// The floor height at p: 0, or minus the depth of the deepest hole containing p.
  [[nodiscard]] double floor_height(const Point2d& p) const {
    double z = 0;
    for (const auto& h : hole_cache_)
      if (h.contains_xy(p)) z = std::min(z, h.z_min);
    return z;
  }

  /// The axis-aligned bounds of the walls, solids and door sweeps (empty world: +inf / -inf).
  [[nodiscard]] std::pair<Point2d, Point2d> bounds() const {
    Point2d lo = Point2d::Constant(std::numeric_limits<double>::infinity());
    Point2d hi = -lo;
    for_each_bounds([&](std::uint32_t, const Point2d& a, const Point2d& b) {
      lo = lo.cwiseMin(a);
      hi = hi.cwiseMax(b);
    });
    for (const auto& h : hole_cache_) {
      lo = lo.cwiseMin(h.center - h.bound_half);
      hi = hi.cwiseMax(h.center + h.bound_half);
    }
    return {lo, hi};
  }

 private:
  static constexpr std::uint32_t wall_tag = 0, box_tag = 1, cylinder_tag = 2, door_tag = 3;
  static constexpr std::uint32_t index_mask = (1u << 30) - 1;
  static std::uint32_t make_item(std::uint32_t tag, std::size_t i) {
    return (tag << 30) | static_cast<std::uint32_t>(i);
  }
  static std::uint32_t kind_of(std::uint32_t item) { return item >> 30; }
  static std::uint32_t index_of(std::uint32_t item) { return item & index_mask; }

  /// A rotated box with its rotation precomputed.
  struct CachedBox {
    Point2d center{0, 0};
    Point2d half{0, 0};
    Point2d bound_half{0, 0};  ///< half extents of the axis-aligned bounds
    double c{1}, s{0};
    double z_min{0}, z_max{0};

    static CachedBox from(const Box& b) {
      CachedBox k;
      k.center = b.center;
      k.half = b.size / 2;
      k.c = std::cos(b.yaw);
      k.s = std::sin(b.yaw);
      k.bound_half = {std::abs(k.c) * k.half.x() + std::abs(k.s) * k.half.y(),
                      std::abs(k.s) * k.half.x() + std::abs(k.c) * k.half.y()};
      k.z_min = b.z_min;
      k.z_max = b.z_max;
      return k;
    }
    [[nodiscard]] Point2d to_local(const Point2d& v) const {
      return {c * v.x() + s * v.y(), -s * v.x() + c * v.y()};
    }
    [[nodiscard]] bool contains_xy(const Point2d& p) const {
      const Point2d q = to_local(p - center);
      return std::abs(q.x()) <= half.x() && std::abs(q.y()) <= half.y();
    }
  };

  static void require_finite_point(std::string_view where, std::string_view name,
                                   const Point2d& p) {
    if (!p.allFinite())
      detail::throw_invalid_argument(where, name, p.transpose(), "must be finite");
  }
  static void require_z_range(std::string_view where, double z_min, double z_max) {
    detail::require_finite(where, "z_min", z_min);
    detail::require_finite(where, "z_max", z_max);
    if (!(z_max > z_min))
      detail::throw_invalid_argument(where, "z_max", z_max,
                                     "must exceed z_min = " + detail::format_value(z_min));
  }

  template <class F>
  void for_each_item(F&& f) const {
    for (std::size_t i = 0; i < walls_.size(); ++i)
      f(make_item(wall_tag, i));
    for (std::size_t i = 0; i < boxes_.size(); ++i)
      f(make_item(box_tag, i));
    for (std::size_t i = 0; i < cylinders_.size(); ++i)
      f(make_item(cylinder_tag, i));
    for (std::size_t i = 0; i < doors_.size(); ++i)
      f(make_item(door_tag, i));
  }

  /// Calls f(item, lo, hi) with each primitive's axis-aligned 2D bounds (doors: their sweep).
  template <class F>
  void for_each_bounds(F&& f) const {
    for (std::size_t i = 0; i < walls_.size(); ++i)
      f(make_item(wall_tag, i), walls_[i].a.cwiseMin(walls_[i].b),
        walls_[i].a.cwiseMax(walls_[i].b));
    for (std::size_t i = 0; i < boxes_.size(); ++i)
      f(make_item(box_tag, i), box_cache_[i].center - box_cache_[i].bound_half,
        box_cache_[i].center + box_cache_[i].bound_half);
    for (std::size_t i = 0; i < cylinders_.size(); ++i)
      f(make_item(cylinder_tag, i), cylinders_[i].center - Point2d::Constant(cylinders_[i].radius),
        cylinders_[i].center + Point2d::Constant(cylinders_[i].radius));
    for (std::size_t i = 0; i < doors_.size(); ++i) {
      const double r = std::hypot(doors_[i].length, doors_[i].thickness / 2);
      f(make_item(door_tag, i), doors_[i].hinge - Point2d::Constant(r),
        doors_[i].hinge + Point2d::Constant(r));
    }
  }

  [[nodiscard]] std::pair<std::size_t, std::size_t> cell_of(const Point2d& p) const {
    const auto clamp_cell = [](double v, std::size_t n) {
      if (!(v > 0)) return std::size_t{0};
      const auto c = static_cast<std::size_t>(v);
      return std::min(c, n - 1);
    };
    return {clamp_cell((p.x() - grid_min_.x()) / cell_size_, nx_),
            clamp_cell((p.y() - grid_min_.y()) / cell_size_, ny_)};
  }

  /// Whether wall `item`'s segment passes through cell (ix, iy) (Liang-Barsky clipping).
  [[nodiscard]] bool segment_touches_cell(std::uint32_t item, std::size_t ix,
                                          std::size_t iy) const {
    const Wall& w = walls_[index_of(item)];
    const double pad = 1e-9;
    const Point2d lo = grid_min_ +
                       Point2d(static_cast<double>(ix), static_cast<double>(iy)) * cell_size_ -
                       Point2d::Constant(pad);
    const Point2d hi = lo + Point2d::Constant(cell_size_ + 2 * pad);
    const Point2d d = w.b - w.a;
    double t0 = 0, t1 = 1;
    for (int k = 0; k < 2; ++k) {
      if (d[k] == 0) {
        if (w.a[k] < lo[k] || w.a[k] > hi[k]) return false;
        continue;
      }
      double ta = (lo[k] - w.a[k]) / d[k], tb = (hi[k] - w.a[k]) / d[k];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      if (t0 > t1) return false;
    }
    return true;
  }

  /// Walks the grid cells along the ray's xy projection in order, calling test(item, best) for
  /// every item in each cell, until the nearest hit lies before the current cell's exit.
  template <class Test>
  void traverse(const Point3d& o, const Point3d& d, double t_end, RayHit& best, Test&& test) const {
    if (nx_ == 0) return;
    // Clip the ray to the grid's bounds (slab test in x and y).
    double t_in = 0, t_out = t_end;
    for (int k = 0; k < 2; ++k) {
      if (d[k] == 0) {
        if (o[k] < grid_min_[k] || o[k] > grid_max_[k]) return;
        continue;
      }
      double ta = (grid_min_[k] - o[k]) / d[k], tb = (grid_max_[k] - o[k]) / d[k];
      if (ta > tb) std::swap(ta, tb);
      t_in = std::max(t_in, ta);
      t_out = std::min(t_out, tb);
    }
    if (t_in > t_out) return;
    const Point2d start(o.x() + t_in * d.x(), o.y() + t_in * d.y());
    auto [ix, iy] = cell_of(start);
    constexpr double inf = std::numeric_limits<double>::infinity();
    const auto axis_setup = [&](int k, std::size_t cell, double& t_next, double& t_delta) {
      if (d[k] == 0) {
        t_next = t_delta = inf;
        return;
      }
      const double boundary =
          grid_min_[k] + (static_cast<double>(cell) + (d[k] > 0 ? 1.0 : 0.0)) * cell_size_;
      t_next = (boundary - o[k]) / d[k];
      t_delta = cell_size_ / std::abs(d[k]);
    };
    double tx, dtx, ty, dty;
    axis_setup(0, ix, tx, dtx);
    axis_setup(1, iy, ty, dty);
    const bool step_x_up = d.x() > 0, step_y_up = d.y() > 0;
    for (;;) {
      const std::size_t c = iy * nx_ + ix;
      for (std::uint32_t k = cell_offsets_[c]; k < cell_offsets_[c + 1]; ++k)
        test(cell_items_[k], best);
      const double t_exit = std::min(tx, ty);
      if (best.range <= t_exit || t_exit >= t_out) return;
      if (tx < ty) {
        if (step_x_up ? ++ix >= nx_ : ix-- == 0) return;
        tx += dtx;
      } else {
        if (step_y_up ? ++iy >= ny_ : iy-- == 0) return;
        ty += dty;
      }
    }
  }

  // ---- primitive tests (update best when nearer) -------------------------------------------

  static void take(RayHit& best, double t, SurfaceKind kind, std::uint32_t index) {
    if (t >= 0 && t < best.range) best = {t, kind, index};
  }

  /// Ray-segment intersection parameter in xy, or -1.
  static double segment_t(const Point3d& o, const Point3d& d, const Wall& w) {
    const double ex = w.b.x() - w.a.x(), ey = w.b.y() - w.a.y();
    const double denom = d.x() * ey - d.y() * ex;
    if (denom == 0) return -1;
    const double ax = w.a.x() - o.x(), ay = w.a.y() - o.y();
    const double t = (ax * ey - ay * ex) / denom;
    const double s = (ax * d.y() - ay * d.x()) / denom;
    return (s >= 0 && s <= 1) ? t : -1;
  }

  /// Entry parameter of the ray into a box (3D when use_z), or -1 when missed or inside.
  static double box_t(const Point3d& o, const Point3d& d, const CachedBox& b, bool use_z) {
    const Point2d lo = b.to_local(Point2d(o.x(), o.y()) - b.center);
    const Point2d ld = b.to_local(Point2d(d.x(), d.y()));
    double t0 = -std::numeric_limits<double>::infinity();
    double t1 = std::numeric_limits<double>::infinity();
    const auto slab = [&](double p, double v, double mn, double mx) {
      if (v == 0) {
        if (p < mn || p > mx) t1 = -1, t0 = 1;  // parallel and outside: miss
        return;
      }
      double ta = (mn - p) / v, tb = (mx - p) / v;
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
    };
    slab(lo.x(), ld.x(), -b.half.x(), b.half.x());
    slab(lo.y(), ld.y(), -b.half.y(), b.half.y());
    if (use_z) slab(o.z(), d.z(), b.z_min, b.z_max);
    if (t0 > t1 || t0 < 0) return -1;
    return t0;
  }

  /// Entry parameter of the ray into a vertical cylinder (3D when use_z), or -1.
  static double cylinder_t(const Point3d& o, const Point3d& d, const Cylinder& cy, bool use_z) {
    const double fx = o.x() - cy.center.x(), fy = o.y() - cy.center.y();
    const double a = d.x() * d.x() + d.y() * d.y();
    const double b = fx * d.x() + fy * d.y();
    const double c = fx * fx + fy * fy - cy.radius * cy.radius;
    double t0, t1;
    if (a == 0) {
      if (c > 0) return -1;
      t0 = -std::numeric_limits<double>::infinity();
      t1 = std::numeric_limits<double>::infinity();
    } else {
      const double disc = b * b - a * c;
      if (disc < 0) return -1;
      const double sq = std::sqrt(disc);
      t0 = (-b - sq) / a;
      t1 = (-b + sq) / a;
    }
    if (use_z) {
      if (d.z() == 0) {
        if (o.z() < cy.z_min || o.z() > cy.z_max) return -1;
      } else {
        double ta = (cy.z_min - o.z()) / d.z(), tb = (cy.z_max - o.z()) / d.z();
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
      }
    }
    if (t0 > t1 || t0 < 0) return -1;
    return t0;
  }

  void test_item_2d(std::uint32_t item, const Point3d& o, const Point3d& d, RayHit& best) const {
    const std::uint32_t i = index_of(item);
    const double z = o.z();
    switch (kind_of(item)) {
      case wall_tag:
        if (z >= 0 && z <= walls_[i].height)
          take(best, segment_t(o, d, walls_[i]), SurfaceKind::wall, i);
        break;
      case box_tag:
        if (z >= box_cache_[i].z_min && z <= box_cache_[i].z_max)
          take(best, box_t(o, d, box_cache_[i], false), SurfaceKind::box, i);
        break;
      case cylinder_tag:
        if (z >= cylinders_[i].z_min && z <= cylinders_[i].z_max)
          take(best, cylinder_t(o, d, cylinders_[i], false), SurfaceKind::cylinder, i);
        break;
      default:
        if (z >= door_cache_[i].z_min && z <= door_cache_[i].z_max)
          take(best, box_t(o, d, door_cache_[i], false), SurfaceKind::door, i);
        break;
    }
  }

  void test_item_3d(std::uint32_t item, const Point3d& o, const Point3d& d, RayHit& best) const {
    const std::uint32_t i = index_of(item);
    switch (kind_of(item)) {
      case wall_tag: {
        const double t = segment_t(o, d, walls_[i]);
        if (t >= 0 && t < best.range) {
          const double z = o.z() + t * d.z();
          if (z >= 0 && z <= walls_[i].height) best = {t, SurfaceKind::wall, i};
        }
        break;
      }
      case box_tag:
        take(best, box_t(o, d, box_cache_[i], true), SurfaceKind::box, i);
        break;
      case cylinder_tag:
        take(best, cylinder_t(o, d, cylinders_[i], true), SurfaceKind::cylinder, i);
        break;
      default:
        take(best, box_t(o, d, door_cache_[i], true), SurfaceKind::door, i);
        break;
    }
  }

  /// Index of a hole containing p whose floor lies below z, or -1.
  [[nodiscard]] std::ptrdiff_t hole_below(const Point2d& p, double z) const {
    for (std::size_t i = 0; i < hole_cache_.size(); ++i)
      if (hole_cache_[i].z_min < z && hole_cache_[i].contains_xy(p))
        return static_cast<std::ptrdiff_t>(i);
    return -1;
  }

  /// The floor (with its holes, whose sides are solid ground) and the ceiling.
  void floor_and_ceiling(const Point3d& o, const Point3d& d, RayHit& best) const {
    if (ceiling_height_ > 0 && d.z() > 0 && o.z() < ceiling_height_)
      take(best, (ceiling_height_ - o.z()) / d.z(), SurfaceKind::ceiling, 0);
    const Point2d oxy(o.x(), o.y()), dxy(d.x(), d.y());
    std::ptrdiff_t current;
    if (o.z() >= 0) {
      if (d.z() >= 0) return;
      const double t = -o.z() / d.z();
      if (t >= best.range) return;
      current = hole_below(oxy + t * dxy, 0.0);
      if (current < 0) {
        take(best, t, SurfaceKind::floor, 0);
        return;
      }
    } else {
      current = hole_below(oxy, o.z());
      if (current < 0) {  // the origin is inside the ground
        take(best, 0.0, SurfaceKind::floor, 0);
        return;
      }
    }
    // Follow the ray through adjoining holes (stair steps) until it meets a bottom or a side.
    for (std::size_t guard = 0; guard <= hole_cache_.size(); ++guard) {
      const CachedBox& h = hole_cache_[static_cast<std::size_t>(current)];
      const auto hi = static_cast<std::uint32_t>(current);
      const Point2d lo = h.to_local(oxy - h.center), ld = h.to_local(dxy);
      double t_side = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 2; ++k)
        if (ld[k] != 0)
          t_side = std::min(t_side, ((ld[k] > 0 ? h.half[k] : -h.half[k]) - lo[k]) / ld[k]);
      if (d.z() < 0) {
        const double t_bottom = (h.z_min - o.z()) / d.z();
        if (t_bottom <= t_side) {
          take(best, t_bottom, SurfaceKind::hole, hi);
          return;
        }
      } else if (d.z() > 0 && -o.z() / d.z() <= t_side) {
        return;  // climbs out of the pit above the floor
      }
      if (t_side >= best.range) return;
      const double z = o.z() + t_side * d.z();
      const std::ptrdiff_t next = hole_below(oxy + (t_side + 1e-9) * dxy, z);
      if (next < 0) {
        take(best, t_side, SurfaceKind::hole, hi);  // a riser or the pit's side
        return;
      }
      current = next;
    }
  }

  static RayHit finish(RayHit best) {
    if (best.kind == SurfaceKind::none) best.range = std::numeric_limits<double>::infinity();
    return best;
  }

  std::vector<Wall> walls_;
  std::vector<Box> boxes_;
  std::vector<Cylinder> cylinders_;
  std::vector<Door> doors_;
  std::vector<FloorHole> holes_;
  std::vector<CachedBox> box_cache_, door_cache_, hole_cache_;
  double ceiling_height_{0};

  bool index_built_{false};
  Point2d grid_min_{0, 0}, grid_max_{0, 0};
  double cell_size_{1};
  std::size_t nx_{0}, ny_{0};
  std::vector<std::uint32_t> cell_offsets_;
  std::vector<std::uint32_t> cell_items_;
};

}  // namespace rangenav::sim
