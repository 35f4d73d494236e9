#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/geometry/planar_polygon.hpp"
#include "rangenav/geometry/polygon_clipper.hpp"
#include "rangenav/mapping/geometric_map.hpp"
#include "rangenav/sim/worlds.hpp"
#ifdef RANGENAV_HAVE_CLIPPER
#include "rangenav/geometry/vatti_clipper.hpp"
#endif

// Where Clipper is installed (the target then defines RANGENAV_HAVE_CLIPPER) the map is tested
// with both PolygonClipper backends.
using BoostGeometryMap = rangenav::GeometricMap<double>;
#ifdef RANGENAV_HAVE_CLIPPER
using VattiMap = rangenav::GeometricMap<double, rangenav::VattiClipper>;
#define RANGENAV_MAPS BoostGeometryMap, VattiMap
#else
#define RANGENAV_MAPS BoostGeometryMap
#endif

using namespace rangenav;

namespace {

// The PlanarPolygon of `plane` whose outer ring has these world vertices (projected onto it).
PlanarPolygon<> planar(const Plane3<>& plane, const std::vector<Point3d>& world_outer) {
  PlanarPolygon<> p{plane, PlaneFrame<>::of(plane), {}};
  for (const auto& w : world_outer)
    p.polygon.outer.push_back(p.frame.to_plane(w));
  return p;
}

// A horizontal rectangle [x0,x1]x[y0,y1] at height z, normal +z (or -z when `down`).
PlanarPolygon<> horizontal(double x0, double y0, double x1, double y1, double z,
                           bool down = false) {
  const auto plane = Plane3<>::from_coefficients(0, 0, down ? -1 : 1, down ? z : -z);
  return planar(plane, {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}});
}

// Rotation by `angle` about a random unit axis.
Eigen::Matrix3d random_tilt(double angle, std::mt19937& rng) {
  std::normal_distribution<double> g(0, 1);
  const Point3d axis = Point3d(g(rng), g(rng), g(rng)).normalized();
  return Eigen::AngleAxisd(angle, axis).toRotationMatrix();
}

// Splits the true plane's outline (a rectangle in its frame) into nu x nv tiles that overlap their
// neighbours by `overlap` (clipped to the outline, so the tiles' union is the outline), tilts
// each tile's plane by up to `max_tilt` about its centre and shifts it by up to `max_shift`.
std::vector<PlanarPolygon<>> split(const sim::ScenePlane& truth, int nu, int nv, double overlap,
                                   double max_tilt, double max_shift, std::mt19937& rng) {
  const Plane3<> plane{truth.normal, truth.d};
  const auto frame = PlaneFrame<>::of(plane);
  Eigen::AlignedBox2d box;
  for (const auto& w : truth.outline)
    box.extend(frame.to_plane(w));
  std::uniform_real_distribution<double> unit(-1, 1);
  std::vector<PlanarPolygon<>> tiles;
  const Point2d size = box.sizes();
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      const Point2d lo = box.min() + Point2d(size.x() * i / nu, size.y() * j / nv);
      const Point2d hi = box.min() + Point2d(size.x() * (i + 1) / nu, size.y() * (j + 1) / nv);
      const Point2d a = (lo.array() - overlap).max(box.min().array()).matrix();
      const Point2d b = (hi.array() + overlap).min(box.max().array()).matrix();
      const Point3d centre = frame.to_world(0.5 * (a + b));
      const Point3d normal = random_tilt(max_tilt * std::abs(unit(rng)), rng) * plane.normal;
      const Point3d shifted = centre + max_shift * unit(rng) * plane.normal;
      const auto tilted = Plane3<>::through(shifted, normal);
      std::vector<Point3d> corners;
      for (const Point2d& c : {a, Point2d(b.x(), a.y()), b, Point2d(a.x(), b.y())})
        corners.push_back(tilted.project(frame.to_world(c)));
      tiles.push_back(planar(tilted, corners));
    }
  }
  return tiles;
}

double true_area(const sim::ScenePlane& truth) {
  const auto frame = PlaneFrame<>::of(Plane3<>{truth.normal, truth.d});
  Polygon2<> p;
  for (const auto& w : truth.outline)
    p.outer.push_back(frame.to_plane(w));
  return std::abs(p.area());
}

}  // namespace

TEMPLATE_TEST_CASE("GeometricMap merges the kitchen's split planes back into one shape each",
                   "[mapping][geometric_map]", RANGENAV_MAPS) {
  const auto scene = sim::kitchen();
  REQUIRE(scene.planes.size() == 5);
  std::mt19937 rng(4);
  std::vector<PlanarPolygon<>> pieces;
  std::vector<std::size_t> pieces_per_plane;
  for (const auto& truth : scene.planes) {
    // 5 m floor pieces tilted by 0.3 deg shift d by up to 0.03 m: well inside t2 = 0.1.
    const auto tiles = split(truth, 3, 2, 0.15, 0.005, 0.005, rng);
    pieces.insert(pieces.end(), tiles.begin(), tiles.end());
    pieces_per_plane.push_back(tiles.size());
  }
  std::shuffle(pieces.begin(), pieces.end(), rng);

  TestType map;
  std::size_t merges = 0;  // each merge removes one shape from the map
  for (const auto& p : pieces)
    merges += map.insert(p).merged;
  REQUIRE(map.size() == scene.planes.size());
  CHECK(merges == pieces.size() - scene.planes.size());
  double total_delta = 0;
  for (const auto& s : map.shapes())
    total_delta += s.delta;
  CHECK(total_delta == Approx(static_cast<double>(pieces.size())));

  for (std::size_t k = 0; k < scene.planes.size(); ++k) {
    const auto& truth = scene.planes[k];
    INFO(truth.name);
    const Plane3<> true_plane{truth.normal, truth.d};
    int associated = 0;
    for (const auto& s : map.shapes()) {
      const auto& plane = s.surface.plane;
      if (std::abs(plane.normal.dot(truth.normal)) < 0.999 || std::abs(plane.d - truth.d) > 0.02)
        continue;
      ++associated;
      CHECK(s.delta == Approx(static_cast<double>(pieces_per_plane[k])));
      CHECK(s.surface.polygon.holes.empty());
      // The merged hull covers the true outline: its area, and every vertex near the plane.
      CHECK(s.surface.area() == Approx(true_area(truth)).epsilon(0.01));
      for (const auto& w : s.surface.outer_world())
        CHECK(std::abs(true_plane.signed_distance(w)) < 0.03);
    }
    CHECK(associated == 1);
  }
}

TEMPLATE_TEST_CASE("GeometricMap keeps planes that are not similar or do not overlap apart",
                   "[mapping][geometric_map]", RANGENAV_MAPS) {
  TestType map;
  const auto base = horizontal(0, 0, 2, 2, 0);
  SECTION("0.15 m apart: beyond t2") {
    map.insert(base);
    CHECK(map.insert(horizontal(1, 1, 3, 3, 0.15)).merged == 0);
    CHECK(map.size() == 2);
  }
  SECTION("normals 20 deg apart: |n1 . n2| = 0.94 < t1") {
    map.insert(base);
    const Eigen::Matrix3d r =
        Eigen::AngleAxisd(20 * std::numbers::pi / 180, Point3d::UnitX()).toRotationMatrix();
    const auto tilted = Plane3<>::through({1, 1, 0}, r * Point3d::UnitZ());
    CHECK_FALSE(map.similar(base.plane, tilted));
    std::vector<Point3d> corners;
    for (const auto& c :
         {Point3d(0.5, 0.5, 0), Point3d(1.5, 0.5, 0), Point3d(1.5, 1.5, 0), Point3d(0.5, 1.5, 0)})
      corners.push_back(tilted.project(c));
    CHECK(map.insert(planar(tilted, corners)).merged == 0);
    CHECK(map.size() == 2);
  }
  SECTION("similar but disjoint, or touching along an edge only") {
    map.insert(base);
    CHECK(map.insert(horizontal(3, 0, 4, 1, 0.02)).merged == 0);
    CHECK(map.insert(horizontal(2, 0, 2.5, 2, 0)).merged == 0);
    CHECK(map.size() == 3);
  }
  SECTION("just inside both thresholds of the paper's Eq. (6b) at the origin: merged") {
    GeometricMapParameters<double> paper;
    paper.offset_test = PlaneOffsetTest::origin;
    map = TestType(paper);
    map.insert(base);
    const Eigen::Matrix3d r =
        Eigen::AngleAxisd(15 * std::numbers::pi / 180, Point3d::UnitY()).toRotationMatrix();
    // d compares the planes at the origin (Eq. 6b): the tilted plane passes 0.05 m above it.
    const auto tilted = Plane3<>::through({0, 0, 0.05}, r * Point3d::UnitZ());
    REQUIRE(map.similar(base.plane, tilted));
    std::vector<Point3d> corners;
    for (const auto& c : {Point3d(1, 1, 0), Point3d(3, 1, 0), Point3d(3, 3, 0), Point3d(1, 3, 0)})
      corners.push_back(tilted.project(c));
    CHECK(map.insert(planar(tilted, corners)).merged == 1);
    CHECK(map.size() == 1);
  }
}

TEMPLATE_TEST_CASE("GeometricMap: Eq. (6b) at the origin or at the shapes' centroids",
                   "[mapping][geometric_map]", RANGENAV_MAPS) {
  // One true plane z = 0 seen as two overlapping pieces 5 m from the origin, the second fitted
  // 3 deg off about the y axis through (5, 0, 0), as plane extraction delivers a small or noisy
  // surface: the offsets at the origin differ by 5 sin 3 deg = 0.26 m > t2, at the pieces by
  // less than 0.5 sin 3 deg = 0.026 m.
  const double tilt = 3 * std::numbers::pi / 180;
  const auto pieces = [&](const Point3d& shift) {
    const Point3d pivot = Point3d(5, 0, 0) + shift;
    const auto truth = Plane3<>::through(pivot, Point3d::UnitZ());
    const auto tilted =
        Plane3<>::through(pivot, Eigen::AngleAxisd(tilt, Point3d::UnitY()) * Point3d::UnitZ());
    std::vector<Point3d> a, b;
    for (const auto& c :
         {Point3d(4, -0.5, 0), Point3d(5, -0.5, 0), Point3d(5, 0.5, 0), Point3d(4, 0.5, 0)}) {
      a.push_back(c + shift);
      b.push_back(tilted.project(c + Point3d(0.5, 0, 0) + shift));
    }
    return std::pair{planar(truth, a), planar(tilted, b)};
  };
  GeometricMapParameters<double> paper, at_centroid;
  paper.offset_test = PlaneOffsetTest::origin;
  at_centroid.offset_test = PlaneOffsetTest::centroid;
  CHECK(GeometricMapParameters<double>{}.offset_test == PlaneOffsetTest::centroid);

  SECTION("two pieces of one plane, 5 m out, 3 deg apart: only the centroid test merges them") {
    const auto [a, b] = pieces(Point3d::Zero());
    CHECK(std::abs(a.plane.d - b.plane.d) == Approx(5 * std::sin(tilt)).epsilon(1e-6));
    TestType origin_map(paper), centroid_map(at_centroid);
    origin_map.insert(a);
    CHECK(origin_map.insert(b).merged == 0);
    CHECK(origin_map.size() == 2);
    centroid_map.insert(a);
    CHECK(centroid_map.insert(b).merged == 1);
    REQUIRE(centroid_map.size() == 1);
    // Eq. (7) with weights 1 and 1: the normal halfway, 1.5 deg off the truth, and the plane
    // still through the pivot both pieces share; the union spans x in [4, 5.5] (1.5 m^2 up to the
    // cos 3 deg of the tilted piece's projection).
    const auto& merged = centroid_map.shapes().front().surface;
    CHECK(std::acos(merged.plane.normal.dot(Point3d::UnitZ())) == Approx(tilt / 2));
    CHECK(merged.plane.signed_distance({5, 0, 0}) == Approx(0).margin(1e-9));
    CHECK(merged.area() == Approx(1.5).epsilon(0.01));
    // The centroid of the union, in the world.
    CHECK((centroid_map.shapes().front().centroid - Point3d(4.75, 0, 0)).norm() < 0.01);
  }
  SECTION("the same pieces next to the origin: both tests merge them") {
    const auto [a, b] = pieces(Point3d(-5, 0, 0));
    for (const auto& params : {paper, at_centroid}) {
      TestType map(params);
      map.insert(a);
      CHECK(map.insert(b).merged == 1);
      CHECK(map.size() == 1);
    }
  }
  SECTION("the centroid test is translation-invariant") {
    for (const Point3d& shift : {Point3d(-5, 0, 0), Point3d(20, -30, 0), Point3d(0, 0, 7)}) {
      const auto [a, b] = pieces(shift);
      TestType map(at_centroid);
      map.insert(a);
      CHECK(map.insert(b).merged == 1);
    }
  }
  SECTION("two parallel overlapping planes 15 cm apart stay apart under both tests") {
    for (const Point3d& shift : {Point3d(0, 0, 0), Point3d(-5, 0, 0)}) {
      const auto [a, b] = pieces(shift);
      auto above = a;
      above.plane.d -= 0.15;  // z = 0.15 (+ shift.z), same frame orientation
      above.frame = PlaneFrame<>::of(above.plane);
      above.polygon.outer.clear();
      for (const auto& c : a.outer_world())
        above.polygon.outer.push_back(above.frame.to_plane(c + Point3d(0.3, 0, 0.15)));
      for (const auto& params : {paper, at_centroid}) {
        TestType map(params);
        map.insert(a);
        CHECK(map.insert(above).merged == 0);
        CHECK(map.size() == 2);
      }
    }
  }
}

TEMPLATE_TEST_CASE("GeometricMap: weighted average plane (Eq. 7), normal flipping and delta",
                   "[mapping][geometric_map]", RANGENAV_MAPS) {
  TestType map;
  const auto first = map.insert(horizontal(0, 0, 2, 2, 0));
  CHECK(first.merged == 0);
  CHECK(map.shape(first.id).delta == 1);
  // delta = 1 and 1: the average of z = 0 and z = 0.06.
  const auto second = map.insert(horizontal(1, 0, 3, 2, 0.06));
  CHECK(second.merged == 1);
  CHECK(second.id == first.id);
  REQUIRE(map.size() == 1);
  const auto& s = map.shape(first.id);
  CHECK(s.delta == 2);
  CHECK(s.surface.plane.normal.isApprox(Point3d::UnitZ()));
  CHECK(s.surface.plane.d == Approx(-0.03));
  CHECK(s.surface.area() == Approx(6));
  // delta = 2 against 1: (2 * 0.03 + 0.09) / 3 = 0.05; the new normal points down and is flipped.
  const auto third = map.insert(horizontal(0, 1, 2, 4, 0.09, true));
  CHECK(third.merged == 1);
  REQUIRE(map.size() == 1);
  const auto& t = map.shape(first.id);
  CHECK(t.delta == 3);
  CHECK(t.surface.plane.normal.isApprox(Point3d::UnitZ()));
  CHECK(t.surface.plane.d == Approx(-0.05));
  CHECK(t.surface.area() == Approx(6 + 2 * 2));  // [0,3]x[0,2] u [0,2]x[1,4]
  // Clipper drops the collinear input vertices (0, 1), (0, 2); Boost.Geometry keeps them.
  CHECK(t.surface.polygon.outer.size() >= 6);
  for (const auto& w : t.surface.outer_world())
    CHECK(w.z() == Approx(0.05));
}

TEMPLATE_TEST_CASE("GeometricMap merges transitively when a polygon bridges two shapes",
                   "[mapping][geometric_map]", RANGENAV_MAPS) {
  TestType map;
  const auto left = map.insert(horizontal(0, 0, 1, 1, 0)).id;
  const auto right = map.insert(horizontal(2, 0, 3, 1, 0)).id;
  map.insert(horizontal(5, 5, 6, 6, 0));
  REQUIRE(map.size() == 3);
  const auto bridge = map.insert(horizontal(0.5, 0.25, 2.5, 0.75, 0));
  CHECK(bridge.merged == 2);
  // insert(vector) counts the polygons that merged: one of these two.
  CHECK(map.insert(std::vector{horizontal(8, 8, 9, 9, 0), horizontal(0, 0, 0.5, 0.5, 0)}) == 1);
  CHECK(map.erase(map.shapes().back().id));
  CHECK(bridge.id == left);
  CHECK_FALSE(map.contains(right));
  REQUIRE(map.size() == 2);
  const auto& s = map.shape(left);
  CHECK(s.delta == 4);
  CHECK(s.surface.area() == Approx(1 + 1 + 0.5));
  CHECK(map.vertex_count() == s.surface.polygon.outer.size() + 4);
  CHECK(s.surface.polygon.outer.size() >= 12);
  CHECK(map.bytes() == (3 * map.vertex_count() + 4 * 2) * 4);
  CHECK(map.memory_bytes() > map.vertex_count() * sizeof(Point2d));
}

TEMPLATE_TEST_CASE("GeometricMap editing: select by id, ray and point; erase; move",
                   "[mapping][geometric_map]", RANGENAV_MAPS) {
  TestType map;
  const auto floor = map.insert(horizontal(0, 0, 5, 4, 0)).id;
  auto table_polygon = horizontal(2, 1.6, 3.2, 2.4, 0.75);
  table_polygon.polygon.holes.push_back({});  // a 0.2 m square hole around (2.6, 2.0)
  for (const Point3d& w : {Point3d(2.5, 1.9, 0.75), Point3d(2.5, 2.1, 0.75),
                           Point3d(2.7, 2.1, 0.75), Point3d(2.7, 1.9, 0.75)})
    table_polygon.polygon.holes.back().push_back(table_polygon.frame.to_plane(w));
  const auto table = map.insert(table_polygon).id;
  const auto wall = map.insert(planar(Plane3<>::from_coefficients(1, 0, 0, 0),
                                      {{0, 0, 0}, {0, 4, 0}, {0, 4, 2.5}, {0, 0, 2.5}}))
                        .id;
  REQUIRE(map.size() == 3);
  CHECK(map.shape(table).surface.area() == Approx(1.2 * 0.8 - 0.04));

  SECTION("by ray: the first polygon hit") {
    const Point3d down(0, 0, -1);
    CHECK(map.select_by_ray({2.3, 2.0, 2}, down) == table);
    CHECK(map.select_by_ray({2.6, 2.0, 2}, down) == floor);              // through the hole
    CHECK(map.select_by_ray({4.0, 2.0, 2}, down) == floor);              // beside the table
    CHECK(map.select_by_ray({2.3, 2.0, 2}, down, 1.0) == std::nullopt);  // too short
    CHECK(map.select_by_ray({2.3, 2.0, 2}, -down) == std::nullopt);
    CHECK(map.select_by_ray({4.0, 2.0, 1}, {-1, 0, 0.1}) == wall);
    CHECK(map.select_by_ray({6.0, 2.0, 0.5}, {1, 0, 0}) == std::nullopt);
    CHECK_THROWS_WITH(map.select_by_ray({0, 0, 1}, Point3d::Zero()),
                      "rangenav: GeometricMap::select_by_ray: argument '|direction|' = 0 must be "
                      "finite and > 0");
  }
  SECTION("by point: the nearest polygon") {
    CHECK(map.select_nearest({2.3, 2.0, 0.8}) == table);
    CHECK(map.select_nearest({2.6, 2.0, 0.8}) == table);  // 0.1 m from the hole's edge
    CHECK(map.select_nearest({4.5, 2.0, 0.3}) == floor);
    CHECK(map.select_nearest({0.2, 2.0, 1.5}) == wall);
    CHECK(map.select_nearest({-0.5, 5.0, 1.5}) == wall);  // outside every polygon
    CHECK(map.select_nearest({4.5, 2.0, 3.0}, 1.0) == std::nullopt);
  }
  SECTION("erase") {
    CHECK(map.erase(table));
    CHECK_FALSE(map.erase(table));
    CHECK(map.size() == 2);
    CHECK(map.select_by_ray({2.3, 2.0, 2}, {0, 0, -1}) == floor);
    CHECK_THROWS_WITH(map.shape(table), "rangenav: GeometricMap::shape: argument 'id' = " +
                                            std::to_string(table) + " names no shape");
  }
  SECTION("move: the plane and frame follow a rigid motion, the polygon keeps its shape") {
    Transform3d lift = Transform3d::Identity();
    lift.translation() = Point3d(1, 0, 0.1);
    lift.rotate(Eigen::AngleAxisd(std::numbers::pi / 2, Point3d::UnitZ()));
    const Point3d centroid = map.shape(table).centroid;  // the table top's, with its hole
    CHECK(centroid.z() == Approx(0.75));
    CHECK((centroid.x() > 2.0 && centroid.x() < 3.2 && centroid.y() > 1.6 && centroid.y() < 2.4));
    map.move(table, lift);
    const auto& s = map.shape(table);
    CHECK(s.centroid.isApprox(lift * centroid, 1e-12));
    CHECK(s.surface.plane.normal.isApprox(Point3d::UnitZ()));
    CHECK(s.surface.plane.d == Approx(-0.85));
    CHECK(s.surface.area() == Approx(1.2 * 0.8 - 0.04));
    const auto moved = s.surface.outer_world();
    const auto original = table_polygon.outer_world();
    REQUIRE(moved.size() == original.size());
    for (std::size_t i = 0; i < moved.size(); ++i)
      CHECK(moved[i].isApprox(lift * original[i], 1e-12));
    // Turned by 90 deg and shifted by 1 m, the table spans x in [-1.4, -0.6], y in [2, 3.2].
    CHECK(map.select_by_ray({-1.0, 2.2, 2}, {0, 0, -1}) == table);
    CHECK(map.select_by_ray({2.3, 2.0, 2}, {0, 0, -1}) == floor);
    CHECK_THROWS_WITH(map.move(99, lift),
                      "rangenav: GeometricMap::move: argument 'id' = 99 names no shape");
  }
}

TEMPLATE_TEST_CASE("GeometricMap rejects bad input", "[mapping][geometric_map]", RANGENAV_MAPS) {
  using Map = TestType;
  CHECK_THROWS_WITH(Map({0.0, 0.1}), "rangenav: GeometricMap: argument 't1' = 0 must be in (0, 1]");
  CHECK_THROWS_WITH(Map({0.95, -1.0}),
                    "rangenav: GeometricMap: argument 't2' = -1 must be finite and > 0");
  Map map;
  auto p = horizontal(0, 0, 1, 1, 0);
  p.polygon.outer.resize(2);
  CHECK_THROWS_WITH(map.insert(p),
                    "rangenav: GeometricMap::insert: argument "
                    "'polygon.polygon.outer vertices' = 2 must be >= 3");
  auto q = horizontal(0, 0, 1, 1, 0);
  q.plane.d = std::nan("");
  CHECK_THROWS_WITH(map.insert(q),
                    "rangenav: GeometricMap::insert: argument 'polygon.plane' is "
                    "not a finite plane with a normal");
  CHECK(map.empty());
  // A clockwise outer ring is accepted and stored counter-clockwise.
  auto cw = horizontal(0, 0, 1, 1, 0);
  std::reverse(cw.polygon.outer.begin(), cw.polygon.outer.end());
  const auto id = map.insert(cw).id;
  CHECK(map.shape(id).surface.polygon.area() == Approx(1));
}
