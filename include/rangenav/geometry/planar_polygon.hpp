#pragma once
// Planes and planar polygons, the vocabulary of the geometric maps of paper 004: a plane in
// Cartesian form (Eq. 4-5), the point-to-plane distance and projection (Eq. 1-3), a right-handed
// frame whose z axis is the plane normal (the clipping frame of Eq. 8-11), and a polygon with holes
// expressed in that frame. Plane extraction produces PlanarPolygons, the geometric map merges them.

#include <cmath>
#include <cstddef>
#include <vector>

#include <Eigen/Geometry>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// The plane n . x + d = 0 with a unit normal n (Eq. 4-5 of paper 004, normalised).
template <class Scalar = double>
struct Plane3 {
  Point<3, Scalar> normal{0, 0, 1};  ///< unit normal n
  Scalar d{0};                       ///< offset: n . x + d = 0 on the plane

  /// The plane a x + b y + c z + d = 0, normalised so that |(a, b, c)| = 1. Throws
  /// invalid_argument when a coefficient is not finite or (a, b, c) is (near) zero.
  [[nodiscard]] static Plane3 from_coefficients(Scalar a, Scalar b, Scalar c, Scalar d) {
    constexpr const char* where = "Plane3::from_coefficients";
    detail::require_finite(where, "a", a);
    detail::require_finite(where, "b", b);
    detail::require_finite(where, "c", c);
    detail::require_finite(where, "d", d);
    const Point<3, Scalar> n(a, b, c);
    const Scalar norm = n.norm();
    if (!(norm > Scalar(1e-12)))
      detail::throw_invalid_argument(where, "|(a, b, c)|", norm, "must be > 0");
    return {n / norm, d / norm};
  }

  /// The plane through `point` with normal direction `normal` (normalised here).
  [[nodiscard]] static Plane3 through(const Point<3, Scalar>& point,
                                      const Point<3, Scalar>& normal) {
    return from_coefficients(normal.x(), normal.y(), normal.z(), -normal.dot(point));
  }

  /// Signed distance delta = n . (p - a) of Eq. (2), with a = -d n the plane point nearest the
  /// origin; positive on the side the normal points to.
  [[nodiscard]] Scalar signed_distance(const Point<3, Scalar>& p) const {
    return normal.dot(p) + d;
  }

  /// Orthogonal projection p_pr = p - delta n of Eq. (3).
  [[nodiscard]] Point<3, Scalar> project(const Point<3, Scalar>& p) const {
    return p - signed_distance(p) * normal;
  }

  /// The same plane with the normal pointing the other way.
  [[nodiscard]] Plane3 flipped() const { return {-normal, -d}; }
};

/// A simple polygon with holes in 2D: `outer` counter-clockwise, every hole clockwise; rings are
/// open (the first vertex is not repeated at the end).
template <class Scalar = double>
struct Polygon2 {
  std::vector<Point<2, Scalar>> outer;               ///< outer ring, counter-clockwise, open
  std::vector<std::vector<Point<2, Scalar>>> holes;  ///< holes, each clockwise, open

  /// Area enclosed by `outer` minus the holes (shoelace formula on each ring).
  [[nodiscard]] Scalar area() const {
    Scalar a = ring_signed_area(outer);
    for (const auto& h : holes)
      a += ring_signed_area(h);
    return a;
  }

  /// Twice-halved shoelace sum: > 0 for counter-clockwise rings.
  [[nodiscard]] static Scalar ring_signed_area(const std::vector<Point<2, Scalar>>& ring) {
    Scalar s = 0;
    for (std::size_t i = 0, n = ring.size(); i < n; ++i) {
      const auto& p = ring[i];
      const auto& q = ring[(i + 1) % n];
      s += p.x() * q.y() - q.x() * p.y();
    }
    return s / Scalar(2);
  }
};

/// A right-handed frame on a plane: z along the plane normal, x and y in the plane, origin on the
/// plane (Eq. 8-11 of paper 004). `world_to_plane` maps world points into the frame; the z
/// coordinate of a mapped point is its signed distance to the plane.
template <class Scalar = double>
struct PlaneFrame {
  /// maps world points into the frame
  Transform<3, Scalar> world_to_plane = Transform<3, Scalar>::Identity();

  /// The frame of `plane`. Its x axis is the world axis least aligned with the normal, made
  /// orthogonal to it, so the frame is a continuous function of the plane away from axis ties.
  /// The origin is the plane point nearest the world origin, -d n: paper 004's Eq. (8) puts it at
  /// x = y = z = -d / (n_x + n_y + n_z), which is undefined when the normal's components sum to
  /// zero (e.g. n = (1, -1, 0) / sqrt 2), so the nearest point is used instead.
  [[nodiscard]] static PlaneFrame of(const Plane3<Scalar>& plane) {
    const Point<3, Scalar> z = plane.normal;
    Eigen::Index axis = 0;
    z.cwiseAbs().minCoeff(&axis);
    Point<3, Scalar> x = Point<3, Scalar>::Unit(axis);
    x = (x - x.dot(z) * z).normalized();
    const Point<3, Scalar> y = z.cross(x);
    Eigen::Matrix<Scalar, 3, 3> r;  // Eq. (9): the rows are the frame's axes
    r.row(0) = x.transpose();
    r.row(1) = y.transpose();
    r.row(2) = z.transpose();
    const Point<3, Scalar> origin = -plane.d * z;
    PlaneFrame f;
    f.world_to_plane.linear() = r;
    f.world_to_plane.translation() = -(r * origin);  // Eq. (10), sign for x_plane = R (x - o)
    return f;
  }

  /// In-plane coordinates of a world point (its projection, Eq. 3, expressed in the frame).
  [[nodiscard]] Point<2, Scalar> to_plane(const Point<3, Scalar>& world) const {
    return (world_to_plane * world).template head<2>();
  }

  /// The world point at in-plane coordinates `uv`.
  [[nodiscard]] Point<3, Scalar> to_world(const Point<2, Scalar>& uv) const {
    return world_to_plane.inverse(Eigen::Isometry) * Point<3, Scalar>(uv.x(), uv.y(), Scalar(0));
  }
};

/// A bounded planar surface: its plane, the frame its polygon is expressed in, and the polygon
/// (e.g. the concave hull of a plane's inliers).
template <class Scalar = double>
struct PlanarPolygon {
  Plane3<Scalar> plane;      ///< the plane the polygon lies on
  PlaneFrame<Scalar> frame;  ///< the frame the polygon's coordinates are given in
  Polygon2<Scalar> polygon;  ///< the outline, in the frame's x-y coordinates

  /// The outer ring's vertices in world coordinates.
  [[nodiscard]] std::vector<Point<3, Scalar>> outer_world() const {
    std::vector<Point<3, Scalar>> out;
    out.reserve(polygon.outer.size());
    for (const auto& uv : polygon.outer)
      out.push_back(frame.to_world(uv));
    return out;
  }

  /// Area of the polygon (m^2), holes subtracted.
  [[nodiscard]] Scalar area() const { return polygon.area(); }
};

}  // namespace rangenav
