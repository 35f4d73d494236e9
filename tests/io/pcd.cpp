// Tests of include/rangenav/io/pcd.hpp and io/detail/lzf.hpp: LZF against hand-built streams,
// round trips in every DATA format, hand-written files with fields of every SIZE / TYPE / COUNT,
// exact error messages, and PCL's own test clouds (ground truth counted by PCL 1.13's reader).

#include "rangenav/io/pcd.hpp"

#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "cloud_checks.hpp"
#include "scratch_dir.hpp"
#include "test_support.hpp"

using rangenav::Cloud3d;
using rangenav::Cloud3f;
using rangenav::io::PcdFormat;
using rangenav::io::StoredScalar;
using namespace rangenav::test;
namespace rd = rangenav::io::detail;

namespace {

std::vector<std::uint8_t> lzf_round_trip(const std::vector<std::uint8_t>& in) {
  std::vector<std::uint8_t> packed;
  rd::lzf_compress(in.data(), in.size(), packed);
  CHECK(packed.size() <= in.size() + in.size() / 32 + 1);
  std::vector<std::uint8_t> out(in.size());
  CHECK(rd::lzf_decompress(packed.data(), packed.size(), out.data(), out.size()) == in.size());
  return out;
}

std::string pcd_error(const std::filesystem::path& path) {
  try {
    (void)rangenav::io::read_pcd(path);
  } catch (const rangenav::io_error& e) {
    return e.what();
  }
  return "no error";
}

const std::string header_xyz =
    "# .PCD v0.7 - Point Cloud Data file format\n"
    "VERSION 0.7\n"
    "FIELDS x y z\n"
    "SIZE 4 4 4\n"
    "TYPE F F F\n"
    "COUNT 1 1 1\n"
    "WIDTH 2\n"
    "HEIGHT 1\n"
    "VIEWPOINT 0 0 0 1 0 0 0\n"
    "POINTS 2\n";

}  // namespace

TEST_CASE("lzf decodes hand-built literal runs and back references") {
  // "abc" as a literal run (control 2), then a reference of length 3 + 2 = 5 (control 3 << 5)
  // three bytes back (offset byte 2): the copy overlaps its own output, giving "abcabcab".
  const std::vector<std::uint8_t> stream{2, 'a', 'b', 'c', 3 << 5, 2};
  std::vector<std::uint8_t> out(8);
  REQUIRE(rd::lzf_decompress(stream.data(), stream.size(), out.data(), out.size()) == 8);
  CHECK(std::string(out.begin(), out.end()) == "abcabcab");

  // A long reference: length field 7 plus extension byte 10 copies 7 + 10 + 2 = 19 bytes of the
  // single byte before it.
  const std::vector<std::uint8_t> run{0, 'z', 7 << 5, 10, 0};
  std::vector<std::uint8_t> zs(20);
  REQUIRE(rd::lzf_decompress(run.data(), run.size(), zs.data(), zs.size()) == 20);
  CHECK(std::string(zs.begin(), zs.end()) == std::string(20, 'z'));

  // Corrupt streams: reference before the start, literal cut short, output too small.
  const std::vector<std::uint8_t> before{0, 'a', 1 << 5, 4};
  const std::vector<std::uint8_t> cut{5, 'a', 'b'};
  CHECK(rd::lzf_decompress(before.data(), before.size(), out.data(), out.size()) == rd::lzf_error);
  CHECK(rd::lzf_decompress(cut.data(), cut.size(), out.data(), out.size()) == rd::lzf_error);
  CHECK(rd::lzf_decompress(run.data(), run.size(), zs.data(), 19) == rd::lzf_error);
  CHECK(rd::lzf_decompress(stream.data(), 5, out.data(), out.size()) == rd::lzf_error);
}

TEST_CASE("lzf round-trips empty, random, repetitive and long inputs") {
  CHECK(lzf_round_trip({}).empty());
  CHECK(lzf_round_trip({42}) == std::vector<std::uint8_t>{42});
  std::mt19937 rng(7);
  std::vector<std::uint8_t> noise(5000);
  for (auto& b : noise)
    b = static_cast<std::uint8_t>(rng());
  CHECK(lzf_round_trip(noise) == noise);

  // Runs longer than a reference (264) and repeats farther back than the window (8192).
  std::vector<std::uint8_t> text;
  for (int block = 0; block < 40; ++block) {
    text.insert(text.end(), 1000, static_cast<std::uint8_t>(block));
    for (int i = 0; i < 300; ++i)
      text.push_back(static_cast<std::uint8_t>(i * 7 + block));
  }
  std::vector<std::uint8_t> packed;
  rd::lzf_compress(text.data(), text.size(), packed);
  CHECK(packed.size() < text.size() / 5);
  CHECK(lzf_round_trip(text) == text);
}

TEST_CASE("pcd round trip keeps organised clouds with NaNs, colours, normals, intensity") {
  ScratchDir dir("pcd_round_trip");
  const auto cloud = make_organised_test_cloud<double>();
  const auto cloud_f = make_organised_test_cloud<float>();
  for (const auto format : {PcdFormat::ascii, PcdFormat::binary, PcdFormat::binary_compressed}) {
    for (const auto precision :
         {StoredScalar::as_cloud, StoredScalar::float32, StoredScalar::float64}) {
      INFO("format " << static_cast<int>(format) << " precision " << static_cast<int>(precision));
      const auto path = dir / "c.pcd";
      rangenav::io::write_pcd(path, cloud, format, precision);
      const auto back = rangenav::io::read_pcd(path);
      require_same_cloud(cloud, back);
      CHECK(back.is_organized());
      CHECK(std::isnan(back.at(1, 2).x()));  // point 6

      rangenav::io::write_pcd(path, cloud_f, format, precision);
      require_same_cloud(cloud_f, rangenav::io::read_pcd<float>(path));

      const auto header = rangenav::io::read_pcd_header(path);
      CHECK(header.width == 4);
      CHECK(header.height == 3);
      CHECK(header.points == 12);
      CHECK(header.data == format);
      REQUIRE(header.fields.size() == 8);
      CHECK(header.fields[4].name == "rgba");
      CHECK(header.fields[0].size == (precision == StoredScalar::float64 ? 8u : 4u));
    }
  }
}

TEST_CASE("pcd stores doubles losslessly as F 8 and xyz-only clouds without extra fields") {
  ScratchDir dir("pcd_double");
  Cloud3d cloud;
  cloud.points = {{0.1, -1e-300, 12345678.123456789}, {1.0 / 3.0, 2e300, -0.0}};
  cloud.width = 2;
  for (const auto format : {PcdFormat::ascii, PcdFormat::binary, PcdFormat::binary_compressed}) {
    rangenav::io::write_pcd(dir / "d.pcd", cloud, format);
    const auto back = rangenav::io::read_pcd(dir / "d.pcd");
    require_same_cloud(cloud, back);
    CHECK(!back.has_colors());
    CHECK(!back.has_normals());
    CHECK(!back.has_intensities());
    CHECK(rangenav::io::read_pcd_header(dir / "d.pcd").fields.size() == 3);
  }
  // Empty clouds write and read back empty.
  Cloud3d empty;
  for (const auto format : {PcdFormat::ascii, PcdFormat::binary, PcdFormat::binary_compressed}) {
    rangenav::io::write_pcd(dir / "e.pcd", empty, format);
    CHECK(rangenav::io::read_pcd(dir / "e.pcd").empty());
  }
}

TEST_CASE("pcd reads fields of any SIZE, TYPE and COUNT and skips the unknown ones") {
  ScratchDir dir("pcd_fields");
  // I 1, U 2, F 8, a COUNT 3 descriptor, a padding field, curvature, a float-packed rgb written
  // as integer text (as PCL does) and one given as its float bit pattern.
  const std::string header =
      "VERSION .7\n"
      "FIELDS tag x _ y z desc intensity rgb curvature\n"
      "SIZE 1 8 4 2 4 4 2 4 4\n"
      "TYPE I F U U F F U F F\n"
      "COUNT 1 1 1 1 1 3 1 1 1\n"
      "WIDTH 2\n"
      "POINTS 2\n";
  float packed = 0;
  const std::uint32_t bits = 0x00102030;  // r 0x10, g 0x20, b 0x30
  std::memcpy(&packed, &bits, 4);
  char packed_text[64];
  std::snprintf(packed_text, sizeof(packed_text), "%.9g", static_cast<double>(packed));
  write_text(dir / "a.pcd", header +
                                "DATA ascii\n"
                                "-5 0.125 7 65535 -2.5 1 2 3 40000 " +
                                std::to_string(0xff0a0b0c) + " 0.5\n" +
                                "\n"
                                "127 1e300 0 0 nan 4 5 6 1 " +
                                packed_text + " 0.25\n");
  const auto a = rangenav::io::read_pcd(dir / "a.pcd");
  REQUIRE(a.size() == 2);
  CHECK(a.width == 2);
  CHECK(a.height == 1);
  CHECK(a.points[0] == rangenav::Point3d(0.125, 65535, -2.5));
  CHECK(a.points[1].x() == 1e300);
  CHECK(std::isnan(a.points[1].z()));
  CHECK(a.intensities == std::vector<float>{40000.f, 1.f});
  CHECK(a.colors[0] == rangenav::Rgba{0x0a, 0x0b, 0x0c, 255});  // "rgb" has no alpha
  CHECK(a.colors[1] == rangenav::Rgba{0x10, 0x20, 0x30, 255});
  CHECK(!a.has_normals());

  // The same two points as packed little-endian records, and column-wise LZF-compressed.
  std::string rec[2];
  const auto put = [](std::string& s, auto v) { rd::append_le(s, v); };
  put(rec[0], std::int8_t{-5}), put(rec[0], 0.125), put(rec[0], std::uint32_t{7});
  put(rec[0], std::uint16_t{65535}), put(rec[0], -2.5f);
  put(rec[0], 1.f), put(rec[0], 2.f), put(rec[0], 3.f), put(rec[0], std::uint16_t{40000});
  put(rec[0], std::uint32_t{0xff0a0b0c}), put(rec[0], 0.5f);
  put(rec[1], std::int8_t{127}), put(rec[1], 1e300), put(rec[1], std::uint32_t{0});
  put(rec[1], std::uint16_t{0}), put(rec[1], std::numeric_limits<float>::quiet_NaN());
  put(rec[1], 4.f), put(rec[1], 5.f), put(rec[1], 6.f), put(rec[1], std::uint16_t{1});
  put(rec[1], bits), put(rec[1], 0.25f);
  REQUIRE(rec[0].size() == 41);
  write_text(dir / "b.pcd", header + "DATA binary\n" + rec[0] + rec[1]);
  require_same_cloud(a, rangenav::io::read_pcd(dir / "b.pcd"));

  std::string columns;
  std::size_t offset = 0;
  for (const std::size_t bytes : std::array<std::size_t, 9>{1, 8, 4, 2, 4, 12, 2, 4, 4}) {
    columns += rec[0].substr(offset, bytes) + rec[1].substr(offset, bytes);
    offset += bytes;
  }
  std::vector<std::uint8_t> lzf;
  rd::lzf_compress(reinterpret_cast<const std::uint8_t*>(columns.data()), columns.size(), lzf);
  std::string body;
  rd::append_le(body, static_cast<std::uint32_t>(lzf.size()));
  rd::append_le(body, static_cast<std::uint32_t>(columns.size()));
  body.append(lzf.begin(), lzf.end());
  write_text(dir / "c.pcd", header + "DATA binary_compressed\n" + body);
  require_same_cloud(a, rangenav::io::read_pcd(dir / "c.pcd"));
}

TEST_CASE("pcd rejects malformed files with messages naming the file and line") {
  ScratchDir dir("pcd_bad");
  const auto p = dir / "bad.pcd";
  const std::string name = p.string();
  const auto with = [&](const std::string& text) {
    write_text(p, text);
    return pcd_error(p);
  };
  const std::string prefix = "rangenav: pcd: " + name + ": ";

  CHECK(pcd_error(dir / "missing.pcd") ==
        "rangenav: pcd: " + (dir / "missing.pcd").string() + ": cannot open file for reading");
  CHECK(pcd_error(dir.path()) == "rangenav: pcd: " + dir.path().string() + ": is a directory");
  CHECK(with("") == prefix + "header ends without a DATA line");
  CHECK(with("ply\nformat ascii 1.0\n") ==
        prefix + "line 1: unknown header keyword 'ply' (not a PCD file?)");
  CHECK(with("# c\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4\n") ==
        prefix + "line 4: FIELDS has 3 names but SIZE has 2");
  CHECK(with("FIELDS x y z\nSIZE 4 4 4\nTYPE F F\n") ==
        prefix + "line 3: FIELDS has 3 names but TYPE has 2");
  CHECK(with("FIELDS x y z\nSIZE 4 4 3\n") == prefix + "line 2: SIZE '3' is not 1, 2, 4 or 8");
  CHECK(with("FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\n") ==
        prefix + "line 3: field 'z' has TYPE F and SIZE 2 (F needs SIZE 4 or 8)");
  CHECK(with("FIELDS x y z\nTYPE F F D\n") == prefix + "line 2: TYPE 'D' is not F, I or U");
  CHECK(with("FIELDS x y z\nCOUNT 1 0 1\n") ==
        prefix + "line 2: COUNT '0' is not a positive integer");
  CHECK(with("WIDTH -3\n") == prefix + "line 1: WIDTH '-3' is not a non-negative integer");
  CHECK(with("VIEWPOINT 0 0 0 1\n") ==
        prefix + "line 1: VIEWPOINT needs 7 values (tx ty tz qw qx qy qz), got 4");
  CHECK(with(header_xyz + "DATA zip\n") ==
        prefix + "line 11: unknown DATA type 'zip' (expected ascii, binary or binary_compressed)");
  CHECK(with("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nDATA ascii\n") ==
        prefix + "line 4: no WIDTH line before DATA");
  CHECK(with("FIELDS x y z\nSIZE 4 4 4\nWIDTH 2\nDATA ascii\n") ==
        prefix + "line 4: no TYPE line before DATA");
  CHECK(with("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 2\nPOINTS 3\nDATA ascii\n") ==
        prefix + "line 6: POINTS 3 does not equal WIDTH*HEIGHT = 2*2");
  CHECK(with("FIELDS x y w\nSIZE 4 4 4\nTYPE F F F\nWIDTH 0\nDATA ascii\n") ==
        prefix + "line 1: FIELDS has no 'z'");
  CHECK(with("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 2 1\nWIDTH 0\nDATA ascii\n") ==
        prefix + "field 'y' has COUNT 2 (expected 1)");
  CHECK(with("FIELDS x y z rgb\nSIZE 4 4 4 2\nTYPE F F F U\nWIDTH 0\nDATA ascii\n") ==
        prefix + "field 'rgb' has SIZE 2 (a packed colour needs SIZE 4)");

  // ascii data
  CHECK(with(header_xyz + "DATA ascii\n1 2 3\n") ==
        prefix + "line 12: data ends after 1 of 2 points");
  CHECK(with(header_xyz + "DATA ascii\n1 2 3\n4 5\n") ==
        prefix + "line 13: point 1 has 2 values but the fields need 3");
  CHECK(with(header_xyz + "DATA ascii\n1 2 3\n4 five 6\n") ==
        prefix + "line 13: point 1: y 'five' is not a valid value");
  CHECK(with(header_xyz + "DATA ascii\n1 2 3\n4 5 6\n7 8 9\n") ==
        prefix + "line 14: more data lines than the 2 POINTS of the header");

  // binary data
  std::string one_and_half(18, '\0');
  CHECK(with(header_xyz + "DATA binary\n" + one_and_half) ==
        prefix + "binary data has 18 bytes but 2 points of 12 bytes need 24 (truncated file?)");
  CHECK(with(header_xyz + "DATA binary_compressed\n" + "\x05\0\0") ==
        prefix + "binary_compressed data ends before its 8-byte size header");
  std::string sizes;
  rd::append_le(sizes, std::uint32_t{100});
  rd::append_le(sizes, std::uint32_t{24});
  CHECK(with(header_xyz + "DATA binary_compressed\n" + sizes + "abc") ==
        prefix + "binary_compressed data has 3 compressed bytes but its header says 100 " +
            "(truncated file?)");
  sizes.clear();
  rd::append_le(sizes, std::uint32_t{4});
  rd::append_le(sizes, std::uint32_t{20});
  CHECK(with(header_xyz + "DATA binary_compressed\n" + sizes + "abcd") ==
        prefix + "binary_compressed data unpacks to 20 bytes but 2 points of 12 bytes need 24");
  sizes.clear();
  rd::append_le(sizes, std::uint32_t{4});
  rd::append_le(sizes, std::uint32_t{24});
  CHECK(with(header_xyz + "DATA binary_compressed\n" + sizes + "\x02xyz") ==
        prefix + "binary_compressed data is corrupt (LZF stream does not unpack to 24 bytes)");

  // Writing: an inconsistent cloud is an invalid argument, an unwritable path an io_error.
  auto cloud = make_organised_test_cloud<double>();
  cloud.colors.pop_back();
  CHECK_THROWS_WITH(rangenav::io::write_pcd(dir / "w.pcd", cloud),
                    "rangenav: write_pcd: argument 'colors' = 11 (attribute count) must be 0 or "
                    "the point count 12");
  const auto nowhere = dir / "no_such_dir" / "w.pcd";
  CHECK_THROWS_WITH(rangenav::io::write_pcd(nowhere, make_organised_test_cloud<double>()),
                    "rangenav: pcd: " + nowhere.string() + ": cannot open file for writing");
  CHECK_THROWS_AS(rangenav::io::read_pcd_header(dir / "missing.pcd"), rangenav::io_error);
}

TEST_CASE("pcd reads PCL's bunny (ascii v.5 header) and bun0 (normals, curvature)") {
  const auto bunny_path = data_file_or_skip("pcl_test/bunny.pcd");
  const auto bun0_path = data_file_or_skip("pcl_test/bun0.pcd");
  if (bunny_path.empty() || bun0_path.empty()) return;
  const auto bunny = rangenav::io::read_pcd<float>(bunny_path);
  const auto bun0 = rangenav::io::read_pcd<float>(bun0_path);
  REQUIRE(bunny.size() == 397);
  REQUIRE(bun0.size() == 397);
  CHECK(!bunny.is_organized());
  CHECK(bunny.width == 397);
  CHECK(finite_count(bunny) == 397);
  // Bounding box as PCL 1.13's reader reports it: a bunny of about 15 x 15 x 11 cm.
  const auto [lo, hi] = finite_bounds(bunny);
  CHECK(lo.x() == Approx(-0.093938).margin(1e-7));
  CHECK(lo.y() == Approx(0.03742).margin(1e-7));
  CHECK(lo.z() == Approx(-0.055026).margin(1e-7));
  CHECK(hi.x() == Approx(0.059562).margin(1e-7));
  CHECK(hi.y() == Approx(0.1845).margin(1e-7));
  CHECK(hi.z() == Approx(0.057803).margin(1e-7));

  // bun0 is the same scan written with more digits, plus unit normals (curvature skipped).
  REQUIRE(bun0.has_normals());
  CHECK(!bun0.has_colors());
  CHECK(rangenav::io::read_pcd_header(bun0_path).fields.size() == 7);
  for (std::size_t i = 0; i < 397; ++i) {
    CHECK((bun0.points[i] - bunny.points[i]).norm() < 1e-6f);
    CHECK(bun0.normals[i].norm() == Approx(1.0f).epsilon(1e-5));
  }
  CHECK(bun0.normals[0].x() == -0.16884723f);  // first data line of the file

  ScratchDir dir("pcd_bunny");
  for (const auto format : {PcdFormat::binary, PcdFormat::binary_compressed, PcdFormat::ascii}) {
    rangenav::io::write_pcd(dir / "bun0.pcd", bun0, format);
    require_same_cloud(bun0, rangenav::io::read_pcd<float>(dir / "bun0.pcd"));
  }
}

TEST_CASE("pcd reads PCL's organised binary_compressed clouds and writes them back bit-exactly") {
  ScratchDir dir("pcd_real");
  struct Case {
    const char* file;
    std::size_t finite;
    rangenav::Point3d lo, hi;
    rangenav::Rgba centre;  // colour of pixel (240, 320)
  };
  // Finite counts, bounds and the centre colour as PCL 1.13's reader reports them.
  const Case cases[] = {
      {"pcl_test/table_scene_mug_stereo_textured.pcd",
       209280,
       {-0.45643, -0.51074, 0.69001},
       {0.71518, 0.17923, 2.5927},
       {0x00, 0x00, 0x28, 0xff}},
      {"pcl_test/office1.pcd",
       254456,
       {-2.6454761, -2.196429, 1.833},
       {1.50436, 1.581246, 5.364},
       {0xc1, 0xb5, 0xb1, 0xff}},  // an "rgb" field: opaque although its fourth byte is 0
  };
  for (const auto& c : cases) {
    const auto path = data_file_or_skip(c.file);
    if (path.empty()) continue;
    INFO(c.file);
    const auto cloud = rangenav::io::read_pcd<float>(path);
    REQUIRE(cloud.width == 640);
    REQUIRE(cloud.height == 480);
    REQUIRE(cloud.size() == 307200);
    CHECK(cloud.has_colors());
    CHECK(finite_count(cloud) == c.finite);
    const auto [lo, hi] = finite_bounds(cloud);
    for (int k = 0; k < 3; ++k) {
      CHECK(lo[k] == Approx(c.lo[k]).margin(1e-5));
      CHECK(hi[k] == Approx(c.hi[k]).margin(1e-5));
    }
    CHECK(cloud.colors[240 * 640 + 320] == c.centre);
    const auto header = rangenav::io::read_pcd_header(path);
    CHECK(header.data == PcdFormat::binary_compressed);
    CHECK(header.viewpoint == std::array<double, 7>{0, 0, 0, 0, 1, 0, 0});

    for (const auto format : {PcdFormat::binary, PcdFormat::binary_compressed, PcdFormat::ascii}) {
      rangenav::io::write_pcd(dir / "out.pcd", cloud, format);
      const auto back = rangenav::io::read_pcd<float>(dir / "out.pcd");
      require_same_cloud(cloud, back);
      if (format != PcdFormat::ascii)  // binary formats keep even the NaN payloads
        CHECK(std::memcmp(back.points.data(), cloud.points.data(),
                          cloud.size() * sizeof(cloud.points[0])) == 0);
    }
    // The compressed file we write is about as small as PCL's.
    rangenav::io::write_pcd(dir / "out.pcd", cloud, PcdFormat::binary_compressed);
    CHECK(std::filesystem::file_size(dir / "out.pcd") < std::filesystem::file_size(path) * 5 / 4);

    const auto as_double = rangenav::io::read_pcd(path);
    CHECK(as_double.points[100000].cast<float>() == cloud.points[100000]);
  }
}

TEST_CASE("pcd reads MRPT's organised ascii RGB-D frame") {
  const auto path = data_file_or_skip("mrpt_pbmap/pointcloud0.pcd");
  if (path.empty()) return;
  const auto cloud = rangenav::io::read_pcd(path);
  REQUIRE(cloud.width == 160);
  REQUIRE(cloud.height == 120);
  CHECK(cloud.is_organized());
  CHECK(finite_count(cloud) == 17176);  // as PROVENANCE.md and PCL count them
  const auto [lo, hi] = finite_bounds(cloud);
  CHECK(lo.z() == Approx(0.845165491).margin(1e-6));  // a wall about 1 m ahead of the camera
  CHECK(hi.z() == Approx(1.03666401).margin(1e-6));
  CHECK(lo.x() == Approx(-0.561497152).margin(1e-6));
  CHECK(hi.y() == Approx(0.41356191).margin(1e-6));
  CHECK(std::isnan(cloud.at(0, 0).x()));
  CHECK(cloud.at(0, 0).z() == Approx(1.0141944));                    // "nan nan 1.0141944 8425308"
  CHECK(cloud.colors[0] == rangenav::Rgba{0x80, 0x8f, 0x5c, 0x00});  // 8425308 = 0x00808f5c
  CHECK(cloud.colors[60 * 160 + 80] == rangenav::Rgba{0xeb, 0xeb, 0xeb, 0xff});

  ScratchDir dir("pcd_mrpt");
  for (const auto format : {PcdFormat::binary, PcdFormat::binary_compressed, PcdFormat::ascii}) {
    rangenav::io::write_pcd(dir / "frame.pcd", cloud, format);
    require_same_cloud(cloud, rangenav::io::read_pcd(dir / "frame.pcd"));
  }
}
