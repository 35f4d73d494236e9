// PGM reading and occupied-cell extraction: hand-made images with known content, the EVG-THIN maps
// with the pixel counts stated in PROVENANCE.md, and malformed files with exact messages.

#include <catch2/catch.hpp>
#include <sstream>
#include <string>

#include "rangenav/io/pgm.hpp"
#include "test_support.hpp"

using Catch::Matchers::Equals;
using rangenav::io::read_pgm;

namespace {
rangenav::io::GrayImage parse(const std::string& text) {
  std::istringstream in(text);
  return read_pgm(in, "mem.pgm");
}
}  // namespace

TEST_CASE("pgm: binary and plain images with comments") {
  const std::string binary = std::string("P5\n# a comment\n3 2\n# another\n255\n") +
                             std::string("\x00\x7f\xff\xff\x00\x10", 6);
  const auto a = parse(binary);
  CHECK(a.width == 3);
  CHECK(a.height == 2);
  CHECK(a.max_value == 255);
  CHECK(a.at(0, 0) == 0);
  CHECK(a.at(1, 0) == 127);
  CHECK(a.at(2, 0) == 255);
  CHECK(a.at(1, 1) == 0);
  CHECK(a.at(2, 1) == 16);

  const auto b = parse("P2 3 2 15\n0 7 15\n15 0 1\n");
  CHECK(b.max_value == 15);
  CHECK(b.pixels == std::vector<std::uint16_t>{0, 7, 15, 15, 0, 1});

  // 16-bit pixels are big-endian.
  const auto c = parse(std::string("P5 2 1 1000\n") + std::string("\x03\xe8\x00\x01", 4));
  CHECK(c.pixels == std::vector<std::uint16_t>{1000, 1});
}

TEST_CASE("pgm: occupied cells become cell centres, y up") {
  const auto image = parse("P2 3 2 255\n0 255 255\n255 255 0\n");
  const auto pts = rangenav::io::occupied_cells(image, 0.5, rangenav::Point2d(1.0, 2.0));
  REQUIRE(pts.size() == 2);
  // Row 0 is the top row: y = 2 + (2 - 1 - 0 + 0.5) * 0.5.
  CHECK(pts[0].x() == Approx(1.25));
  CHECK(pts[0].y() == Approx(2.75));
  CHECK(pts[1].x() == Approx(2.25));
  CHECK(pts[1].y() == Approx(2.25));
  // 127 of 255 is "unknown" (occupancy 0.5), not occupied.
  CHECK(rangenav::io::occupied_cells(parse("P2 1 1 255 127"), 1.0).empty());
  CHECK_THROWS_WITH(
      rangenav::io::occupied_cells(image, 0.0),
      Equals("rangenav: occupied_cells: argument 'resolution' = 0 must be finite and > 0"));
}

TEST_CASE("pgm: the EVG-THIN maps") {
  const auto path = rangenav::test::data_file_or_skip("evg-thin/test1.pgm");
  if (path.empty()) return;
  const auto image = read_pgm(path);
  CHECK(image.width == 420);
  CHECK(image.height == 300);
  std::size_t occupied = 0, unknown = 0, free = 0;
  for (auto v : image.pixels)
    (v == 0 ? occupied : v == 127 ? unknown : free)++;
  CHECK(occupied == 6532);
  CHECK(unknown == 70956);
  CHECK(free == 48512);
  CHECK(rangenav::io::occupied_cells(image, 0.05).size() == 6532);
}

TEST_CASE("pgm: malformed input") {
  CHECK_THROWS_WITH(
      parse("P6 1 1 255\n\x01"),
      Equals("rangenav: read_pgm: mem.pgm: not a PGM file (magic number must be P5 or P2)"));
  CHECK_THROWS_WITH(parse(""), Equals("rangenav: read_pgm: mem.pgm: not a PGM file (magic number "
                                      "must be P5 or P2)"));
  CHECK_THROWS_WITH(
      parse("P5 3 x 255\n"),
      Equals("rangenav: read_pgm: mem.pgm: header field 'height' is missing or not a number"));
  CHECK_THROWS_WITH(parse("P5 0 2 255\n"),
                    Equals("rangenav: read_pgm: mem.pgm: image size 0x2 is empty"));
  CHECK_THROWS_WITH(parse("P5 1 1 70000\n"),
                    Equals("rangenav: read_pgm: mem.pgm: maxval 70000 is not in 1..65535"));
  CHECK_THROWS_WITH(parse("P5 2 2 255\nab"),
                    Equals("rangenav: read_pgm: mem.pgm: truncated pixel data: 2 of 4 bytes"));
  CHECK_THROWS_WITH(
      parse("P2 2 2 255\n1 2 3"),
      Equals("rangenav: read_pgm: mem.pgm: truncated pixel data: pixel 3 of 4 is missing"));
  CHECK_THROWS_WITH(parse("P2 1 2 10\n1 11"),
                    Equals("rangenav: read_pgm: mem.pgm: pixel 1 = 11 exceeds maxval 10"));
  CHECK_THROWS_WITH(read_pgm(std::filesystem::path("/nonexistent/map.pgm")),
                    Equals("rangenav: read_pgm: cannot open /nonexistent/map.pgm"));
}
