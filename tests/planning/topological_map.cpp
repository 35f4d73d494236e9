// The topological layer of paper 000 §4: named objects with pose and shape, queried by name.

#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>

#include "rangenav/planning/topological_map.hpp"

using Catch::Matchers::Equals;
using rangenav::Point2d;
using rangenav::TopologicalMap;

TEST_CASE("topological map: add, query by name, footprint, approach pose") {
  TopologicalMap map;
  CHECK(map.empty());
  map.add({"refrigerator",
           {4.0, 2.0, std::numbers::pi / 2},
           {{-0.3, -0.3}, {0.3, -0.3}, {0.3, 0.3}, {-0.3, 0.3}}});
  map.add({"kitchen", {5.0, 1.0, 3 * std::numbers::pi}, {}});
  CHECK(map.size() == 2);
  const auto& fridge = map.at("refrigerator");
  const auto fp = fridge.footprint();
  REQUIRE(fp.size() == 4);
  // Rotated by +90 degrees: (0.3, -0.3) -> (0.3, 0.3) relative to the centre.
  CHECK(fp[1].x() == Approx(4.3));
  CHECK(fp[1].y() == Approx(2.3));
  const auto approach = fridge.approach_pose(0.5);
  CHECK(approach.x == Approx(4.0).margin(1e-12));
  CHECK(approach.y == Approx(2.5));
  CHECK(approach.theta == Approx(-std::numbers::pi / 2));           // facing the object
  CHECK(map.at("kitchen").pose.theta == Approx(std::numbers::pi));  // normalised
  CHECK(map.find("sofa") == nullptr);
  CHECK(map.nearest(Point2d(4.9, 1.1))->name == "kitchen");
  CHECK(map.remove("kitchen"));
  CHECK(!map.remove("kitchen"));
  CHECK(map.nearest(Point2d(4.9, 1.1))->name == "refrigerator");
  CHECK(TopologicalMap{}.nearest(Point2d(0, 0)) == nullptr);
}

TEST_CASE("topological map: contracts") {
  TopologicalMap map;
  map.add({"door", {0, 0, 0}, {}});
  CHECK_THROWS_WITH(
      map.add({"door", {1, 0, 0}, {}}),
      Equals("rangenav: TopologicalMap::add: argument 'object.name' = door is already in the map"));
  CHECK_THROWS_WITH(map.add({"", {1, 0, 0}, {}}),
                    Equals("rangenav: TopologicalMap::add: argument 'object.name' is empty"));
  CHECK_THROWS_WITH(
      map.add({"x", {std::nan(""), 0, 0}, {}}),
      Equals("rangenav: TopologicalMap::add: argument 'object.pose.x' = nan must be finite"));
  CHECK_THROWS_WITH(
      map.add({"x", {0, 0, 0}, {{0, INFINITY}}}),
      Equals("rangenav: TopologicalMap::add: argument 'object.shape[0]' = 0 inf must be finite"));
  CHECK_THROWS_WITH(
      map.at("sofa"),
      Equals("rangenav: TopologicalMap::at: argument 'name' = sofa is not in the map"));
  CHECK(map.size() == 1);
}
