#pragma once
// Polygon clipping for the geometric maps of paper 004 (§3.4): the two operations the merge step
// needs, an intersection test and the union of two simple polygons with holes (concave shapes
// included), behind the `PolygonClipper` concept, and its default backend on Boost.Geometry.
// The Vatti backend on Clipper (libpolyclipping) lives in geometry/vatti_clipper.hpp and is
// compiled only where that library is installed.
//
// Conventions shared by every backend:
// - Input rings may have either orientation and must not repeat their first vertex; a hole must
//   lie inside its outer ring. Each input polygon must be simple (no self-intersections).
//   BoostGeometryClipper checks this with boost::geometry::is_valid and raises invalid_argument
//   naming the defect (a self-crossing "bowtie", a hole outside its outer ring): an invalid
//   polygon would otherwise give a wrong answer silently. Repeated vertices and rings that touch
//   themselves are accepted (the overlay follows touching turns); spikes are removed; a polygon
//   whose outer ring has no area is the empty set: it intersects nothing and adds nothing to a
//   union (detail::prepare_overlay_input).
// - `intersects(a, b)` is true when the interiors of a and b overlap, i.e. their intersection has
//   a positive area. Polygons that only touch along an edge or at a point do not intersect: the
//   paper computes the intersection and merges only when it is not empty.
// - `union_of(a, b)` returns the union as a list of polygons with holes (outer counter-clockwise,
//   holes clockwise, open rings, as Polygon2): one polygon when a and b overlap, two when they are
//   disjoint, and possibly several when they touch only at points (each connected piece of the
//   union's interior is one polygon). The total area is area(a) + area(b) - area(a ∩ b).

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <exception>
#include <string>
#include <vector>

#include <boost/geometry.hpp>
#include <boost/geometry/geometries/point_xy.hpp>
#include <boost/geometry/geometries/polygon.hpp>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/planar_polygon.hpp"

namespace rangenav {

/// An intersection test and a union of two Polygon2 (see the conventions at the top of the file).
template <class C, class Scalar = double>
concept PolygonClipper = requires(const C& clipper, const Polygon2<Scalar>& a,
                                  const Polygon2<Scalar>& b) {
  { clipper.intersects(a, b) } -> std::convertible_to<bool>;
  { clipper.union_of(a, b) } -> std::same_as<std::vector<Polygon2<Scalar>>>;
};

/// Boost.Geometry's point with Polygon2's conventions.
template <class Scalar = double>
using BoostPoint2 = boost::geometry::model::d2::point_xy<Scalar>;
/// Boost.Geometry's polygon with Polygon2's conventions: outer ring counter-clockwise
/// (ClockWise = false), open rings (Closed = false).
template <class Scalar = double>
using BoostPolygon2 = boost::geometry::model::polygon<BoostPoint2<Scalar>, false, false>;

namespace detail {

/// Throws invalid_argument unless `polygon` has an outer ring of >= 3 vertices, holes of >= 3
/// vertices and finite coordinates only.
template <class Scalar>
void require_valid_polygon(const char* where, const char* name, const Polygon2<Scalar>& polygon) {
  const auto check_ring = [&](const std::vector<Point<2, Scalar>>& ring, const char* what) {
    if (ring.size() < 3)
      throw_invalid_argument(where, std::string(name) + what + " vertices", ring.size(),
                             "must be >= 3");
    for (const auto& p : ring)
      if (!p.allFinite())
        throw_invalid(where, std::string("argument '") + name + "' has a non-finite vertex");
  };
  check_ring(polygon.outer, ".outer");
  for (const auto& h : polygon.holes)
    check_ring(h, ".holes[i]");
}

}  // namespace detail

namespace detail {

/// boost::geometry::is_valid's visitor for the clippers' inputs: records the first defect that
/// makes an overlay's answer wrong. A ring that touches itself (a self-turn that does not cross)
/// and the interior such touches split are accepted, since Boost.Geometry's overlay follows
/// touching turns (concave hulls of real scans have them); crossings, rings without area, holes
/// outside their ring or inside another hole are not. Repeated vertices are fine.
struct OverlayValidity {
  boost::geometry::validity_failure_type failure = boost::geometry::no_failure;

  template <boost::geometry::validity_failure_type Failure>
  bool apply() {
    return accept(Failure);
  }
  template <boost::geometry::validity_failure_type Failure, class Turns>
  bool apply(const Turns& turns) {
    if constexpr (Failure == boost::geometry::failure_self_intersections) {
      for (const auto& turn : turns)
        if (turn.method == boost::geometry::detail::overlay::method_crosses) return accept(Failure);
      return true;
    } else {
      return accept(Failure);
    }
  }
  template <boost::geometry::validity_failure_type Failure, class A, class B>
  bool apply(const A&, const B&) {
    return accept(Failure);
  }

 private:
  bool accept(boost::geometry::validity_failure_type f) {
    namespace bg = boost::geometry;
    if (f == bg::no_failure || f == bg::failure_duplicate_points ||
        f == bg::failure_disconnected_interior)
      return true;
    failure = f;
    return false;
  }
};

/// The defect of an invalid input in words.
inline std::string overlay_failure_text(boost::geometry::validity_failure_type failure) {
  namespace bg = boost::geometry;
  switch (failure) {
    case bg::failure_few_points:
      return "a ring has fewer than 3 distinct points";
    case bg::failure_wrong_topological_dimension:
    case bg::failure_spikes:
      return "a ring has no area (its points are collinear)";
    case bg::failure_self_intersections:
      return "a ring crosses itself or another ring";
    case bg::failure_wrong_orientation:  // after bg::correct: lobes whose areas cancel
      return "a ring crosses itself (its orientation is undefined)";
    case bg::failure_interior_rings_outside:
      return "a hole lies outside its outer ring";
    case bg::failure_nested_interior_rings:
      return "a hole lies inside another hole";
    default:
      return "Boost.Geometry validity failure " + std::to_string(static_cast<int>(failure));
  }
}

/// Makes `polygon` (orientation corrected) fit for an overlay and says whether it has area:
/// false for a polygon whose outer ring encloses nothing (all its vertices on one line), which
/// is the empty set; a hole without area is dropped. Throws invalid_argument naming `where`,
/// `name` and the defect (OverlayValidity) for any other invalid polygon. Spikes, zero-width
/// needles, are the one defect repaired, explicitly, by boost::geometry::remove_spikes, and the
/// result checked again.
template <class Scalar>
[[nodiscard]] bool prepare_overlay_input(const char* where, const char* name,
                                         BoostPolygon2<Scalar>& polygon) {
  namespace bg = boost::geometry;
  // No area: every vertex on one line (a ring whose lobes cancel, a bowtie, has vertices off it).
  const auto no_area = [](const auto& ring) {
    for (std::size_t i = 1; i < ring.size(); ++i) {
      const Scalar ux = ring[i].x() - ring[0].x(), uy = ring[i].y() - ring[0].y();
      if (ux == Scalar(0) && uy == Scalar(0)) continue;
      for (std::size_t j = i + 1; j < ring.size(); ++j)
        if (ux * (ring[j].y() - ring[0].y()) != uy * (ring[j].x() - ring[0].x())) return false;
      return true;
    }
    return true;
  };
  auto& holes = polygon.inners();
  holes.erase(std::remove_if(holes.begin(), holes.end(), no_area), holes.end());
  if (no_area(polygon.outer())) return false;
  OverlayValidity check;
  if (bg::is_valid(polygon, check, bg::default_strategy())) return true;
  if (check.failure == bg::failure_spikes) {
    bg::remove_spikes(polygon);
    if (no_area(polygon.outer())) return false;
    check = {};
    if (bg::is_valid(polygon, check, bg::default_strategy())) return true;
  }
  throw_invalid(where, std::string("argument '") + name +
                           "' is not a valid polygon: " + overlay_failure_text(check.failure));
}

}  // namespace detail

/// Polygon2 -> Boost.Geometry polygon, with orientations corrected (outer counter-clockwise,
/// holes clockwise) so that either input orientation is accepted.
template <class Scalar>
[[nodiscard]] BoostPolygon2<Scalar> to_boost_polygon(const Polygon2<Scalar>& polygon) {
  BoostPolygon2<Scalar> out;
  auto& outer = out.outer();
  outer.reserve(polygon.outer.size());
  for (const auto& p : polygon.outer)
    outer.emplace_back(p.x(), p.y());
  out.inners().resize(polygon.holes.size());
  for (std::size_t h = 0; h < polygon.holes.size(); ++h) {
    auto& ring = out.inners()[h];
    ring.reserve(polygon.holes[h].size());
    for (const auto& p : polygon.holes[h])
      ring.emplace_back(p.x(), p.y());
  }
  boost::geometry::correct(out);
  return out;
}

/// Boost.Geometry polygon (counter-clockwise, open) -> Polygon2.
template <class Scalar>
[[nodiscard]] Polygon2<Scalar> from_boost_polygon(const BoostPolygon2<Scalar>& polygon) {
  const auto copy_ring = [](const auto& ring) {
    std::vector<Point<2, Scalar>> out;
    out.reserve(ring.size());
    for (const auto& p : ring)
      out.emplace_back(p.x(), p.y());
    return out;
  };
  Polygon2<Scalar> out;
  out.outer = copy_ring(polygon.outer());
  out.holes.reserve(polygon.inners().size());
  for (const auto& h : polygon.inners())
    out.holes.push_back(copy_ring(h));
  return out;
}

// g++ 12 reports a false -Wmaybe-uninitialized inside Boost 1.74's rescale policy (the scale factor
// of get_rescale_policy, always set before use) wherever union_ or relate is inlined; silence it
// for the calls below only.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

namespace detail {

// Whether one of up to 8 vertices spread over `ring` lies strictly inside `polygon`
// (boost::geometry::within: in the interior, not on the boundary). A sample, not every vertex:
// each test walks all of polygon's edges, and the answer only spares the overlay below.
template <class Scalar, class Ring>
bool sampled_vertex_within(const Ring& ring, const BoostPolygon2<Scalar>& polygon) {
  const std::size_t stride = std::max<std::size_t>(1, ring.size() / 8);
  for (std::size_t i = 0; i < ring.size(); i += stride)
    if (boost::geometry::within(ring[i], polygon)) return true;
  return false;
}

// Out of line so that the warning above is attributed to these bodies, inside the pragma.
// As the paper does with Vatti's algorithm: the intersection, tested for a positive area, after
// two cheap answers: disjoint bounding boxes (no overlap), and a vertex of one polygon strictly
// inside the other (an overlap: every neighbourhood of a boundary point of b holds interior
// points of b), the common case of two views of one surface. Then boost::geometry::intersects
// (no overlay) and only for polygons that have a common point the overlay. (A DE-9IM relate with
// the mask "T********" would decide without the overlay, 3x faster on the benchmark's star
// polygons, but its out-of-line body in Boost trips the warning above where no pragma reaches.)
template <class Scalar>
[[gnu::noinline]] bool boost_interiors_intersect(const BoostPolygon2<Scalar>& a,
                                                 const BoostPolygon2<Scalar>& b) {
  namespace bg = boost::geometry;
  using Box = bg::model::box<BoostPoint2<Scalar>>;
  if (bg::disjoint(bg::return_envelope<Box>(a), bg::return_envelope<Box>(b))) return false;
  // A polygon without area overlaps nothing (and has no interior for the vertex test).
  if (!(bg::area(a) > Scalar(0) && bg::area(b) > Scalar(0))) return false;
  if (sampled_vertex_within(b.outer(), a) || sampled_vertex_within(a.outer(), b)) return true;
  if (!bg::intersects(a, b)) return false;
  bg::model::multi_polygon<BoostPolygon2<Scalar>> common;
  bg::intersection(a, b, common);
  return bg::area(common) > Scalar(0);
}

template <class Scalar>
[[gnu::noinline]] void boost_union(
    const BoostPolygon2<Scalar>& a, const BoostPolygon2<Scalar>& b,
    boost::geometry::model::multi_polygon<BoostPolygon2<Scalar>>& out) {
  boost::geometry::union_(a, b, out);
}

}  // namespace detail

/// The default PolygonClipper on Boost.Geometry (header-only): the intersection test is a
/// bounding-box test, a vertex-inside test, and where these do not decide
/// boost::geometry::intersects followed by boost::geometry::intersection (positive area?); the
/// union is boost::geometry::union_. Boost 1.74 rescales floating-point coordinates to an integer
/// grid for robust overlays (unless the whole program defines BOOST_GEOMETRY_NO_ROBUSTNESS).
/// Stateless and thread-safe.
struct BoostGeometryClipper {
  /// True when the interiors of a and b overlap (positive intersection area). Throws
  /// invalid_argument for a ring with fewer than 3 vertices, a non-finite vertex, or a polygon
  /// that is not valid (see the conventions at the top of the file).
  template <class Scalar>
  [[nodiscard]] bool intersects(const Polygon2<Scalar>& a, const Polygon2<Scalar>& b) const {
    constexpr const char* where = "BoostGeometryClipper::intersects";
    detail::require_valid_polygon(where, "a", a);
    detail::require_valid_polygon(where, "b", b);
    auto pa = to_boost_polygon(a);
    auto pb = to_boost_polygon(b);
    const bool area_a = detail::prepare_overlay_input(where, "a", pa);
    const bool area_b = detail::prepare_overlay_input(where, "b", pb);
    if (!area_a || !area_b) return false;  // a polygon without area overlaps nothing
    try {
      return detail::boost_interiors_intersect(pa, pb);
    } catch (const std::exception& e) {
      detail::throw_invalid(where, std::string("Boost.Geometry rejected the input: ") + e.what());
    }
  }

  /// The union of a and b as a list of polygons with holes (see the file's conventions). Throws
  /// invalid_argument like intersects() and when Boost.Geometry rejects the input.
  template <class Scalar>
  [[nodiscard]] std::vector<Polygon2<Scalar>> union_of(const Polygon2<Scalar>& a,
                                                       const Polygon2<Scalar>& b) const {
    constexpr const char* where = "BoostGeometryClipper::union_of";
    detail::require_valid_polygon(where, "a", a);
    detail::require_valid_polygon(where, "b", b);
    auto pa = to_boost_polygon(a);
    auto pb = to_boost_polygon(b);
    const bool area_a = detail::prepare_overlay_input(where, "a", pa);
    const bool area_b = detail::prepare_overlay_input(where, "b", pb);
    boost::geometry::model::multi_polygon<BoostPolygon2<Scalar>> result;
    try {
      // A polygon without area adds nothing to the other (which the overlay lost before).
      if (area_a && area_b)
        detail::boost_union(pa, pb, result);
      else if (area_a || area_b)
        result.push_back(area_a ? pa : pb);
    } catch (const std::exception& e) {
      detail::throw_invalid(where, std::string("Boost.Geometry rejected the input: ") + e.what());
    }
    std::vector<Polygon2<Scalar>> out;
    out.reserve(result.size());
    for (const auto& p : result)
      out.push_back(from_boost_polygon(p));
    return out;
  }
};

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

static_assert(PolygonClipper<BoostGeometryClipper, double>);
static_assert(PolygonClipper<BoostGeometryClipper, float>);

}  // namespace rangenav
