#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <string>

#include "rangenav/sim/worlds.hpp"

using namespace rangenav;
using namespace rangenav::sim;

TEST_CASE("apartment: the couch table is above the 2D scan plane, legs thin", "[sim][worlds]") {
  const Scene s = apartment();
  const SceneObject& table = s.object("couch_table");
  CHECK(table.type == "table");
  CHECK(table.max.z() == Approx(0.44));
  CHECK(table.min.z() == Approx(0.0));
  CHECK(table.parts.size() == 5);
  CHECK(table.max.z() - 0.04 > apartment_scan_height);
  // A beam at the scanner's height from (3, 3.4) towards -y passes between the legs and under the
  // top, and hits the couch's front at y = 0.95.
  const RayHit low = s.world.cast_ray_2d({3, 3.4}, {0, -1}, apartment_scan_height, 10);
  REQUIRE(low.hit());
  CHECK(s.object_of({low.kind, low.index})->name == "couch");
  CHECK(low.range == Approx(3.4 - 0.95));
  // At the top's height it hits the table's edge at y = 2.1.
  const RayHit high = s.world.cast_ray_2d({3, 3.4}, {0, -1}, 0.42, 10);
  REQUIRE(high.hit());
  CHECK(s.object_of({high.kind, high.index})->name == "couch_table");
  CHECK(high.range == Approx(3.4 - 2.1));
}

TEST_CASE("apartment: drawer overhang, small objects and the stair", "[sim][worlds]") {
  const Scene s = apartment();
  // The drawer sticks out 30 cm in front of the dresser above the scan plane.
  const SceneObject& drawer = s.object("drawer");
  const SceneObject& dresser = s.object("dresser");
  CHECK(dresser.min.x() - drawer.min.x() == Approx(0.3));
  CHECK(drawer.min.z() > apartment_scan_height);
  const RayHit at_scan = s.world.cast_ray_2d({8.5, 3.5}, {1, 0}, apartment_scan_height, 10);
  CHECK(s.object_of({at_scan.kind, at_scan.index})->name == "dresser");
  CHECK(at_scan.range == Approx(1.0));
  const RayHit at_drawer = s.world.cast_ray_2d({8.5, 3.5}, {1, 0}, 0.6, 10);
  CHECK(s.object_of({at_drawer.kind, at_drawer.index})->name == "drawer");
  CHECK(at_drawer.range == Approx(0.7));
  // Every small object is 3-10 cm high and below the scan plane.
  int small = 0;
  for (const auto& o : s.objects)
    if (o.type == "small_object") {
      ++small;
      CHECK(o.max.z() >= 0.03);
      CHECK(o.max.z() <= 0.10);
      CHECK(o.min.z() == 0.0);
    }
  CHECK(small >= 4);
  // Looking straight down over the third step of the stair: its tread is 3 x 0.18 m below.
  const SceneObject& stair = s.object("stair");
  CHECK(stair.min.z() == Approx(-6 * 0.18));
  const RayHit down = s.world.cast_ray({8.8, 7.2 + 2.5 * 0.28, 1.0}, {0, 0, -1}, 5);
  CHECK(down.kind == SurfaceKind::hole);
  CHECK(s.object_of({down.kind, down.index})->name == "stair");
  CHECK(down.range == Approx(1.0 + 3 * 0.18));
  // A 2D scanner in front of the stair looks over it and sees the stairwell's far wall.
  const RayHit over = s.world.cast_ray_2d({8.8, 6.7}, {0, 1}, apartment_scan_height, 10);
  CHECK(over.kind == SurfaceKind::wall);
  CHECK(over.range == Approx(10 - 6.7));
  // Doors exist with their states.
  CHECK(s.world.doors().size() == 3);
  CHECK(s.object("door_bathroom").parts[0].kind == SurfaceKind::door);
  CHECK_THROWS_WITH(s.object("sofa"),
                    "rangenav: Scene::object: argument 'name' = sofa names no object");
}

TEST_CASE("office corridor: door states decide what a beam sees", "[sim][worlds]") {
  std::vector<double> open(office_corridor_door_count, 0.0);
  open[1] = std::numbers::pi / 2;  // door_s1 at x = 7.5, open into the office
  const Scene s = office_corridor(open);
  CHECK(s.world.doors().size() == 8);
  // Through door_s1's opening the beam reaches the office's far wall at y = -4.
  const RayHit through = s.world.cast_ray_2d({7.5, 1.0}, {0, -1}, 1.0, 20);
  CHECK(through.kind == SurfaceKind::wall);
  CHECK(through.range == Approx(5.0));
  // door_s2 (x = 12.5) is closed: the leaf, 2 cm thick on each side of y = 0.
  const RayHit closed = s.world.cast_ray_2d({12.5, 1.0}, {0, -1}, 1.0, 20);
  CHECK(closed.kind == SurfaceKind::door);
  CHECK(s.object_of({closed.kind, closed.index})->name == "door_s2");
  CHECK(closed.range == Approx(1.0 - 0.02));
  // North doors open into +y.
  open.assign(office_corridor_door_count, 0.0);
  open[6] = 1.0;
  const Scene n = office_corridor(open);
  const Door& d = n.world.doors()[6];
  CHECK(d.leaf().center.y() > 2.0);
  // Negative openings swing into the corridor: door_s1 at -30 deg, hinged at (7.05, 0), stops a
  // beam along y = 0.2 where its leaf crosses it, 0.2 / tan(30 deg) past the hinge (the leaf's
  // face 2 cm nearer, measured along the beam 0.02 / sin(30 deg)).
  open.assign(office_corridor_door_count, 0.0);
  open[1] = -std::numbers::pi / 6;
  const Scene c = office_corridor(open);
  const RayHit leaf = c.world.cast_ray_2d({5.5, 0.2}, {1, 0}, 1.0, 20);
  CHECK(leaf.kind == SurfaceKind::door);
  CHECK(leaf.range == Approx(7.05 + 0.2 / std::tan(std::numbers::pi / 6) - 0.02 / 0.5 - 5.5));
  // Doors moved off the even spacing: door_n1 centred at x = 6.9, the wall continues where the
  // default door was (x = 7.5).
  const std::vector<double> centers = {1.4, 6.1, 13.6, 17.9, 3.3, 6.9, 11.2, 16.4};
  const Scene irregular = office_corridor({}, false, centers);
  CHECK(irregular.world.doors()[5].hinge.x() == Approx(6.9 - 0.45));
  const RayHit door_n1 = irregular.world.cast_ray_2d({6.9, 1.0}, {0, 1}, 1.0, 20);
  CHECK(door_n1.kind == SurfaceKind::door);
  CHECK(irregular.object_of({door_n1.kind, door_n1.index})->name == "door_n1");
  const RayHit old_n1 = irregular.world.cast_ray_2d({7.5, 1.0}, {0, 1}, 1.0, 20);
  CHECK(old_n1.kind == SurfaceKind::wall);
  CHECK(old_n1.range == Approx(1.0));
  std::vector<double> into_partition = centers;
  into_partition[1] = 5.25;  // door_s1 would cut the partition at x = 5
  CHECK_THROWS_WITH(office_corridor({}, false, into_partition),
                    "rangenav: office_corridor: argument 'door_centers[1]' = 5.25 must be in "
                    "[5.5, 9.5] (its office)");
  std::vector<double> into_alcove = centers;
  into_alcove[5] = 9.0;
  CHECK_THROWS_WITH(office_corridor({}, true, into_alcove),
                    "rangenav: office_corridor: argument 'door_centers[5]' = 9 must be in [5.5, "
                    "9.5] (its office) and clear of the alcove");
  CHECK_THROWS_WITH(office_corridor(std::vector<double>(8, -4.0)),
                    "rangenav: office_corridor: argument 'door_openings[i]' = -4 must be in "
                    "[-pi, pi]");
  CHECK_THROWS_WITH(
      office_corridor({1.0}),
      "rangenav: office_corridor: argument 'door_openings.size()' = 1 must be 0 or 8");
  // The copier alcove: the north wall is 0.5 m farther back at x in [8.4, 9.6] only, so the half
  // turn about (10, 1) no longer maps the corridor onto itself.
  const Scene a = office_corridor({}, true);
  const RayHit in_alcove = a.world.cast_ray_2d({9.0, 1.0}, {0, 1}, 1.0, 20);
  CHECK(a.object_of({in_alcove.kind, in_alcove.index})->name == "copier_alcove");
  CHECK(in_alcove.range == Approx(1.5));
  CHECK(a.world.cast_ray_2d({11.0, 1.0}, {0, -1}, 1.0, 20).range == Approx(1.0));  // its image
  CHECK(s.world.cast_ray_2d({9.0, 1.0}, {0, 1}, 1.0, 20).range == Approx(1.0));
}

TEST_CASE("kitchen: rays hit the true planes", "[sim][worlds]") {
  const Scene s = kitchen();
  REQUIRE(s.planes.size() == 5);
  const Point3d eye(4.2, 2.0, 1.4);
  for (const auto& plane : s.planes) {
    // Aim at the centre of each plane's outline; where the ray is not blocked it must end on it.
    Point3d target = Point3d::Zero();
    for (const auto& v : plane.outline)
      target += v;
    target /= static_cast<double>(plane.outline.size());
    INFO(plane.name);
    for (const auto& v : plane.outline)
      CHECK(plane.signed_distance(v) == Approx(0.0).margin(1e-12));
    if (plane.name == "wall" || plane.name == "floor" || plane.name == "table_top") continue;
    const Point3d dir = (target - eye).normalized();
    const RayHit h = s.world.cast_ray(eye, dir, 10);
    REQUIRE(h.hit());
    CHECK(plane.signed_distance(eye + h.range * dir) == Approx(0.0).margin(1e-9));
  }
  // The table top, seen from above next to the objects on it.
  const RayHit t = s.world.cast_ray({2.2, 2.2, 1.5}, {0, 0, -1}, 5);
  CHECK(s.object_of({t.kind, t.index})->name == "table");
  CHECK(t.range == Approx(1.5 - 0.75));
  // The floor beside the table.
  CHECK(s.world.cast_ray({4.0, 0.5, 1.5}, {0, 0, -1}, 5).kind == SurfaceKind::floor);
}

TEST_CASE("long_corridor: walls 1 m either side, boxes against alternate walls", "[sim][worlds]") {
  const Scene s = long_corridor();
  CHECK(s.objects.size() == 9);
  // From the start the walls are 1 m away, and the corridor runs to its end wall at x = 80.
  const RayHit left = s.world.cast_ray_2d({0, 0}, {0, 1}, 0.3, 10);
  REQUIRE(left.hit());
  CHECK(left.range == Approx(1.0));
  // Along y = 0.85 the first box in the way is box_1 (x = 7.9, north wall): face at 7.75.
  const RayHit along = s.world.cast_ray_2d({0, 0.85}, {1, 0}, 0.3, 100);
  REQUIRE(along.hit());
  CHECK(s.object_of({along.kind, along.index})->name == "box_1");
  CHECK(along.range == Approx(7.75));
  CHECK(s.object("box_0").max.y() == Approx(-0.7));
  // Bare, the same beam reaches the end wall.
  const Scene bare = long_corridor(false);
  CHECK(bare.objects.empty());
  const RayHit end = bare.world.cast_ray_2d({0, 0.85}, {1, 0}, 0.3, 100);
  REQUIRE(end.hit());
  CHECK(end.range == Approx(80.0));
  CHECK(bare.tour.back().x() == Approx(75.0));
}
