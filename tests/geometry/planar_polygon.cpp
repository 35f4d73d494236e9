#include <catch2/catch.hpp>

#include <cmath>

#include "rangenav/core/error.hpp"
#include "rangenav/geometry/planar_polygon.hpp"

using namespace rangenav;

TEST_CASE("Plane3 normalises coefficients and measures Eq. (2) distances", "[geometry]") {
  const auto pl = Plane3<>::from_coefficients(0, 0, 2, -3);  // z = 1.5
  CHECK(pl.normal.isApprox(Point3d(0, 0, 1)));
  CHECK(pl.d == Approx(-1.5));
  CHECK(pl.signed_distance(Point3d(4, -2, 2.5)) == Approx(1.0));
  CHECK(pl.project(Point3d(4, -2, 2.5)).isApprox(Point3d(4, -2, 1.5)));
  const auto f = pl.flipped();
  CHECK(f.signed_distance(Point3d(0, 0, 2.5)) == Approx(-1.0));
  const auto through = Plane3<>::through(Point3d(1, 2, 3), Point3d(1, 1, 0));
  CHECK(through.signed_distance(Point3d(1, 2, 3)) == Approx(0).margin(1e-12));
  CHECK(through.normal.norm() == Approx(1));
}

TEST_CASE("Plane3 rejects degenerate and non-finite coefficients", "[geometry]") {
  CHECK_THROWS_WITH(Plane3<>::from_coefficients(0, 0, 0, 1),
                    Catch::Contains("argument '|(a, b, c)|' = 0 must be > 0"));
  CHECK_THROWS_AS(Plane3<>::from_coefficients(std::nan(""), 0, 1, 0), invalid_argument);
}

TEST_CASE("PlaneFrame maps the plane onto z = 0 and back", "[geometry]") {
  // n = (1, -1, 0)/sqrt2 makes Eq. (8)'s denominator zero: the frame must still work.
  for (const Point3d& n : {Point3d(0, 0, 1), Point3d(1, -1, 0), Point3d(0.3, 0.4, -0.8)}) {
    const auto pl = Plane3<>::through(Point3d(0.5, -1, 2), n);
    const auto frame = PlaneFrame<>::of(pl);
    const Eigen::Matrix3d r = frame.world_to_plane.linear();
    CHECK((r * r.transpose()).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
    CHECK(r.determinant() == Approx(1));
    const Point3d on = pl.project(Point3d(3, 1, -2));
    CHECK((frame.world_to_plane * on).z() == Approx(0).margin(1e-12));
    CHECK(frame.to_world(frame.to_plane(on)).isApprox(on, 1e-12));
    const Point3d off = on + 0.25 * pl.normal;
    CHECK((frame.world_to_plane * off).z() == Approx(0.25));
    CHECK(frame.to_plane(off).isApprox(frame.to_plane(on), 1e-12));
  }
}

TEST_CASE("Polygon2 area subtracts holes and PlanarPolygon lifts its ring", "[geometry]") {
  Polygon2<> sq;
  sq.outer = {{0, 0}, {2, 0}, {2, 2}, {0, 2}};
  CHECK(sq.area() == Approx(4));
  sq.holes.push_back({{0.5, 0.5}, {0.5, 1.5}, {1.5, 1.5}, {1.5, 0.5}});  // clockwise
  CHECK(sq.area() == Approx(3));

  PlanarPolygon<> table;
  table.plane = Plane3<>::from_coefficients(0, 0, 1, -0.75);
  table.frame = PlaneFrame<>::of(table.plane);
  table.polygon = sq;
  CHECK(table.area() == Approx(3));
  for (const Point3d& p : table.outer_world())
    CHECK(p.z() == Approx(0.75));
}
