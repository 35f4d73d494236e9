// The polygon clipper's bad-input table (issue 21): polygons that are not simple. A bowtie gave
// intersects = false and a wrong union area, a zero-area ring made the union lose the other
// polygon, a hole outside its ring was accepted: each is an invalid_argument with Boost.Geometry's
// reason now.
#include <catch2/catch.hpp>
#include <string>
#include <vector>

#include "bad_input.hpp"
#include "rangenav/geometry/polygon_clipper.hpp"

using namespace rangenav;
using Catch::Matchers::Contains;
using rangenav::test::error_of;
using Ring = std::vector<Point2d>;

TEST_CASE("BoostGeometryClipper: invalid polygons are invalid_arguments with the reason",
          "[geometry][bad]") {
  const BoostGeometryClipper clipper;
  const Polygon2<> square{{{0, 0}, {2, 0}, {2, 2}, {0, 2}}, {}};
  struct Row {
    const char* what;
    Polygon2<> polygon;
    const char* reason;
  };
  const std::vector<Row> rows{
      {"a bowtie",
       {{{0, 0}, {2, 2}, {2, 0}, {0, 2}}, {}},
       "a ring crosses itself (its orientation is undefined)"},
      {"a lopsided bowtie",
       {{{0, 0}, {3, 3}, {3, 0}, {0, 1}}, {}},
       "a ring crosses itself or another ring"},
      {"a hole outside its ring",
       {{{0, 0}, {1, 0}, {1, 1}, {0, 1}}, {{{5, 5}, {6, 5}, {6, 6}, {5, 6}}}},
       "a hole lies outside its outer ring"},
      {"a hole crossing its ring",
       {{{0, 0}, {4, 0}, {4, 4}, {0, 4}}, {{{3, 1}, {5, 1}, {5, 2}, {3, 2}}}},
       "a ring crosses itself or another ring"},
  };
  for (const Row& row : rows) {
    INFO(row.what);
    CHECK_THAT(error_of<invalid_argument>([&] { (void)clipper.intersects(row.polygon, square); }),
               Contains("BoostGeometryClipper::intersects: argument 'a' is not a valid polygon") &&
                   Contains(row.reason));
    CHECK_THAT(error_of<invalid_argument>([&] { (void)clipper.union_of(square, row.polygon); }),
               Contains("BoostGeometryClipper::union_of: argument 'b' is not a valid polygon") &&
                   Contains(row.reason));
  }
  // A polygon without area is the empty set: it lost the other polygon of a union before.
  for (const Polygon2<>& flat : {Polygon2<>{{{0, 0}, {1, 1}, {2, 2}}, {}},
                                 Polygon2<>{{{0.5, 1}, {1, 1}, {1.5, 1}, {1.9, 1}}, {}},
                                 Polygon2<>{{{1, 1}, {1, 1}, {1, 1}}, {}}}) {
    CHECK_FALSE(clipper.intersects(flat, square));
    CHECK_FALSE(clipper.intersects(square, flat));
    for (const auto& u : {clipper.union_of(flat, square), clipper.union_of(square, flat)}) {
      REQUIRE(u.size() == 1);
      CHECK(u[0].area() == Approx(4.0));
    }
    CHECK(clipper.union_of(flat, flat).empty());
  }
  // A hole without area removes nothing.
  const Polygon2<> slit{{{0, 0}, {2, 0}, {2, 2}, {0, 2}}, {{{0.5, 0.5}, {1, 1}, {1.5, 1.5}}}};
  CHECK(clipper.union_of(slit, square)[0].area() == Approx(4.0));
  // A spike (a needle of no width) is removed, not an error: the union is the square's.
  const Polygon2<> spiked{{{0, 0}, {2, 0}, {2, 1}, {3, 1}, {2, 1}, {2, 2}, {0, 2}}, {}};
  const auto unite = clipper.union_of(spiked, Polygon2<>{{{1, 1}, {1.5, 1}, {1.5, 1.5}}, {}});
  REQUIRE(unite.size() == 1);
  CHECK(unite[0].area() == Approx(4.0));
  CHECK(clipper.intersects(spiked, square));
#ifdef NDEBUG
  // A ring that touches itself at a vertex (two lobes) is accepted: the overlay follows the touch.
  // Only without assertions: Boost 1.74's is_valid asserts on a self-touching outer ring
  // (is_valid/polygon.hpp, are_holes_inside) although it then judges such a ring correctly.
  const Polygon2<> lobes{{{0, 0}, {2, 0}, {1, 1}, {2, 2}, {0, 2}, {1, 1}}, {}};
  CHECK(clipper.intersects(lobes, square));
  const auto merged = clipper.union_of(lobes, Polygon2<>{{{0, 0}, {2, 0}, {2, 2}}, {}});
  double total = 0;
  for (const auto& piece : merged)
    total += piece.area();
  CHECK(total == Approx(3.0));
#endif
  // Either orientation and repeated vertices are accepted (and answered right).
  const Polygon2<> clockwise{{{1, 1}, {1, 3}, {3, 3}, {3, 1}}, {}};
  CHECK(clipper.intersects(square, clockwise));
  const Polygon2<> repeated{{{1, 1}, {3, 1}, {3, 1}, {3, 3}, {1, 3}}, {}};
  const auto pieces = clipper.union_of(square, repeated);
  REQUIRE(pieces.size() == 1);
  CHECK(pieces[0].area() == Approx(7.0));
}
