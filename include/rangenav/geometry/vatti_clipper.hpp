#pragma once
// The Vatti backend of the PolygonClipper concept: Angus Johnson's Clipper 6.4 (Debian package
// libpolyclipping-dev), the algorithm paper 004 uses for merging (§3.4, Vatti [15]).
//
// Optional peer: this header needs <polyclipping/clipper.hpp> and linking against libpolyclipping.
// rangenav's CMake finds them and then provides the target rangenav::clipper, which links the
// library and defines RANGENAV_HAVE_CLIPPER; nothing else in rangenav includes this header, and
// the umbrella header rangenav.hpp includes it only when RANGENAV_HAVE_CLIPPER is defined.
//
// Clipper works on integer coordinates (64-bit `cInt`): a coordinate x becomes
// llround(x * scale). The default scale 1e6 is a micrometre grid for coordinates in metres;
// results are exact on that grid and rounded to it, so areas agree with the Boost.Geometry
// backend to about perimeter * 1 / scale. Coordinates must satisfy |x * scale| <= 2^62 - 1
// (Clipper's hiRange); |x * scale| <= 2^30 - 1 (about +-1 km at the default scale) keeps Clipper
// on its fast 64-bit arithmetic instead of 128-bit products.

#if !__has_include(<polyclipping/clipper.hpp>)
#error "rangenav/geometry/vatti_clipper.hpp needs Clipper (Debian: libpolyclipping-dev)"
#endif

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include <polyclipping/clipper.hpp>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/planar_polygon.hpp"
#include "rangenav/geometry/polygon_clipper.hpp"

namespace rangenav {

/// PolygonClipper on Clipper (Vatti's algorithm) with integer coordinates x * scale (see the
/// file's comment). Both polygons are filled even-odd, so ring orientation does not matter.
/// Stateless apart from `scale`; calls on one object may run concurrently.
class VattiClipper {
 public:
  /// A clipper on a micrometre grid (scale 1e6).
  VattiClipper() = default;
  /// A clipper with `scale` integer grid steps per input unit (1e6: micrometres for metres).
  /// Throws invalid_argument unless finite and > 0.
  explicit VattiClipper(double scale) : scale_(scale) {
    detail::require_positive("VattiClipper", "scale", scale);
  }

  /// Integer grid steps per input unit.
  [[nodiscard]] double scale() const { return scale_; }

  /// True when the intersection of a and b has a positive area on the integer grid. Two cheap
  /// answers come before Vatti's intersection: bounding boxes that do not overlap with a positive
  /// area (no), and a vertex of one polygon strictly inside the other (ClipperLib::PointInPolygon
  /// on up to 8 vertices of each outer ring, inside the outer ring and in no hole: yes, every
  /// neighbourhood of a boundary point of b holds interior points of b).
  template <class Scalar>
  [[nodiscard]] bool intersects(const Polygon2<Scalar>& a, const Polygon2<Scalar>& b) const {
    constexpr const char* where = "VattiClipper::intersects";
    const ClipperLib::Paths pa = to_paths(where, "a", a);
    const ClipperLib::Paths pb = to_paths(where, "b", b);
    // A polygon without area on the grid overlaps nothing (and has no interior to hold a vertex).
    if (ClipperLib::Area(pa.front()) == 0 || ClipperLib::Area(pb.front()) == 0) return false;
    const Box ba = bounds(pa.front()), bb = bounds(pb.front());
    if (ba.right <= bb.left || bb.right <= ba.left || ba.top <= bb.bottom || bb.top <= ba.bottom)
      return false;
    if (sampled_vertex_inside(pb.front(), pa) || sampled_vertex_inside(pa.front(), pb)) return true;
    ClipperLib::Paths result;
    execute(where, ClipperLib::ctIntersection, pa, pb, result);
    double area = 0;
    for (const auto& path : result)
      area += ClipperLib::Area(path);
    return std::abs(area) > 0;
  }

  /// The union of a and b as a list of polygons with holes (outer counter-clockwise, holes
  /// clockwise, open rings), one per outer contour of Clipper's PolyTree with its holes as
  /// children; an island inside a hole becomes a polygon of its own.
  template <class Scalar>
  [[nodiscard]] std::vector<Polygon2<Scalar>> union_of(const Polygon2<Scalar>& a,
                                                       const Polygon2<Scalar>& b) const {
    constexpr const char* where = "VattiClipper::union_of";
    ClipperLib::PolyTree tree;
    execute(where, ClipperLib::ctUnion, to_paths(where, "a", a), to_paths(where, "b", b), tree);
    std::vector<Polygon2<Scalar>> out;
    collect(tree, out);
    return out;
  }

 private:
  double scale_{1e6};

  template <class Scalar>
  ClipperLib::Path to_path(const char* where, const std::vector<Point<2, Scalar>>& ring) const {
    // Clipper's hiRange; beyond it Clipper throws its own exception type.
    constexpr double limit = 4611686018427387903.0;
    ClipperLib::Path path;
    path.reserve(ring.size());
    for (const auto& p : ring) {
      const double x = static_cast<double>(p.x()) * scale_;
      const double y = static_cast<double>(p.y()) * scale_;
      if (!(std::abs(x) < limit && std::abs(y) < limit))
        detail::throw_invalid_argument(where, "vertex coordinate * scale",
                                       std::abs(x) > std::abs(y) ? x : y,
                                       "must be within Clipper's range +-(2^62 - 1)");
      path.emplace_back(static_cast<ClipperLib::cInt>(std::llround(x)),
                        static_cast<ClipperLib::cInt>(std::llround(y)));
    }
    return path;
  }

  // The outer ring first, then the holes, on the integer grid; validates the polygon.
  template <class Scalar>
  ClipperLib::Paths to_paths(const char* where, const char* name,
                             const Polygon2<Scalar>& polygon) const {
    detail::require_valid_polygon(where, name, polygon);
    ClipperLib::Paths paths;
    paths.reserve(1 + polygon.holes.size());
    paths.push_back(to_path(where, polygon.outer));
    for (const auto& h : polygon.holes)
      paths.push_back(to_path(where, h));
    return paths;
  }

  struct Box {
    ClipperLib::cInt left, bottom, right, top;
  };
  static Box bounds(const ClipperLib::Path& ring) {
    Box box{ring.front().X, ring.front().Y, ring.front().X, ring.front().Y};
    for (const auto& p : ring) {
      box.left = std::min(box.left, p.X);
      box.right = std::max(box.right, p.X);
      box.bottom = std::min(box.bottom, p.Y);
      box.top = std::max(box.top, p.Y);
    }
    return box;
  }

  // Whether one of up to 8 vertices spread over `ring` lies strictly inside `polygon` (inside its
  // outer ring, neither on a boundary nor in or on a hole).
  static bool sampled_vertex_inside(const ClipperLib::Path& ring,
                                    const ClipperLib::Paths& polygon) {
    const std::size_t stride = std::max<std::size_t>(1, ring.size() / 8);
    for (std::size_t i = 0; i < ring.size(); i += stride) {
      if (ClipperLib::PointInPolygon(ring[i], polygon.front()) != 1) continue;
      bool in_hole = false;
      for (std::size_t h = 1; h < polygon.size() && !in_hole; ++h)
        in_hole = ClipperLib::PointInPolygon(ring[i], polygon[h]) != 0;
      if (!in_hole) return true;
    }
    return false;
  }

  template <class Solution>
  static void execute(const char* where, ClipperLib::ClipType type, const ClipperLib::Paths& a,
                      const ClipperLib::Paths& b, Solution& solution) {
    ClipperLib::Clipper clipper;
    clipper.AddPaths(a, ClipperLib::ptSubject, true);
    clipper.AddPaths(b, ClipperLib::ptClip, true);
    if (!clipper.Execute(type, solution, ClipperLib::pftEvenOdd, ClipperLib::pftEvenOdd))
      detail::throw_invalid(where, "Clipper failed on the input");
  }

  template <class Scalar>
  std::vector<Point<2, Scalar>> to_ring(const ClipperLib::Path& path) const {
    std::vector<Point<2, Scalar>> ring;
    ring.reserve(path.size());
    const double inv = 1.0 / scale_;
    for (const auto& p : path)
      ring.emplace_back(static_cast<Scalar>(static_cast<double>(p.X) * inv),
                        static_cast<Scalar>(static_cast<double>(p.Y) * inv));
    return ring;
  }

  // Outer contours of the tree (depth 0, 2, ...) become polygons, their children their holes.
  template <class Scalar>
  void collect(const ClipperLib::PolyNode& node, std::vector<Polygon2<Scalar>>& out) const {
    for (const ClipperLib::PolyNode* outer : node.Childs) {
      Polygon2<Scalar> polygon;
      polygon.outer = to_ring<Scalar>(outer->Contour);
      for (const ClipperLib::PolyNode* hole : outer->Childs) {
        polygon.holes.push_back(to_ring<Scalar>(hole->Contour));
        collect(*hole, out);
      }
      // Clipper's outer contours have Orientation() == true, counter-clockwise with y up, and
      // holes the opposite: Polygon2's convention already.
      out.push_back(std::move(polygon));
    }
  }
};

static_assert(PolygonClipper<VattiClipper, double>);
static_assert(PolygonClipper<VattiClipper, float>);

}  // namespace rangenav
