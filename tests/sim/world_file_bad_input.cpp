// World files' bad-input table (issue 21): numbers whose extent overflows (each finite, the
// difference not), non-finite numbers, lines, primitive counts and sparse worlds whose ray-casting
// index would take hundreds of megabytes.
#include <catch2/catch.hpp>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "bad_input.hpp"
#include "rangenav/sim/world_file.hpp"

using namespace rangenav;
using namespace rangenav::sim;
using Catch::Matchers::Contains;
using rangenav::test::error_of;

namespace {
std::string world_error(const std::string& text, const WorldFileLimits& limits = {}) {
  std::istringstream in(text);
  return error_of<io_error>([&] { (void)read_world(in, "w.world", limits); });
}
}  // namespace

TEST_CASE("world files: numbers beyond max_coordinate and non-finite ones are io_errors",
          "[sim][bad]") {
  // -1e308 to 1e308: an infinite extent, a NaN converted to an index and a crash before.
  CHECK(world_error("# big\nwall -1e308 -1e308 1e308 1e308\n") ==
        "rangenav: w.world:2: number 1 = '-1e308' is not finite or exceeds "
        "WorldFileLimits::max_coordinate = 1000000");
  CHECK_THAT(world_error("wall 0 0 1 nan\n"),
             Contains("w.world:1: number 4 = 'nan' is not finite"));
  CHECK_THAT(world_error("box 0 0 inf 1 0 0 1\n"), Contains("number 3 = 'inf'"));
  CHECK_THAT(world_error("polygon 1 0 0 1 0 1 1e7\n"), Contains("number 7 = '1e7'"));
  CHECK_THAT(error_of<invalid_argument>([] {
               std::istringstream in("wall 0 0 1 1\n");
               (void)read_world(in, "w.world", {.max_coordinate = -1});
             }),
             Contains("read_world: argument 'limits.max_coordinate' = -1"));
  CHECK_THAT(world_error("wall 0 0 1 1 2.5 extra\n"), Contains("bad number 'extra'"));
  CHECK_THAT(world_error("wall 0 0 0 0\n"), Contains("w.world:1: rangenav: World::add_wall"));
}

TEST_CASE("world files: lines and primitive counts beyond the limits", "[sim][bad]") {
  CHECK(world_error(std::string(200, ' ') + "wall 0 0 1 1\n", {.max_line_bytes = 100}) ==
        "rangenav: w.world:1: line longer than WorldFileLimits::max_line_bytes = 100 bytes");
  CHECK(world_error("wall 0 0 1 1\nwall 1 1 2 2\nwall 2 2 3 3\n", {.max_primitives = 2}) ==
        "rangenav: w.world:3: more than WorldFileLimits::max_primitives = 2 primitives");
  CHECK_THAT(world_error("polygon 1 0 0 1 0 1 1 0 1\n", {.max_primitives = 3}),
             Contains("more than WorldFileLimits::max_primitives = 3"));
}

TEST_CASE("world files: a sparse world's index stays within max_index_cells", "[sim][bad]") {
  // Two tiny polygons 1000 km apart took 0.4-0.7 s and 100-190 MB of index before.
  std::istringstream in(
      "polygon 1 0 0 0.1 0 0.1 0.1\npolygon 1 999999 999999 1e6 999999 1e6 1e6\n");
  const World w = read_world(in, "sparse.world");
  const auto [lo, hi] = w.bounds();
  const double area = (hi.x() - lo.x()) * (hi.y() - lo.y());
  CHECK(area / (w.cell_size() * w.cell_size()) <= 65536.0 * 1.01);
  // The casts are the same with any index: the one wall a ray from the first polygon meets.
  const auto hit = w.cast_ray_2d({0.02, 0.01}, {1, 0}, 0.5, 10.0);
  const auto ref = w.cast_ray_2d_exhaustive({0.02, 0.01}, {1, 0}, 0.5, 10.0);
  CHECK(hit.hit());
  CHECK(hit.range == ref.range);
  // A building-sized world keeps World's own cell size (at most 2 m).
  std::istringstream small("polygon 2.5 0 0 40 0 40 30 0 30\nwall 10 0 10 20\n");
  CHECK(read_world(small).cell_size() <= 2.0);
}
