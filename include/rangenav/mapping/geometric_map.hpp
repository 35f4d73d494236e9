#pragma once
// GeometricMap: the aggregation of planar polygons into a geometric map, §3.4 of paper 004.
//
// Each shape of the map is a plane with its hull polygon and a merge weight delta. A new
// PlanarPolygon (e.g. the concave hull of a plane extracted from a key frame) is compared with the
// map's shapes by the similarity test of Eq. (6); for a similar shape both polygons are projected
// into the frame of the weighted virtual average plane of Eq. (7) (Eq. 8-12, 3), and if they
// intersect their union replaces the map's shape, with delta increased. A polygon that merges with
// nothing becomes a new shape of weight 1.
//
// Eq. (6b) compares the planes' offsets d, i.e. their distances at the world origin. Two pieces of
// one surface whose fitted normals differ by a few degrees then differ in d by the distance from
// the origin times that angle (5 m and 3 deg: 0.26 m > t2), so far from the origin the paper's
// test keeps them apart, and where the origin is changes the map. The default offset test
// (PlaneOffsetTest::centroid) asks the same question where the shapes are: each polygon's area
// centroid must lie within t2 of the other's plane. PlaneOffsetTest::origin is the paper's form.
//
// Merging is transitive: after a merge the grown shape is tested again against every other shape
// of the map, and shapes that are now similar and intersecting are merged into it, until nothing
// changes. So a new polygon that bridges two map shapes of one wall leaves a single shape. Two map
// shapes A (weight delta_A) and B (delta_B) merge into the plane of Eq. (7) with the weights
// delta_A and delta_B (the paper's case is delta_B = 1 for the new plane) and the merged shape gets
// delta_A + delta_B, which is the paper's "delta += 1" for a new plane. The merged shape keeps the
// oldest id and the normal orientation of the older shape (the newer normal is flipped, Eq. 6).
//
// The editing API serves a human operator (paper 004 §1): select a shape by id, by a ray (the
// first polygon hit) or by a point (the nearest polygon), erase it, or move it rigidly.
//
// Not thread-safe for concurrent modification; const member functions may run concurrently.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <boost/geometry.hpp>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/planar_polygon.hpp"
#include "rangenav/geometry/polygon_clipper.hpp"

namespace rangenav {

/// Where the offset test of Eq. (6b) compares two planes.
enum class PlaneOffsetTest {
  /// Paper 004's Eq. (6b): |d1 - d2| < t2, the offsets d of the planes n . x + d = 0, i.e. their
  /// distances at the world origin. Two pieces of one surface whose fitted normals differ by an
  /// angle a are then |d1 - d2| ~ r sin a apart at a distance r from the origin: 5 m away,
  /// 3 deg of tilt already exceed t2 = 0.1 m, and the test depends on where the world origin is.
  origin,
  /// The same test where the shapes are: the area centroid of each shape's polygon is within t2
  /// of the other shape's plane. Translation-invariant; for parallel planes it is |d1 - d2| < t2.
  /// The default: measured in example 08 (640 x 480, 65 key frames, kitchen at x, y in [0, 5] x
  /// [0, 4]) it leaves each labelled plane one shape at every noise level where the origin test
  /// left up to 5 pieces of the floor (sigma 0.02); see docs/mapping.md.
  centroid,
};

/// Parameters of GeometricMap, with paper 004's values (§4.1).
template <class Scalar = double>
struct GeometricMapParameters {
  /// t1 of Eq. (6a): two planes are similar only if |n1 . n2| > t1. 0.95 allows about 18.2 deg
  /// between the normals.
  Scalar t1{0.95};
  /// t2 of Eq. (6b): and only if their offsets differ by less than t2 (m), compared after flipping
  /// n2 towards n1, at the world origin or at the shapes (offset_test).
  Scalar t2{0.1};
  /// Where Eq. (6b) compares the offsets (see PlaneOffsetTest).
  PlaneOffsetTest offset_test{PlaneOffsetTest::centroid};
};

/// What GeometricMap::insert did with one polygon.
struct GeometricMapInsertion {
  std::size_t id{0};      ///< the id of the map shape that now holds the polygon
  std::size_t merged{0};  ///< how many map shapes it was merged with (0: added as a new shape)
};

/// A geometric map of planar polygons merged by 2D clipping (paper 004 §3.4), templated on the
/// PolygonClipper (default: Boost.Geometry; VattiClipper from geometry/vatti_clipper.hpp is the
/// paper's algorithm where Clipper is installed).
template <class Scalar = double, class Clipper = BoostGeometryClipper>
requires PolygonClipper<Clipper, Scalar>
class GeometricMap {
 public:
  /// The similarity parameters.
  using Parameters = GeometricMapParameters<Scalar>;
  /// A 3D vector.
  using Vector3 = Point<3, Scalar>;

  /// One shape of the map: the plane, its frame and the polygon in that frame, and the merge
  /// weight delta of Eq. (7) (1 for a shape never merged).
  struct Shape {
    std::size_t id{0};              ///< stable identifier (the older id survives a merge)
    PlanarPolygon<Scalar> surface;  ///< plane, frame and polygon
    Scalar delta{1};                ///< merge weight: the polygons merged into it
    /// The area centroid of the polygon (holes subtracted), in world coordinates.
    Vector3 centroid{Vector3::Zero()};
  };

  /// Throws invalid_argument unless 0 < t1 <= 1 and t2 > 0.
  explicit GeometricMap(const Parameters& parameters = {}, Clipper clipper = Clipper())
      : parameters_(parameters), clipper_(std::move(clipper)) {
    constexpr const char* where = "GeometricMap";
    if (!(parameters.t1 > Scalar(0) && parameters.t1 <= Scalar(1)))
      detail::throw_invalid_argument(where, "t1", parameters.t1, "must be in (0, 1]");
    detail::require_positive(where, "t2", parameters.t2);
  }

  /// The similarity parameters.
  [[nodiscard]] const Parameters& parameters() const { return parameters_; }
  /// The polygon clipper.
  [[nodiscard]] const Clipper& clipper() const { return clipper_; }

  /// The similarity test of Eq. (6) as the paper writes it: |n1 . n2| > t1 and |d1 - d2| < t2,
  /// with n2 (and d2) flipped when the normals point in opposite directions (the offsets compared
  /// at the world origin, whatever offset_test says).
  [[nodiscard]] bool similar(const Plane3<Scalar>& p1, const Plane3<Scalar>& p2) const {
    const Scalar dot = p1.normal.dot(p2.normal);
    const Scalar d2 = dot < 0 ? -p2.d : p2.d;
    return std::abs(dot) > parameters_.t1 && std::abs(p1.d - d2) < parameters_.t2;
  }

  /// The similarity test of Eq. (6) between two shapes, with the offset test of offset_test:
  /// Eq. (6a) |n1 . n2| > t1, and Eq. (6b) at the world origin (origin) or at the shapes
  /// (centroid: each polygon's area centroid within t2 of the other's plane).
  [[nodiscard]] bool similar(const Shape& a, const Shape& b) const {
    const auto& pa = a.surface.plane;
    const auto& pb = b.surface.plane;
    if (!(std::abs(pa.normal.dot(pb.normal)) > parameters_.t1)) return false;  // Eq. (6a)
    const Scalar t2 = parameters_.t2;
    switch (parameters_.offset_test) {
      case PlaneOffsetTest::origin:
        return similar(pa, pb);
      case PlaneOffsetTest::centroid:
        return std::abs(pa.signed_distance(b.centroid)) < t2 &&
               std::abs(pb.signed_distance(a.centroid)) < t2;
    }
    return false;
  }

  /// Inserts one polygon (weight 1) and merges it with every similar map shape it intersects,
  /// transitively (see the file's comment). The input's rings may have either orientation; the
  /// plane's normal need not be unit length. Throws invalid_argument for a polygon with a ring of
  /// fewer than 3 vertices, a non-finite vertex or plane coefficient, or a zero normal.
  GeometricMapInsertion insert(const PlanarPolygon<Scalar>& polygon) {
    constexpr const char* where = "GeometricMap::insert";
    detail::require_valid_polygon(where, "polygon.polygon", polygon.polygon);
    const Scalar norm = polygon.plane.normal.norm();
    if (!(std::isfinite(norm) && norm > Scalar(0) && std::isfinite(polygon.plane.d)))
      detail::throw_invalid(where, "argument 'polygon.plane' is not a finite plane with a normal");
    if (!polygon.frame.world_to_plane.matrix().allFinite())
      detail::throw_invalid(where, "argument 'polygon.frame' is not finite");
    Shape shape{next_id_++, polygon, Scalar(1)};
    shape.surface.plane = {polygon.plane.normal / norm, polygon.plane.d / norm};
    orient(shape.surface.polygon);
    shape.centroid = centroid_of(shape.surface);
    shapes_.push_back(std::move(shape));
    return absorb(shapes_.size() - 1);
  }

  /// Inserts every polygon in order; returns how many of them were merged into the map (the
  /// others became new shapes).
  std::size_t insert(const std::vector<PlanarPolygon<Scalar>>& polygons) {
    std::size_t merged = 0;
    for (const auto& p : polygons)
      merged += insert(p).merged > 0 ? 1 : 0;
    return merged;
  }

  // ---- access ---------------------------------------------------------------------------------

  /// The shapes, ordered by increasing id.
  [[nodiscard]] const std::vector<Shape>& shapes() const { return shapes_; }
  /// Number of shapes.
  [[nodiscard]] std::size_t size() const { return shapes_.size(); }
  /// True when the map has no shapes.
  [[nodiscard]] bool empty() const { return shapes_.empty(); }
  /// Removes every shape.
  void clear() { shapes_.clear(); }

  /// True when a shape has this id.
  [[nodiscard]] bool contains(std::size_t id) const { return find(id) != shapes_.end(); }

  /// The shape with this id; throws invalid_argument when there is none.
  [[nodiscard]] const Shape& shape(std::size_t id) const {
    return *find_or_throw("GeometricMap::shape", id);
  }

  // ---- editing (paper 004 §1: an operator corrects the map) ------------------------------------

  /// The id of the first shape the ray origin + t direction (0 <= t <= max_range) hits inside its
  /// polygon (boundary included), or nothing. Throws invalid_argument for a zero or non-finite
  /// direction or a non-finite origin.
  [[nodiscard]] std::optional<std::size_t> select_by_ray(
      const Vector3& origin, const Vector3& direction,
      Scalar max_range = std::numeric_limits<Scalar>::infinity()) const {
    constexpr const char* where = "GeometricMap::select_by_ray";
    if (!origin.allFinite()) detail::throw_invalid(where, "argument 'origin' is not finite");
    const Scalar length = direction.norm();
    if (!(std::isfinite(length) && length > Scalar(0)))
      detail::throw_invalid_argument(where, "|direction|", length, "must be finite and > 0");
    const Vector3 u = direction / length;
    std::optional<std::size_t> best;
    Scalar best_t = max_range;
    for (const auto& s : shapes_) {
      const auto& plane = s.surface.plane;
      const Scalar along = plane.normal.dot(u);
      if (std::abs(along) < std::numeric_limits<Scalar>::epsilon()) continue;  // parallel
      const Scalar t = -plane.signed_distance(origin) / along;
      if (t < 0 || t > best_t) continue;
      const Point<2, Scalar> uv = s.surface.frame.to_plane(origin + t * u);
      if (boost::geometry::covered_by(BoostPoint2<Scalar>(uv.x(), uv.y()),
                                      to_boost_polygon(s.surface.polygon))) {
        best = s.id;
        best_t = t;
      }
    }
    return best;
  }

  /// The id of the shape nearest to `point` (distance to the planar region: the plane offset
  /// combined with the in-plane distance to the polygon, zero inside it) if it is within
  /// max_distance, or nothing. Throws invalid_argument for a non-finite point.
  [[nodiscard]] std::optional<std::size_t> select_nearest(
      const Vector3& point, Scalar max_distance = std::numeric_limits<Scalar>::infinity()) const {
    if (!point.allFinite())
      detail::throw_invalid("GeometricMap::select_nearest", "argument 'point' is not finite");
    std::optional<std::size_t> best;
    Scalar best_sq = max_distance * max_distance;
    for (const auto& s : shapes_) {
      const Vector3 q = s.surface.frame.world_to_plane * point;
      const Scalar in_plane = static_cast<Scalar>(boost::geometry::distance(
          BoostPoint2<Scalar>(q.x(), q.y()), to_boost_polygon(s.surface.polygon)));
      const Scalar distance_sq = q.z() * q.z() + in_plane * in_plane;
      if (distance_sq <= best_sq) {
        if (best && distance_sq == best_sq) continue;  // ties: the older shape
        best = s.id;
        best_sq = distance_sq;
      }
    }
    return best;
  }

  /// Removes the shape with this id; false when there is none.
  bool erase(std::size_t id) {
    const auto it = find(id);
    if (it == shapes_.end()) return false;
    shapes_.erase(it);
    return true;
  }

  /// Moves the shape with this id rigidly by `motion` (applied in world coordinates: a point x of
  /// the shape goes to motion * x). The polygon keeps its in-plane coordinates; the plane and its
  /// frame move. The moved shape is not merged with others. Throws invalid_argument for an
  /// unknown id or a non-finite motion.
  void move(std::size_t id, const Transform<3, Scalar>& motion) {
    constexpr const char* where = "GeometricMap::move";
    auto& s = *find_or_throw(where, id);
    if (!motion.matrix().allFinite())
      detail::throw_invalid(where, "argument 'motion' is not finite");
    auto& plane = s.surface.plane;
    plane.normal = (motion.linear() * plane.normal).normalized();
    plane.d -= plane.normal.dot(motion.translation());
    s.surface.frame.world_to_plane =
        s.surface.frame.world_to_plane * motion.inverse(Eigen::Isometry);
    s.centroid = motion * s.centroid;
  }

  // ---- statistics -----------------------------------------------------------------------------

  /// Vertices of every ring of every shape.
  [[nodiscard]] std::size_t vertex_count() const {
    std::size_t n = 0;
    for (const auto& s : shapes_) {
      n += s.surface.polygon.outer.size();
      for (const auto& h : s.surface.polygon.holes)
        n += h.size();
    }
    return n;
  }

  /// Size of the map as paper 004 counts it in Table 5: three 32-bit values per vertex and four
  /// 32-bit plane coefficients per polygon.
  [[nodiscard]] std::size_t bytes() const {
    return (3 * vertex_count() + 4 * size()) * sizeof(float);
  }

  /// Memory this object holds for its shapes (the Shape records and the vertex arrays).
  [[nodiscard]] std::size_t memory_bytes() const {
    std::size_t n = shapes_.capacity() * sizeof(Shape);
    for (const auto& s : shapes_) {
      n += s.surface.polygon.outer.capacity() * sizeof(Point<2, Scalar>);
      n += s.surface.polygon.holes.capacity() * sizeof(std::vector<Point<2, Scalar>>);
      for (const auto& h : s.surface.polygon.holes)
        n += h.capacity() * sizeof(Point<2, Scalar>);
    }
    return n;
  }

 private:
  using ShapeIterator = typename std::vector<Shape>::iterator;
  using ConstShapeIterator = typename std::vector<Shape>::const_iterator;

  Parameters parameters_;
  Clipper clipper_;
  std::vector<Shape> shapes_;  // sorted by id: new shapes get increasing ids and go to the back
  std::size_t next_id_{0};

  [[nodiscard]] ConstShapeIterator find(std::size_t id) const {
    const auto it = std::lower_bound(shapes_.begin(), shapes_.end(), id,
                                     [](const Shape& s, std::size_t v) { return s.id < v; });
    return (it != shapes_.end() && it->id == id) ? it : shapes_.end();
  }
  [[nodiscard]] ShapeIterator find(std::size_t id) {
    const auto it = std::lower_bound(shapes_.begin(), shapes_.end(), id,
                                     [](const Shape& s, std::size_t v) { return s.id < v; });
    return (it != shapes_.end() && it->id == id) ? it : shapes_.end();
  }
  template <class Self>
  static auto find_or_throw_impl(Self& self, const char* where, std::size_t id) {
    const auto it = self.find(id);
    if (it == self.shapes_.end()) detail::throw_invalid_argument(where, "id", id, "names no shape");
    return it;
  }
  [[nodiscard]] ConstShapeIterator find_or_throw(const char* where, std::size_t id) const {
    return find_or_throw_impl(*this, where, id);
  }
  [[nodiscard]] ShapeIterator find_or_throw(const char* where, std::size_t id) {
    return find_or_throw_impl(*this, where, id);
  }

  // The area centroid of the polygon in world coordinates; the vertex mean for a polygon of
  // (near) zero area, where Boost.Geometry has no area centroid.
  static Vector3 centroid_of(const PlanarPolygon<Scalar>& p) {
    BoostPoint2<Scalar> c(Scalar(0), Scalar(0));
    try {
      boost::geometry::centroid(to_boost_polygon(p.polygon), c);
      if (std::isfinite(c.x()) && std::isfinite(c.y()))
        return p.frame.to_world(Point<2, Scalar>(c.x(), c.y()));
    } catch (const boost::geometry::centroid_exception&) {
    }
    Point<2, Scalar> mean = Point<2, Scalar>::Zero();
    for (const auto& v : p.polygon.outer)
      mean += v;
    return p.frame.to_world(mean / static_cast<Scalar>(p.polygon.outer.size()));
  }

  // Polygon2's convention: outer ring counter-clockwise, holes clockwise.
  static void orient(Polygon2<Scalar>& p) {
    if (Polygon2<Scalar>::ring_signed_area(p.outer) < 0)
      std::reverse(p.outer.begin(), p.outer.end());
    for (auto& h : p.holes)
      if (Polygon2<Scalar>::ring_signed_area(h) > 0) std::reverse(h.begin(), h.end());
  }

  // The polygon of `s` in the frame `target`: each vertex back to the world (T_w2p^-1 of its own
  // frame), into the target frame (Eq. 12), and projected onto its plane by dropping z (Eq. 3).
  static Polygon2<Scalar> project(const Shape& s, const PlaneFrame<Scalar>& target,
                                  Eigen::AlignedBox<Scalar, 2>& box) {
    const Transform<3, Scalar> t =
        target.world_to_plane * s.surface.frame.world_to_plane.inverse(Eigen::Isometry);
    const auto map_ring = [&](const std::vector<Point<2, Scalar>>& ring) {
      std::vector<Point<2, Scalar>> out;
      out.reserve(ring.size());
      for (const auto& uv : ring) {
        const Point<2, Scalar> p = (t * Vector3(uv.x(), uv.y(), Scalar(0))).template head<2>();
        box.extend(p);
        out.push_back(p);
      }
      return out;
    };
    Polygon2<Scalar> out;
    out.outer = map_ring(s.surface.polygon.outer);
    for (const auto& h : s.surface.polygon.holes)
      out.holes.push_back(map_ring(h));
    return out;
  }

  // Tries to merge shapes_[older] and shapes_[newer] (older < newer): similarity (Eq. 6), the
  // virtual average plane (Eq. 7) and its frame (Eq. 8-11), projection (Eq. 12, 3), clipping.
  // On success shapes_[older] holds the union and shapes_[newer] is erased.
  bool try_merge(std::size_t older, std::size_t newer) {
    const Shape& a = shapes_[older];
    const Shape& b = shapes_[newer];
    if (!similar(a, b)) return false;
    // Eq. (7) with weights delta_a and delta_b; b's normal flipped towards a's (Eq. 6).
    const Scalar sign = a.surface.plane.normal.dot(b.surface.plane.normal) < 0 ? Scalar(-1) : 1;
    const Vector3 n = a.delta * a.surface.plane.normal + sign * b.delta * b.surface.plane.normal;
    const Scalar d = a.delta * a.surface.plane.d + sign * b.delta * b.surface.plane.d;
    const Scalar norm = n.norm();
    const Plane3<Scalar> p3{n / norm, d / norm};
    const PlaneFrame<Scalar> frame = PlaneFrame<Scalar>::of(p3);
    Eigen::AlignedBox<Scalar, 2> box_a, box_b;
    const Polygon2<Scalar> pa = project(a, frame, box_a);
    const Polygon2<Scalar> pb = project(b, frame, box_b);
    // Disjoint bounding boxes cannot overlap with a positive area: skip the clipper.
    if (!box_a.intersects(box_b) || !clipper_.intersects(pa, pb)) return false;
    std::vector<Polygon2<Scalar>> pieces = clipper_.union_of(pa, pb);
    if (pieces.empty()) return false;
    // Overlapping polygons have a connected union; a union that touches itself only at points
    // may still come back in pieces: the largest stays this shape, the others become new shapes
    // on the same plane with the same weight.
    std::sort(pieces.begin(), pieces.end(),
              [](const auto& x, const auto& y) { return x.area() > y.area(); });
    const Scalar delta = a.delta + b.delta;
    Shape& merged = shapes_[older];
    merged.surface = {p3, frame, std::move(pieces.front())};
    merged.delta = delta;
    merged.centroid = centroid_of(merged.surface);
    shapes_.erase(shapes_.begin() + static_cast<std::ptrdiff_t>(newer));
    for (std::size_t i = 1; i < pieces.size(); ++i) {
      Shape piece{next_id_++, {p3, frame, std::move(pieces[i])}, delta};
      piece.centroid = centroid_of(piece.surface);
      shapes_.push_back(std::move(piece));
    }
    return true;
  }

  // Merges shapes_[index] with every shape it is similar to and intersects, repeatedly, and
  // returns where it ended up.
  GeometricMapInsertion absorb(std::size_t index) {
    GeometricMapInsertion result;
    for (bool changed = true; changed;) {
      changed = false;
      for (std::size_t j = 0; j < shapes_.size(); ++j) {
        if (j == index) continue;
        const std::size_t older = std::min(index, j), newer = std::max(index, j);
        if (try_merge(older, newer)) {
          index = older;
          ++result.merged;
          changed = true;
          break;
        }
      }
    }
    result.id = shapes_[index].id;
    return result;
  }
};

}  // namespace rangenav
