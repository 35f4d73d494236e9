#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <random>
#include <sstream>
#include <string>

#include "rangenav/sim/world.hpp"
#include "rangenav/sim/world_file.hpp"

using namespace rangenav;
using namespace rangenav::sim;

namespace {
const double pi = std::numbers::pi;
const double sqrt2 = std::numbers::sqrt2;
Point2d dir2(double a) {
  return {std::cos(a), std::sin(a)};
}

std::string error_of(const std::string& text) {
  std::istringstream in(text);
  try {
    (void)read_world(in, "test.world");
  } catch (const io_error& e) {
    return e.what();
  }
  return "no error";
}
}  // namespace

TEST_CASE("a beam hits a wall at the distance computed by hand", "[sim][world]") {
  World w;
  w.add_wall({3, -5}, {3, 5}, 2.0);
  w.build_index();
  const RayHit h = w.cast_ray_2d({0, 0}, {1, 0}, 0.3, 30);
  CHECK(h.kind == SurfaceKind::wall);
  CHECK(h.index == 0);
  CHECK(h.range == Approx(3.0));
  // 30 degrees off the normal: 3 / cos(30).
  CHECK(w.cast_ray_2d({0, 0}, dir2(pi / 6), 0.3, 30).range == Approx(3.0 / std::cos(pi / 6)));
  // Beyond max range, behind the origin, and above the wall: nothing.
  CHECK_FALSE(w.cast_ray_2d({0, 0}, {1, 0}, 0.3, 2.5).hit());
  CHECK(w.cast_ray_2d({0, 0}, {1, 0}, 0.3, 2.5).range == std::numeric_limits<double>::infinity());
  CHECK_FALSE(w.cast_ray_2d({0, 0}, {-1, 0}, 0.3, 30).hit());
  CHECK_FALSE(w.cast_ray_2d({0, 0}, {1, 0}, 2.1, 30).hit());
  // The same in 3D: a beam rising at 15 degrees from 1 m height meets the wall at
  // z = 1 + 3 tan(15) = 1.80 < 2; rising at 40 degrees it passes above (z = 3.52) and sees
  // nothing.
  const double a15 = pi / 12;
  const RayHit up = w.cast_ray({0, 0, 1}, {std::cos(a15), 0, std::sin(a15)}, 30);
  CHECK(up.kind == SurfaceKind::wall);
  CHECK(up.range == Approx(3.0 / std::cos(a15)));
  const double a40 = 40 * pi / 180;
  CHECK_FALSE(w.cast_ray({0, 0, 1}, {std::cos(a40), 0, std::sin(a40)}, 30).hit());
}

TEST_CASE("a table top above the scan plane is missed in 2D and seen from above", "[sim][world]") {
  World w;
  // Table 1 m x 0.6 m centred at (2, 0), top from 0.40 to 0.43 m, four thin legs.
  w.add_box({{2, 0}, {1.0, 0.6}, 0, 0.40, 0.43});
  for (double sx : {-1.0, 1.0})
    for (double sy : {-1.0, 1.0})
      w.add_cylinder({{2 + sx * 0.45, sy * 0.25}, 0.015, 0, 0.40});
  w.build_index();
  // A 2D scanner at 0.3 m passes between the legs (beam along y = 0).
  CHECK_FALSE(w.cast_ray_2d({0, 0}, {1, 0}, 0.30, 10).hit());
  // At 0.41 m it hits the top's edge at x = 1.5.
  const RayHit top = w.cast_ray_2d({0, 0}, {1, 0}, 0.41, 10);
  CHECK(top.kind == SurfaceKind::box);
  CHECK(top.range == Approx(1.5));
  // A leg at (1.55, 0.25): a beam through its centre meets it at its radius.
  const Point2d to_leg = Point2d(1.55, 0.25).normalized();
  const RayHit leg = w.cast_ray_2d({0, 0}, to_leg, 0.2, 10);
  CHECK(leg.kind == SurfaceKind::cylinder);
  CHECK(leg.range == Approx(Point2d(1.55, 0.25).norm() - 0.015));
  // A ray straight down from 1 m above the table meets the top at z = 0.43.
  const RayHit down = w.cast_ray({2, 0, 1}, {0, 0, -1}, 10);
  CHECK(down.kind == SurfaceKind::box);
  CHECK(down.range == Approx(1 - 0.43));
  // Next to the table it reaches the floor.
  const RayHit floor = w.cast_ray({3, 0, 1}, {0, 0, -1}, 10);
  CHECK(floor.kind == SurfaceKind::floor);
  CHECK(floor.range == Approx(1.0));
}

TEST_CASE("the floor, holes and stairs below it, and the ceiling", "[sim][world]") {
  World w;
  // Ray from (0, 0, 2) going down at 45 degrees: reaches z = 0 at x = 2.
  const Point3d o(0, 0, 2), d = Point3d(1, 0, -1).normalized();
  CHECK(w.cast_ray(o, d, 10).kind == SurfaceKind::floor);
  CHECK(w.cast_ray(o, d, 10).range == Approx(2 * sqrt2));
  // A pit x in [1.5, 2.5] of depth 0.3: the ray enters at x = 2 and meets its bottom at x = 2.3.
  World pit;
  pit.add_hole({{2, 0}, {1, 2}, 0, 0.3});
  RayHit h = pit.cast_ray(o, d, 10);
  CHECK(h.kind == SurfaceKind::hole);
  CHECK(h.range == Approx(2.3 * sqrt2));
  CHECK(pit.floor_height({2, 0}) == Approx(-0.3));
  CHECK(pit.floor_height({3, 0}) == 0);
  // Depth 1: it meets the far side at x = 2.5, z = -0.5.
  World deep;
  deep.add_hole({{2, 0}, {1, 2}, 0, 1.0});
  h = deep.cast_ray(o, d, 10);
  CHECK(h.kind == SurfaceKind::hole);
  CHECK(h.range == Approx(2.5 * sqrt2));
  // A descending stair: steps 0.3 m deep (x) going down 0.2 m each, starting at x = 1.9.
  World stair;
  for (int k = 0; k < 4; ++k)
    stair.add_hole({{1.9 + 0.15 + 0.3 * k, 0}, {0.3, 1}, 0, 0.2 * (k + 1)});
  // Step k (k = 1..4) spans x in [1.9 + 0.3 (k-1), 1.9 + 0.3 k] with its tread at z = -0.2 k.
  // A ray from (1, 0, 2) with slope -2 crosses z = 0 at x = 2 (over step 1) and lands on step 1's
  // tread (z = -0.2) at x = 2.1.
  const Point3d steep = Point3d(1, 0, -2).normalized();
  const Point3d o2(1.0, 0, 2);
  h = stair.cast_ray(o2, steep, 10);
  CHECK(h.kind == SurfaceKind::hole);
  CHECK(h.index == 0);
  CHECK(h.range == Approx(Point3d(1.1, 0, -2.2).norm()));
  // A shallow ray (slope -1/4) from (1.5, 0, 0.25) crosses z = 0 at x = 2.5 over step 3
  // (x in [2.5, 2.8], tread -0.6), passes into step 4 at z = -0.075, and meets the stair's far
  // end x = 3.1 at z = -0.15, above step 4's tread (-0.8): it hits the pit's side there.
  const Point3d shallow = Point3d(4, 0, -1).normalized();
  h = stair.cast_ray({1.5, 0, 0.25}, shallow, 10);
  CHECK(h.kind == SurfaceKind::hole);
  CHECK(h.index == 3);
  CHECK(h.range == Approx(Point3d(1.6, 0, -0.4).norm()));
  // Looking back up the stair from inside step 4 at z = -0.7 towards -x: the riser of step 3
  // (floor -0.6) at x = 2.8.
  h = stair.cast_ray({3.0, 0, -0.7}, {-1, 0, 0}, 10);
  CHECK(h.kind == SurfaceKind::hole);
  CHECK(h.index == 3);
  CHECK(h.range == Approx(0.2));
  // A ceiling at 2.5 m.
  World room;
  room.set_ceiling_height(2.5);
  h = room.cast_ray({0, 0, 1}, {0, 0, 1}, 10);
  CHECK(h.kind == SurfaceKind::ceiling);
  CHECK(h.range == Approx(1.5));
  CHECK_FALSE(room.cast_ray({0, 0, 1}, {1, 0, 0}, 10).hit());
}

TEST_CASE("doors turn about their hinge", "[sim][world]") {
  World w;
  w.add_wall({3, -5}, {3, 5});
  // Closed door across the beam: leaf from (2, -0.5) towards +y, 1 m long, 4 cm thick.
  const std::size_t d = w.add_door({{2, -0.5}, pi / 2, 1.0, 0.0, 0.04, 2.0});
  w.build_index();
  RayHit h = w.cast_ray_2d({0, 0}, {1, 0}, 0.5, 10);
  CHECK(h.kind == SurfaceKind::door);
  CHECK(h.range == Approx(2 - 0.02));
  // Opened by 90 degrees counter-clockwise the leaf points to -x along y = -0.5: the beam passes.
  w.set_door_opening(d, pi / 2);
  h = w.cast_ray_2d({0, 0}, {1, 0}, 0.5, 10);
  CHECK(h.kind == SurfaceKind::wall);
  CHECK(h.range == Approx(3.0));
  // ...and a beam along y = -0.4 grazes the open leaf's side at y = -0.5 + 0.02.
  h = w.cast_ray_2d({1.5, 0}, {0, -1}, 0.5, 10);
  CHECK(h.kind == SurfaceKind::door);
  CHECK(h.range == Approx(0.5 - 0.02));
  // Above the door's height the beam passes.
  w.set_door_opening(d, 0);
  CHECK(w.cast_ray_2d({0, 0}, {1, 0}, 2.1, 10).kind == SurfaceKind::wall);
  CHECK(w.doors()[d].leaf().center.isApprox(Point2d(2, 0)));
  CHECK_THROWS_WITH(w.set_door_opening(5, 0.0),
                    "rangenav: World::set_door_opening: argument 'i' = 5 must be < door count 1");
}

TEST_CASE("the grid gives the same hits as testing every primitive", "[sim][world]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(-10, 10), ang(-pi, pi), len(0.2, 3), h(0.1, 2.5);
  World w;
  for (int i = 0; i < 100; ++i) {
    const Point2d a(pos(rng), pos(rng));
    w.add_wall(a, a + len(rng) * dir2(ang(rng)), h(rng));
  }
  for (int i = 0; i < 30; ++i) {
    const double z0 = h(rng) / 2;
    w.add_box({{pos(rng), pos(rng)}, {len(rng) / 2, len(rng) / 2}, ang(rng), z0, z0 + 0.3});
    w.add_cylinder({{pos(rng), pos(rng)}, len(rng) / 10, 0, h(rng)});
  }
  for (int i = 0; i < 5; ++i)
    w.add_door({{pos(rng), pos(rng)}, ang(rng), 0.9, ang(rng) / 2});
  w.add_hole({{0, 0}, {2, 3}, 0.3, 0.5});
  w.set_ceiling_height(2.4);
  w.build_index();
  REQUIRE(w.has_index());
  int hits = 0;
  for (int i = 0; i < 3000; ++i) {
    const Point2d o(pos(rng) * 1.3, pos(rng) * 1.3);  // some rays start outside the grid
    const Point2d dd = dir2(ang(rng));
    const double z = h(rng);
    const RayHit a = w.cast_ray_2d(o, dd, z, 15), b = w.cast_ray_2d_exhaustive(o, dd, z, 15);
    REQUIRE(a.kind == b.kind);
    REQUIRE(a.index == b.index);
    if (a.hit()) REQUIRE(a.range == Approx(b.range));
    hits += a.hit();
    const Point3d o3(o.x(), o.y(), z);
    const Point3d d3 = Point3d(dd.x(), dd.y(), ang(rng) / 3).normalized();
    const RayHit c = w.cast_ray(o3, d3, 15), e = w.cast_ray_exhaustive(o3, d3, 15);
    REQUIRE(c.kind == e.kind);
    REQUIRE(c.index == e.index);
    if (c.hit()) REQUIRE(c.range == Approx(e.range));
  }
  CHECK(hits > 1000);
  // Vertical rays too.
  for (int i = 0; i < 200; ++i) {
    const Point3d o3(pos(rng), pos(rng), 2.0);
    const RayHit c = w.cast_ray(o3, {0, 0, -1}, 15), e = w.cast_ray_exhaustive(o3, {0, 0, -1}, 15);
    REQUIRE(c.kind == e.kind);
    REQUIRE(c.range == Approx(e.range));
  }
}

TEST_CASE("bad primitives are refused with the argument and value", "[sim][world]") {
  World w;
  CHECK_THROWS_WITH(w.add_box({{0, 0}, {-1, 1}, 0, 0, 1}),
                    "rangenav: World::add_box: argument 'size.x' = -1 must be finite and > 0");
  CHECK_THROWS_WITH(w.add_cylinder({{0, 0}, 0.1, 1, 0.5}),
                    "rangenav: World::add_cylinder: argument 'z_max' = 0.5 must exceed z_min = 1");
  CHECK_THROWS_WITH(w.add_wall({0, 0}, {0, 0}),
                    "rangenav: World::add_wall: wall end points a and b coincide");
  CHECK_THROWS_AS(w.add_wall({0, std::nan("")}, {1, 0}), invalid_argument);
  CHECK_THROWS_WITH(w.add_hole({{0, 0}, {1, 1}, 0, 0}),
                    "rangenav: World::add_hole: argument 'depth' = 0 must be finite and > 0");
  const std::vector<Point2d> two{{0, 0}, {1, 0}};
  CHECK_THROWS_WITH(w.add_polygon(two),
                    "rangenav: World::add_polygon: argument 'vertices.size()' = 2 must be >= 3");
  CHECK(w.primitive_count() == 0);
  // An empty world still has a floor.
  w.build_index();
  CHECK(w.cast_ray({0, 0, 1}, {0, 0, -1}, 5).range == Approx(1.0));
  CHECK_FALSE(w.cast_ray_2d({0, 0}, {1, 0}, 0.3, 5).hit());
}

TEST_CASE("world files round-trip and bad lines name their line", "[sim][world]") {
  const std::string text =
      "# a test world\n"
      "ceiling 2.6\n"
      "\n"
      "wall 0 0 4 0   # the south wall, default height\n"
      "polygon 2.0 5 5 6 5 6 6\n"
      "box 2 1 1.2 0.6 0.3 0.4 0.43\n"
      "cylinder 1 1 0.02 0 0.4\n"
      "door 3 0 1.5707963267948966 0.9 0.5\n"
      "door 4 0 0 0.8 0 0.05 1.9\n"
      "hole 3 3 1 1 0 0.18\n";
  std::istringstream in(text);
  const World a = read_world(in, "a.world");
  REQUIRE(a.walls().size() == 4);
  CHECK(a.walls()[0].height == 2.5);
  CHECK(a.walls()[3].a == Point2d(6, 6));
  CHECK(a.walls()[3].b == Point2d(5, 5));
  CHECK(a.boxes().size() == 1);
  CHECK(a.boxes()[0].yaw == 0.3);
  CHECK(a.doors().size() == 2);
  CHECK(a.doors()[0].thickness == 0.04);
  CHECK(a.doors()[1].height == 1.9);
  CHECK(a.holes()[0].depth == 0.18);
  CHECK(a.ceiling_height() == 2.6);
  CHECK(a.has_index());
  std::ostringstream out;
  write_world(out, a);
  std::istringstream back(out.str());
  const World b = read_world(back);
  REQUIRE(b.walls().size() == a.walls().size());
  for (std::size_t i = 0; i < a.walls().size(); ++i) {
    CHECK(b.walls()[i].a == a.walls()[i].a);
    CHECK(b.walls()[i].b == a.walls()[i].b);
    CHECK(b.walls()[i].height == a.walls()[i].height);
  }
  CHECK(b.boxes()[0].center == a.boxes()[0].center);
  CHECK(b.boxes()[0].size == a.boxes()[0].size);
  CHECK(b.boxes()[0].z_max == a.boxes()[0].z_max);
  CHECK(b.cylinders()[0].radius == a.cylinders()[0].radius);
  CHECK(b.doors()[0].closed_yaw == a.doors()[0].closed_yaw);
  CHECK(b.doors()[0].opening == a.doors()[0].opening);
  CHECK(b.holes()[0].size == a.holes()[0].size);
  CHECK(b.ceiling_height() == a.ceiling_height());
  std::ostringstream again;
  write_world(again, b);
  CHECK(again.str() == out.str());

  CHECK(error_of("wall 0 0 1 1\nwal 0 0 1 1\n") ==
        "rangenav: test.world:2: unknown primitive 'wal'");
  CHECK(error_of("\n# x\nwall 0 0 1\n") ==
        "rangenav: test.world:3: 'wall' needs 4 or 5 numbers, got 3");
  CHECK(error_of("box 1 2 3 4 5 6 7 8\n") ==
        "rangenav: test.world:1: 'box' needs 7 numbers, got 8");
  CHECK(error_of("door 0 0 0 1 0 0.1\n") ==
        "rangenav: test.world:1: 'door' thickness needs a height after it");
  CHECK(error_of("cylinder 1 1 abc 0 1\n") == "rangenav: test.world:1: bad number 'abc'");
  CHECK(error_of("cylinder 1 1 0.1x 0 1\n") == "rangenav: test.world:1: bad number '0.1x'");
  CHECK(error_of("polygon 2 0 0 1 1\n") ==
        "rangenav: test.world:1: 'polygon' needs a height and at least 3 x y pairs, got 5 numbers");
  CHECK(error_of("cylinder 1 1 -0.1 0 1\n") ==
        "rangenav: test.world:1: rangenav: World::add_cylinder: argument 'radius' = "
        "-0.10000000000000001 must be finite and > 0");
  CHECK_THROWS_WITH(load_world("/nonexistent/x.world"),
                    "rangenav: cannot open world file '/nonexistent/x.world'");
}
