#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/geometry/planar_polygon.hpp"
#include "rangenav/geometry/polygon_clipper.hpp"
#ifdef RANGENAV_HAVE_CLIPPER
#include "rangenav/geometry/vatti_clipper.hpp"
#endif

// Every backend runs the same closed-form cases; where Clipper is installed (the test target
// then defines RANGENAV_HAVE_CLIPPER) the Vatti backend runs them too and both are compared.
#ifdef RANGENAV_HAVE_CLIPPER
#define RANGENAV_CLIPPERS rangenav::BoostGeometryClipper, rangenav::VattiClipper
#else
#define RANGENAV_CLIPPERS rangenav::BoostGeometryClipper
#endif

using namespace rangenav;
using Ring = std::vector<Point2d>;

namespace {

Ring rect(double x0, double y0, double x1, double y1) {
  return {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
}

Ring reversed(Ring r) {
  return {r.rbegin(), r.rend()};
}

Polygon2<> poly(Ring outer, std::vector<Ring> holes = {}) {
  return {std::move(outer), std::move(holes)};
}

// L = [0,3]x[0,1] u [0,1]x[0,3] (area 5) and its copy turned by pi about (1.5, 1.5).
Polygon2<> l_shape() {
  return poly({{0, 0}, {3, 0}, {3, 1}, {1, 1}, {1, 3}, {0, 3}});
}
Polygon2<> l_shape_turned() {
  return poly({{3, 3}, {0, 3}, {0, 2}, {2, 2}, {2, 0}, {3, 0}});
}
// U = [0,3]^2 without the notch [1,2]x[1,3] (area 7).
Polygon2<> u_shape() {
  return poly({{0, 0}, {3, 0}, {3, 3}, {2, 3}, {2, 1}, {1, 1}, {1, 3}, {0, 3}});
}
// [0,4]^2 with the hole [1,3]^2 (area 12); the hole given clockwise.
Polygon2<> frame_shape() {
  return poly(rect(0, 0, 4, 4), {reversed(rect(1, 1, 3, 3))});
}

double total_area(const std::vector<Polygon2<>>& polygons) {
  double a = 0;
  for (const auto& p : polygons)
    a += p.area();
  return a;
}

std::size_t hole_count(const std::vector<Polygon2<>>& polygons) {
  std::size_t n = 0;
  for (const auto& p : polygons)
    n += p.holes.size();
  return n;
}

// Every result follows Polygon2's conventions: outer ring counter-clockwise, holes clockwise,
// open rings.
void check_conventions(const std::vector<Polygon2<>>& polygons) {
  for (const auto& p : polygons) {
    REQUIRE(p.outer.size() >= 3);
    CHECK(Polygon2<>::ring_signed_area(p.outer) > 0);
    CHECK_FALSE(p.outer.front().isApprox(p.outer.back()));
    for (const auto& h : p.holes) {
      REQUIRE(h.size() >= 3);
      CHECK(Polygon2<>::ring_signed_area(h) < 0);
      CHECK_FALSE(h.front().isApprox(h.back()));
    }
  }
}

// A star-shaped concave polygon with n vertices around `center` (radii alternate in [r0, r1]).
Polygon2<> star(Point2d center, int n, double r0, double r1, std::mt19937& rng) {
  std::uniform_real_distribution<double> radius(r0, r1);
  Polygon2<> p;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    const double r = (i % 2 == 0) ? radius(rng) : 0.5 * radius(rng);
    p.outer.push_back(center + r * Point2d(std::cos(a), std::sin(a)));
  }
  return p;
}

}  // namespace

TEMPLATE_TEST_CASE("PolygonClipper: overlapping squares", "[geometry][clipper]",
                   RANGENAV_CLIPPERS) {
  const TestType clipper;
  const auto a = poly(rect(0, 0, 2, 2));
  const auto b = poly(rect(1, 1, 3, 3));
  CHECK(clipper.intersects(a, b));
  CHECK(clipper.intersects(b, a));
  const auto u = clipper.union_of(a, b);
  REQUIRE(u.size() == 1);
  CHECK(u[0].holes.empty());
  CHECK(u[0].area() == Approx(4 + 4 - 1));
  CHECK(u[0].outer.size() == 8);
  check_conventions(u);
}

TEMPLATE_TEST_CASE("PolygonClipper: concave L and U shapes", "[geometry][clipper]",
                   RANGENAV_CLIPPERS) {
  const TestType clipper;
  SECTION("two L shapes overlapping in two squares close a ring around a hole") {
    const auto u = clipper.union_of(l_shape(), l_shape_turned());
    CHECK(clipper.intersects(l_shape(), l_shape_turned()));
    REQUIRE(u.size() == 1);
    REQUIRE(u[0].holes.size() == 1);
    CHECK(u[0].area() == Approx(5 + 5 - 2));
    CHECK(Polygon2<>::ring_signed_area(u[0].holes[0]) == Approx(-1));
    check_conventions(u);
  }
  SECTION("a square across the arms of the U") {
    const auto bar = poly(rect(0.5, 2, 2.5, 4));
    CHECK(clipper.intersects(u_shape(), bar));
    const auto u = clipper.union_of(u_shape(), bar);
    REQUIRE(u.size() == 1);
    REQUIRE(u[0].holes.size() == 1);  // the notch's bottom [1,2]x[1,2] is enclosed
    CHECK(u[0].area() == Approx(7 + 4 - 1));
    check_conventions(u);
  }
  SECTION("a square inside the notch touches the U along edges only") {
    const auto plug = poly(rect(1, 2, 2, 4));
    CHECK_FALSE(clipper.intersects(u_shape(), plug));
    const auto u = clipper.union_of(u_shape(), plug);
    CHECK(total_area(u) == Approx(7 + 2));
    CHECK(hole_count(u) == 1);
    check_conventions(u);
  }
}

TEMPLATE_TEST_CASE("PolygonClipper: polygons with holes", "[geometry][clipper]",
                   RANGENAV_CLIPPERS) {
  const TestType clipper;
  SECTION("a square over a corner of the hole leaves an L-shaped hole") {
    const auto b = poly(rect(2, 2, 5, 5));
    CHECK(clipper.intersects(frame_shape(), b));
    const auto u = clipper.union_of(frame_shape(), b);
    REQUIRE(u.size() == 1);
    REQUIRE(u[0].holes.size() == 1);
    CHECK(u[0].area() == Approx(12 + 9 - 3));
    CHECK(Polygon2<>::ring_signed_area(u[0].holes[0]) == Approx(-3));
    check_conventions(u);
  }
  SECTION("an island inside the hole does not intersect and stays a polygon of its own") {
    const auto island = poly(rect(1.5, 1.5, 2.5, 2.5));
    CHECK_FALSE(clipper.intersects(frame_shape(), island));
    const auto u = clipper.union_of(frame_shape(), island);
    CHECK(u.size() == 2);
    CHECK(total_area(u) == Approx(12 + 1));
    check_conventions(u);
  }
  SECTION("a square covering the hole fills it") {
    const auto patch = poly(rect(0.5, 0.5, 3.5, 3.5));
    const auto u = clipper.union_of(frame_shape(), patch);
    REQUIRE(u.size() == 1);
    CHECK(u[0].holes.empty());
    CHECK(u[0].area() == Approx(16));
  }
}

TEMPLATE_TEST_CASE("PolygonClipper: disjoint, touching and contained polygons",
                   "[geometry][clipper]", RANGENAV_CLIPPERS) {
  const TestType clipper;
  const auto unit = poly(rect(0, 0, 1, 1));
  SECTION("disjoint") {
    const auto other = poly(rect(2, 0, 3, 1));
    CHECK_FALSE(clipper.intersects(unit, other));
    const auto u = clipper.union_of(unit, other);
    CHECK(u.size() == 2);
    CHECK(total_area(u) == Approx(2));
    check_conventions(u);
  }
  SECTION("touching along an edge: no intersection, one polygon") {
    const auto other = poly(rect(1, 0, 2, 1));
    CHECK_FALSE(clipper.intersects(unit, other));
    const auto u = clipper.union_of(unit, other);
    REQUIRE(u.size() == 1);
    CHECK(u[0].area() == Approx(2));
    check_conventions(u);
  }
  SECTION("touching at a corner") {
    const auto other = poly(rect(1, 1, 2, 2));
    CHECK_FALSE(clipper.intersects(unit, other));
    const auto u = clipper.union_of(unit, other);
    CHECK(total_area(u) == Approx(2));
    check_conventions(u);
  }
  SECTION("containment, either way round") {
    const auto big = poly(rect(-1, -1, 3, 3));
    CHECK(clipper.intersects(unit, big));
    CHECK(clipper.intersects(big, unit));
    for (const auto& u : {clipper.union_of(unit, big), clipper.union_of(big, unit)}) {
      REQUIRE(u.size() == 1);
      CHECK(u[0].area() == Approx(16));
      CHECK(u[0].outer.size() == 4);
    }
  }
  SECTION("clockwise input is accepted") {
    const auto cw = poly(reversed(rect(0.5, 0.5, 1.5, 1.5)));
    CHECK(clipper.intersects(unit, cw));
    const auto u = clipper.union_of(unit, cw);
    REQUIRE(u.size() == 1);
    CHECK(u[0].area() == Approx(1.75));
    check_conventions(u);
  }
}

TEMPLATE_TEST_CASE("PolygonClipper: overlaps with no vertex of one inside the other",
                   "[geometry][clipper]", RANGENAV_CLIPPERS) {
  const TestType clipper;
  SECTION("a plus sign: two bars crossing, every vertex outside the other bar") {
    const auto h = poly(rect(-1, -0.1, 1, 0.1));
    const auto v = poly(rect(-0.1, -1, 0.1, 1));
    CHECK(clipper.intersects(h, v));
    CHECK(clipper.intersects(v, h));
    const auto u = clipper.union_of(h, v);
    REQUIRE(u.size() == 1);
    CHECK(u[0].area() == Approx(0.4 + 0.4 - 0.04));
    CHECK(u[0].outer.size() == 12);
  }
  SECTION("a polygon without area (collinear vertices) inside a square overlaps nothing") {
    const auto square = poly(rect(0, 0, 2, 2));
    const auto flat = poly({{0.5, 1}, {1, 1}, {1.5, 1}});
    CHECK_FALSE(clipper.intersects(square, flat));
    CHECK_FALSE(clipper.intersects(flat, square));
  }
  SECTION("a square inside the L's bounding box but off the L") {
    const auto off = poly(rect(2, 2, 3, 3));
    CHECK_FALSE(clipper.intersects(l_shape(), off));
    CHECK_FALSE(clipper.intersects(off, l_shape()));
    CHECK(total_area(clipper.union_of(l_shape(), off)) == Approx(5 + 1));
  }
  SECTION("a bar across the frame's hole, its vertices in the hole or outside") {
    const auto bar = poly(rect(-1, 1.5, 2, 2.5));  // from outside over the frame into the hole
    CHECK(clipper.intersects(frame_shape(), bar));
    const auto u = clipper.union_of(frame_shape(), bar);
    REQUIRE(u.size() == 1);
    CHECK(u[0].area() == Approx(12 + 3 - 1));
  }
}

TEMPLATE_TEST_CASE("PolygonClipper: intersects agrees with the union's inclusion-exclusion",
                   "[geometry][clipper]", RANGENAV_CLIPPERS) {
  // area(a ∩ b) = area(a) + area(b) - area(a ∪ b): the intersection test must say true exactly
  // when that is positive, on random concave 64-gons from far apart to nested (each backend's
  // union against its own intersection test; Boost's test runs no overlay).
  const TestType clipper;
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> offset(-2.6, 2.6);
  int hits = 0, misses = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const auto a = star({0, 0}, 64, 0.8, 1.2, rng);
    const auto b = star({offset(rng), offset(rng)}, 64, 0.4, 1.2, rng);
    const double common = a.area() + b.area() - total_area(clipper.union_of(a, b));
    const bool hit = clipper.intersects(a, b);
    // (Clipper's micrometre grid moves the areas by up to ~1e-5 m^2.)
    if (hit)
      CHECK(common > 0);
    else
      CHECK(common == Approx(0).margin(1e-4));
    CHECK(clipper.intersects(b, a) == hit);
    (hit ? hits : misses) += 1;
  }
  CHECK(hits > 10);
  CHECK(misses > 10);
}

TEMPLATE_TEST_CASE("PolygonClipper: bad input", "[geometry][clipper]", RANGENAV_CLIPPERS) {
  const TestType clipper;
  const auto unit = poly(rect(0, 0, 1, 1));
  const auto segment = poly({{0, 0}, {1, 0}});
  CHECK_THROWS_WITH(clipper.intersects(segment, unit),
                    Catch::Contains("::intersects: argument 'a.outer vertices' = 2 must be >= 3"));
  CHECK_THROWS_WITH(clipper.union_of(unit, poly(rect(0, 0, 1, 1), {{{0.5, 0.5}}})),
                    Catch::Contains("::union_of: argument 'b.holes[i] vertices' = 1 must be >= 3"));
  auto nan_poly = unit;
  nan_poly.outer[2].x() = std::nan("");
  CHECK_THROWS_WITH(clipper.union_of(unit, nan_poly),
                    Catch::Contains("argument 'b' has a non-finite vertex"));
  CHECK_THROWS_AS(clipper.intersects(Polygon2<>{}, unit), invalid_argument);
}

TEST_CASE("PolygonClipper: float polygons", "[geometry][clipper]") {
  const BoostGeometryClipper clipper;
  const Polygon2<float> a{{{0, 0}, {2, 0}, {2, 2}, {0, 2}}, {}};
  const Polygon2<float> b{{{1, 1}, {3, 1}, {3, 3}, {1, 3}}, {}};
  CHECK(clipper.intersects(a, b));
  const auto u = clipper.union_of(a, b);
  REQUIRE(u.size() == 1);
  CHECK(u[0].area() == Approx(7.0f));
}

#ifdef RANGENAV_HAVE_CLIPPER
TEST_CASE("VattiClipper: backends agree on random concave 64-gons", "[geometry][clipper]") {
  std::mt19937 rng(9);
  const BoostGeometryClipper boost_clipper;
  const VattiClipper vatti;
  int overlapping = 0;
  for (int trial = 0; trial < 40; ++trial) {
    std::uniform_real_distribution<double> offset(-1.5, 1.5);
    const auto a = star({0, 0}, 64, 0.8, 1.2, rng);
    const auto b = star({offset(rng), offset(rng)}, 64, 0.8, 1.2, rng);
    const bool hit = boost_clipper.intersects(a, b);
    CHECK(vatti.intersects(a, b) == hit);
    overlapping += hit ? 1 : 0;
    const auto ub = boost_clipper.union_of(a, b);
    const auto uv = vatti.union_of(a, b);
    // The micrometre grid moves each vertex by < 1e-6 m: areas agree to ~perimeter * 1e-6.
    CHECK(total_area(uv) == Approx(total_area(ub)).margin(1e-4));
    CHECK(total_area(ub) <= a.area() + b.area() + 1e-9);
    check_conventions(uv);
  }
  CHECK(overlapping > 10);
}

TEST_CASE("VattiClipper: scale and coordinate range", "[geometry][clipper]") {
  CHECK_THROWS_WITH(VattiClipper(0.0),
                    "rangenav: VattiClipper: argument 'scale' = 0 must be finite and > 0");
  CHECK(VattiClipper().scale() == 1e6);
  const VattiClipper coarse(10.0);  // a 0.1 grid rounds (0.04, 0.04) away
  const auto u = coarse.union_of(poly(rect(0.04, 0.04, 1, 1)), poly(rect(0.5, 0.5, 2, 2)));
  REQUIRE(u.size() == 1);
  CHECK(u[0].area() == Approx(1 + 2.25 - 0.25));
  const auto far = poly(rect(0, 0, 1e13, 1e13));
  CHECK_THROWS_WITH(VattiClipper().intersects(far, far),
                    Catch::Contains("argument 'vertex coordinate * scale' = 1e+19 must be within "
                                    "Clipper's range"));
}
#endif
