// The readers' bad-input table (issue 21): crafted headers whose counts overflow or promise more
// than the file holds, values beyond the reader's scalar type, non-finite poses and timestamps,
// and inputs beyond ReaderLimits. Each gives an io_error naming the file, the line or point and
// the field, and nothing is allocated for what the file does not hold (the sanitizer build runs
// these with ASan, which would report a multi-gigabyte allocation or an out-of-bounds read).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "bad_input.hpp"
#include "rangenav/io/carmen.hpp"
#include "rangenav/io/mrpt_pose.hpp"
#include "rangenav/io/pcd.hpp"
#include "rangenav/io/pgm.hpp"
#include "rangenav/io/ply.hpp"
#include "rangenav/io/slam_relations.hpp"
#include "rangenav/io/trajectory.hpp"
#include "scratch_dir.hpp"

using namespace rangenav;
using namespace rangenav::io;
using Catch::Matchers::Contains;
using rangenav::test::error_of;

namespace {

struct TempDir : rangenav::test::ScratchDir {
  TempDir() : ScratchDir("bad_input") {}
};

std::string pcd_header(const std::string& fields, const std::string& size, const std::string& type,
                       const std::string& count, const std::string& size_lines,
                       const std::string& data) {
  return "VERSION 0.7\nFIELDS " + fields + "\nSIZE " + size + "\nTYPE " + type + "\nCOUNT " +
         count + "\n" + size_lines + "DATA " + data + "\n";
}

std::string read_pcd_error(const std::filesystem::path& path, const ReaderLimits& limits = {}) {
  return error_of<io_error>([&] { (void)read_pcd<double>(path, limits); });
}

}  // namespace

TEST_CASE("PCD: counts and sizes that overflow or exceed the data are io_errors", "[io][bad]") {
  TempDir dir;
  struct Row {
    const char* what;
    std::string content;
    const char* expected;  // part of the message after "rangenav: pcd: <path>: "
  };
  const std::string sixteen(16, '\0');
  const std::vector<Row> rows{
      // SIZE x COUNT wraps the point size: the truncation check passed and the decoder read far
      // out of bounds before.
      {"SIZE*COUNT overflow",
       pcd_header("a x y z b", "8 4 4 4 8", "F F F F F",
                  "1152921504606846976 1 1 1 2305843009213693953", "WIDTH 1\nHEIGHT 1\n",
                  "binary") +
           sixteen,
       "line 8: field 'b': SIZE*COUNT = 8*2305843009213693953 overflows the point size"},
      {"POINTS beyond the data (binary)",
       pcd_header("x y z", "4 4 4", "F F F", "1 1 1", "WIDTH 100000000000\nPOINTS 100000000000\n",
                  "binary"),
       "binary data has 0 bytes but 100000000000 points of 12 bytes need 1200000000000"},
      {"POINTS beyond the limits",
       pcd_header("x y z", "4 4 4", "F F F", "1 1 1", "WIDTH 100000000000\nPOINTS 100000000000\n",
                  "ascii") +
           "1 2 3\n",
       "line 8: point count = 100000000000 exceeds ReaderLimits::max_points = 268435456"},
      {"POINTS beyond the data (ascii): the cloud grows with the lines read",
       pcd_header("x y z", "4 4 4", "F F F", "1 1 1", "WIDTH 100000000\nPOINTS 100000000\n",
                  "ascii") +
           "1 2 3\n",
       "line 9: data ends after 1 of 100000000 points"},
      {"a huge COUNT",
       pcd_header("x y z w", "4 4 4 4", "F F F F", "1 1 1 100000000000", "WIDTH 1\n", "binary") +
           sixteen,
       "binary data has 16 bytes but 1 points of 400000000012 bytes need 400000000012"},
      {"WIDTH*HEIGHT overflow",
       pcd_header("x y z", "4 4 4", "F F F", "1 1 1", "WIDTH 4294967296\nHEIGHT 4294967296\n",
                  "binary"),
       "line 8: WIDTH*HEIGHT = 4294967296*4294967296 overflows"},
      {"POINTS*point size overflow",
       pcd_header("x y z", "8 8 8", "F F F", "1 1 1",
                  "WIDTH 1000000000000000000\nPOINTS 1000000000000000000\n", "binary"),
       "line 8: POINTS*point size = 1000000000000000000*24 overflows"},
      {"an ascii line of a huge COUNT",
       pcd_header("x y z w", "4 4 4 4", "F F F F", "1 1 1 1000000000000000000", "WIDTH 0\n",
                  "ascii") +
           "1 2 3\n",
       "more data lines than the 0 POINTS"},
      {"a non-finite VIEWPOINT",
       pcd_header("x y z", "4 4 4", "F F F", "1 1 1", "WIDTH 1\nVIEWPOINT 0 0 nan 1 0 0 0\n",
                  "ascii") +
           "1 2 3\n",
       "line 7: VIEWPOINT value 'nan' is not a finite number"},
      {"a float64 value beyond float (read as float)", "", ""},  // below, with Scalar = float
      {"an infinite coordinate",
       pcd_header("x y z", "4 4 4", "F F F", "1 1 1", "WIDTH 2\n", "ascii") + "1 2 3\n4 inf 6\n",
       "point 1: y = inf is not finite"},
  };
  for (const Row& row : rows) {
    if (row.content.empty()) continue;
    INFO(row.what);
    const auto path = dir.write("bad.pcd", row.content);
    CHECK_THAT(read_pcd_error(path), Contains(path.string()) && Contains(row.expected));
  }
  // binary_compressed: an unpacked size no LZF stream of that length can reach.
  {
    std::string text =
        pcd_header("x y z", "4 4 4", "F F F", "1 1 1", "WIDTH 100000000\n", "binary_compressed");
    const std::uint32_t compressed = 4, unpacked = 1200000000;
    text.append(reinterpret_cast<const char*>(&compressed), 4);
    text.append(reinterpret_cast<const char*>(&unpacked), 4);
    text.append("\x1f\x00\x00\x00", 4);
    const auto path = dir.write("lzf.pcd", text);
    CHECK_THAT(read_pcd_error(path), Contains("4 LZF bytes cannot unpack to 1200000000"));
  }
  // A float64 field beyond float's range, read into a float cloud.
  {
    const auto path =
        dir.write("wide.pcd", pcd_header("x y z", "8 8 8", "F F F", "1 1 1", "WIDTH 1\n", "ascii") +
                                  "1 1e300 3\n");
    CHECK_THAT(error_of<io_error>([&] { (void)read_pcd<float>(path); }),
               Contains("point 0: y = inf is not finite"));
    CHECK(read_pcd<double>(path).points[0].y() == 1e300);
  }
}

TEST_CASE("PCD: ReaderLimits bound what a read allocates", "[io][bad]") {
  TempDir dir;
  Cloud<3, double> cloud;
  cloud.points.assign(10, Point3d(1, 2, 3));
  cloud.width = 10;
  const auto path = dir.path() / "ten.pcd";
  write_pcd(path, cloud);
  CHECK(read_pcd<double>(path).size() == 10);
  CHECK_THAT(read_pcd_error(path, {.max_points = 9}),
             Contains("point count = 10 exceeds ReaderLimits::max_points = 9"));
  CHECK_THAT(read_pcd_error(path, {.max_bytes = 100}),
             Contains("file size = ") && Contains("exceeds ReaderLimits::max_bytes = 100"));
  // 100 points of 3 bytes in the file, of 24 bytes in a Cloud<3, double>.
  const auto bytes = dir.write(
      "bytes.pcd", pcd_header("x y z", "1 1 1", "U U U", "1 1 1", "WIDTH 100\n", "binary") +
                       std::string(300, '\x07'));
  CHECK(read_pcd<double>(bytes).points[99] == Point3d(7, 7, 7));
  CHECK_THAT(read_pcd_error(bytes, {.max_bytes = 1000}),
             Contains("a cloud of 100 points of 24 bytes exceeds ReaderLimits::max_bytes = 1000"));
  CHECK_THAT(error_of<io_error>([&] { (void)read_pcd_header(path, {.max_line_bytes = 16}); }),
             Contains(path.string() + ": line 1: header line length"));
  CHECK_THAT(error_of<invalid_argument>([&] { (void)read_pcd<double>(path, {.max_points = 0}); }),
             Contains("argument 'limits.max_points' = 0 must be > 0"));
  // NaN points are data (a missing point of an organised cloud), not an error.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  cloud.points[3] = Point3d(nan, nan, nan);
  cloud.width = 5;
  cloud.height = 2;
  write_pcd(path, cloud, PcdFormat::binary_compressed);
  const auto back = read_pcd<double>(path);
  CHECK(back.height == 2);
  CHECK(std::isnan(back.points[3].x()));
}

TEST_CASE("PLY: counts beyond the data, negative list lengths and limits are io_errors",
          "[io][bad]") {
  TempDir dir;
  const std::string head = "ply\nformat ascii 1.0\n";
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  struct Row {
    const char* what;
    std::string content;
    const char* expected;
  };
  const std::vector<Row> rows{
      {"element vertex beyond the limits",
       head + "element vertex 100000000000\n" + xyz + "end_header\n1 2 3\n",
       "line 3: point count = 100000000000 exceeds ReaderLimits::max_points = 268435456"},
      {"element vertex beyond the data: the cloud grows with the lines read",
       head + "element vertex 100000000\n" + xyz + "end_header\n1 2 3\n",
       "line 8: data ends after 1 of 100000000 'vertex' elements"},
      {"binary vertices beyond the data",
       "ply\nformat binary_little_endian 1.0\nelement vertex 100000000\n" + xyz + "end_header\n" +
           std::string(24, '\0'),
       "binary data ends inside element 'vertex' 2 of 100000000 (truncated file?)"},
      {"a list longer than its line",
       head + "element vertex 1\nproperty list uchar float w\n" + xyz + "end_header\n200 1 2 3\n",
       "line 9: vertex 0: list 'w' has 200 items but the line holds 3 more values"},
      {"a negative list length (text)",
       head + "element vertex 1\nproperty list char float w\n" + xyz + "end_header\n-1 1 2 3\n",
       "line 9: vertex 0: list length of 'w' is missing or not a valid count"},
      {"a negative list length (binary)",
       "ply\nformat binary_little_endian 1.0\nelement vertex 1\n" + xyz +
           "element face 1\nproperty list char int idx\nend_header\n" + std::string(12, '\0') +
           "\xff",
       "element 'face' 0: list 'idx' has a negative length -1"},
      {"an infinite coordinate", head + "element vertex 1\n" + xyz + "end_header\n1 -inf 3\n",
       "point 0: y = -inf is not finite"},
  };
  for (const Row& row : rows) {
    INFO(row.what);
    const auto path = dir.write("bad.ply", row.content);
    CHECK_THAT(error_of<io_error>([&] { (void)read_ply<double>(path); }),
               Contains(path.string()) && Contains(row.expected));
  }
  // An organised-size comment whose product overflows does not organise the cloud.
  const auto path = dir.write(
      "wrap.ply", head + "comment rangenav organized width 4294967296 height 4294967296\n" +
                      "element vertex 0\n" + xyz + "end_header\n");
  const auto cloud = read_ply<double>(path);
  CHECK(cloud.height == 1);
  CHECK(cloud.width == 0);
  CHECK_THAT(error_of<io_error>([&] {
               (void)read_ply<double>(dir.write("two.ply", head + "element vertex 2\n" + xyz +
                                                               "end_header\n1 2 3\n4 5 6\n"),
                                      {.max_points = 1});
             }),
             Contains("point count = 2 exceeds ReaderLimits::max_points = 1"));
}

TEST_CASE("PGM: image sizes beyond the limits or the data, pixels beyond maxval", "[io][bad]") {
  const auto pgm_error = [](const std::string& text, const ReaderLimits& limits = {}) {
    std::istringstream in(text);
    return error_of<io_error>([&] { (void)read_pgm(in, "map.pgm", limits); });
  };
  CHECK(pgm_error("P5 999999999 999999999 255\n") ==
        "rangenav: read_pgm: map.pgm: image size 999999999x999999999: pixel count = "
        "999999998000000001 exceeds ReaderLimits::max_points = 268435456");
  // Valid-looking and within the limits, but the data is missing: the pixels read so far are all
  // that was allocated.
  CHECK(pgm_error("P2 10000 10000 255\n1 2 3\n") ==
        "rangenav: read_pgm: map.pgm: truncated pixel data: pixel 3 of 100000000 is missing");
  CHECK(pgm_error("P5 10000 10000 255\n" + std::string(10, 'x')) ==
        "rangenav: read_pgm: map.pgm: truncated pixel data: 10 of 100000000 bytes");
  CHECK_THAT(pgm_error("P5 4 4 255\n" + std::string(16, 'x'), {.max_points = 15}),
             Contains("pixel count = 16 exceeds ReaderLimits::max_points = 15"));
  CHECK_THAT(pgm_error("P5 4 4 65535\n" + std::string(32, 'x'), {.max_bytes = 31}),
             Contains("bytes = 32 exceeds ReaderLimits::max_bytes = 31"));
  // 70000 does not fit 16 bits: it was stored as 0 before, and passed the maxval check.
  CHECK(pgm_error("P2 2 1 65535\n5 70000\n") ==
        "rangenav: read_pgm: map.pgm: pixel 1 = 70000 exceeds maxval 65535");
  CHECK(pgm_error("P2 1234567890 1 255\n") ==
        "rangenav: read_pgm: map.pgm: header field 'width' is missing or not a number");
  CHECK(pgm_error("P5 0 3 255\n") == "rangenav: read_pgm: map.pgm: image size 0x3 is empty");

  GrayImage image;
  image.width = 2;
  image.height = 1;
  image.pixels = {0, 255};
  CHECK_THAT(error_of<invalid_argument>([&] { (void)image.at(2, 0); }),
             Contains("argument 'column' = 2 must be < width = 2"));
  CHECK_THAT(error_of<invalid_argument>([&] { (void)image.at(0, 1); }),
             Contains("argument 'row' = 1 must be < height = 1"));
  CHECK_THAT(error_of<invalid_argument>([&] { (void)occupied_cells(image, 1e308); }),
             Contains("resolution = 1e+308 is too large"));
  image.width = std::size_t{1} << 32;
  image.height = std::size_t{1} << 32;  // width * height wraps to 0
  image.pixels.clear();
  CHECK_THAT(error_of<invalid_argument>([&] { (void)occupied_cells(image, 0.05); }),
             Contains("image.pixels.size()"));
}

TEST_CASE("CARMEN: crafted counts and non-finite poses or timestamps are io_errors",
          "[io][carmen][bad]") {
  TempDir dir;
  const std::string tail = " 0 0 0 0 0 0 10 h 1\n";
  struct Row {
    const char* what;
    std::string line;
    const char* expected;  // after "rangenav: carmen: <path>:"
  };
  const std::vector<Row> rows{
      // n + 9 wrapped: std::length_error escaped before.
      {"a beam count near 2^64", "FLASER 18446744073709551607 1 2" + tail,
       "1: FLASER: expected 18446744073709551607 ranges, found 2"},
      {"a beam count near 2^64, too few fields", "FLASER 18446744073709551607 1 2\n",
       "1: FLASER: too few fields: expected 18446744073709551607 + 9 after the beam count, "
       "found 2"},
      {"a remission count near 2^64",
       "RAWLASER1 0 -1.5 3 0.75 30 0.01 0 2 1 2 18446744073709551615 5 6 1 h 1\n",
       "1: RAWLASER1: expected 18446744073709551615 remissions, found 2"},
      {"a range count near 2^64",
       "RAWLASER1 0 -1.5 3 0.75 30 0.01 0 18446744073709551615 1 2 0 1 h 1\n",
       "1: RAWLASER1: expected 18446744073709551615 ranges, found 2"},
      {"a NaN pose", "FLASER 2 1 2 nan 0 0 0 0 0 10 h 1\n",
       "1: FLASER: field 5 is not a finite number: 'nan'"},
      {"an infinite odometry pose", "FLASER 2 1 2 0 0 0 0 inf 0 10 h 1\n",
       "1: FLASER: field 9 is not a finite number: 'inf'"},
      {"a NaN ODOM pose", "ODOM 1 nan 0 0 0 0 1 h 1\n",
       "1: ODOM: field 3 is not a finite number: 'nan'"},
      {"a NaN velocity", "ODOM 1 1 0 nan 0 0 1 h 1\n",
       "1: ODOM: field 5 is not a finite number: 'nan'"},
      {"a NaN timestamp", "FLASER 2 1 2 0 0 0 0 0 0 nan h 1\n",
       "1: FLASER: field 11 is not a finite number: 'nan'"},
      {"an infinite ROBOTLASER1 robot pose",
       "ROBOTLASER1 0 -1.5 3 0.5 20 0.01 0 2 1 2 0 1 2 3 -inf 5 6 7 8 9 10 11 1 h 1\n",
       "1: ROBOTLASER1: field 16 is not a finite number: '-inf'"},
      {"an infinite RAWLASER configuration", "RAWLASER1 0 -inf 3 0.75 30 0.01 0 1 1 0 1 h 1\n",
       "1: RAWLASER1: field 3 is not a finite number: '-inf'"},
  };
  for (const Row& row : rows) {
    INFO(row.what);
    const auto path = dir.write("bad.clf", row.line);
    CHECK(error_of<io_error>([&] { (void)read_carmen_lasers(path); }) ==
          "rangenav: carmen: " + path.string() + ":" + row.expected);
  }
  // Ranges are data: NaN, inf and negative readings are invalid beams, not errors.
  const auto ok = read_carmen_lasers(dir.write("ok.clf", "FLASER 3 nan -inf -2" + tail));
  REQUIRE(ok.size() == 1);
  CHECK(ok[0].scan.valid_count() == 0);
}

TEST_CASE("CARMEN: lines and record counts beyond ReaderLimits", "[io][carmen][bad]") {
  TempDir dir;
  const std::string line = "FLASER 3 1 2 3 0 0 0 0 0 0 10 h 1\n";
  const auto path = dir.write("two.clf", "# a comment\n" + line + line);
  CHECK(read_carmen_lasers(path).size() == 2);
  CarmenReaderOptions options;
  options.limits.max_points = 1;
  CHECK(error_of<io_error>([&] { (void)read_carmen_lasers(path, options); }) ==
        "rangenav: carmen: " + path.string() +
            ":3: laser record count = 2 exceeds ReaderLimits::max_points = 1");
  options = {};
  options.limits.max_line_bytes = 20;
  CHECK(error_of<io_error>([&] { (void)read_carmen_lasers(path, options); }) ==
        "rangenav: carmen: " + path.string() +
            ":2: line longer than ReaderLimits::max_line_bytes = 20 bytes");
  // A line without any newline, longer than the limit, is stopped while it is read.
  const auto endless = dir.write("endless.clf", std::string(100000, '1'));
  options.limits.max_line_bytes = 1000;
  CHECK(error_of<io_error>([&] { (void)read_carmen_lasers(endless, options); }) ==
        "rangenav: carmen: " + endless.string() +
            ":1: line longer than ReaderLimits::max_line_bytes = 1000 bytes");
  options = {};
  options.saturation_evidence = 0;
  CHECK_THAT(error_of<invalid_argument>([&] { (void)read_carmen_lasers(path, options); }),
             Contains("argument 'options.saturation_evidence' = 0 must be >= 1"));
}

TEST_CASE("trajectories and relations: non-finite values and limits are io_errors", "[io][bad]") {
  TempDir dir;
  CHECK_THAT(
      error_of<io_error>([&] { (void)read_xytheta(dir.write("nan.txt", "0 1 2 3\n1 nan 2 3\n")); }),
      Contains("nan.txt:2: field 2 is not a finite number: 'nan'"));
  CHECK_THAT(error_of<io_error>([&] {
               (void)read_tum(dir.write("inf.tum", "0 1 2 3 0 0 0 1\n1 1 2 3 inf 0 0 1\n"));
             }),
             Contains("inf.tum:2: field 5 is not a finite number: 'inf'"));
  CHECK_THAT(
      error_of<io_error>([&] { (void)read_tum(dir.write("big.tum", "0 1 2 3 1e300 0 0 1\n")); }),
      Contains("big.tum:1: quaternion norm inf is not 1"));
  const auto three = dir.write("three.txt", "0 0 0 0\n1 0 0 0\n2 0 0 0\n");
  CHECK_THAT(error_of<io_error>([&] { (void)read_xytheta(three, {.max_points = 2}); }),
             Contains("three.txt:3: record count = 3 exceeds ReaderLimits::max_points = 2"));
  CHECK_THAT(error_of<io_error>([&] { (void)read_xytheta(three, {.max_line_bytes = 4}); }),
             Contains("three.txt:1: line longer than ReaderLimits::max_line_bytes = 4 bytes"));
  {  // the stream readers stop a long line too
    std::istringstream in(std::string(1000, '7'));
    CHECK_THAT(error_of<io_error>([&] { (void)read_tum(in, "s.tum", {.max_line_bytes = 100}); }),
               Contains("s.tum:1: line longer than ReaderLimits::max_line_bytes = 100 bytes"));
  }
  CHECK_THAT(error_of<io_error>([&] {
               (void)read_slam_relations(
                   dir.write("r.rel", "1 2 0 0 0 0 0 0\n1 2 0 0 0 0 0 -inf\n"), {.max_points = 1});
             }),
             Contains("r.rel:2: relation count = 2 exceeds ReaderLimits::max_points = 1"));
  CHECK_THAT(error_of<io_error>(
                 [&] { (void)read_slam_relations(dir.write("r.rel", "1 2 0 0 0 0 0 -inf\n")); }),
             Contains("r.rel:1: field 8 is not a finite number: '-inf'"));

  const std::vector<SlamRelation> relations{{1.0, 2.0, {0.5, 0, 0}}};
  const std::vector<double> stamps{1.0, 2.0};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Pose2d> bad_poses{{0, 0, 0}, {nan, 0, 0}};
  CHECK_THAT(error_of<invalid_argument>(
                 [&] { (void)evaluate_slam_relations(relations, stamps, bad_poses); }),
             Contains("argument 'poses[i]' = 1 is not finite"));
  const std::vector<Pose2d> poses{{0, 0, 0}, {0.5, 0, 0}};
  CHECK_THAT(error_of<invalid_argument>(
                 [&] { (void)evaluate_slam_relations(relations, stamps, poses, nan); }),
             Contains("argument 'local_gap' = nan must be finite and >= 0"));
  CHECK(evaluate_slam_relations(relations, stamps, poses).all.translation_mean == 0.0);
}

TEST_CASE("MRPT pose: files too large to be a pose are not read", "[io][bad]") {
  TempDir dir;
  const auto path = dir.write("big.mat", std::string((std::size_t{1} << 20) + 1, '\0'));
  CHECK_THAT(error_of<io_error>([&] { (void)read_mrpt_pose(path); }),
             Contains("file size = 1048577 exceeds ReaderLimits::max_bytes = 1048576"));
  std::string bytes(64, '\0');
  const float inf = std::numeric_limits<float>::infinity();
  std::memcpy(bytes.data() + 48, &inf, 4);
  CHECK_THAT(error_of<io_error>([&] { (void)read_mrpt_pose(dir.write("inf.mat", bytes)); }),
             Contains("non-finite matrix element"));
}
