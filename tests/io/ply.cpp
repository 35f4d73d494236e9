// Tests of include/rangenav/io/ply.hpp: round trips in both formats, hand-written files with
// property types, lists and extra elements, exact error messages, and small_gicp's CloudCompare
// clouds (ground truth counted by PCL 1.13's reader).

#include "rangenav/io/ply.hpp"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "cloud_checks.hpp"
#include "scratch_dir.hpp"
#include "test_support.hpp"

using rangenav::Cloud3d;
using rangenav::Cloud3f;
using rangenav::io::PlyFormat;
using rangenav::io::StoredScalar;
using namespace rangenav::test;
namespace rd = rangenav::io::detail;

namespace {

std::string ply_error(const std::filesystem::path& path) {
  try {
    (void)rangenav::io::read_ply(path);
  } catch (const rangenav::io_error& e) {
    return e.what();
  }
  return "no error";
}

std::string file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string body_of(const std::string& bytes) {
  const auto at = bytes.find("end_header\n");
  return at == std::string::npos ? std::string() : bytes.substr(at + 11);
}

}  // namespace

TEST_CASE("ply round trip keeps organised clouds with NaNs, colours, normals, intensity") {
  ScratchDir dir("ply_round_trip");
  const auto cloud = make_organised_test_cloud<double>();
  const auto cloud_f = make_organised_test_cloud<float>();
  for (const auto format : {PlyFormat::ascii, PlyFormat::binary_little_endian}) {
    for (const auto precision :
         {StoredScalar::as_cloud, StoredScalar::float32, StoredScalar::float64}) {
      INFO("format " << static_cast<int>(format) << " precision " << static_cast<int>(precision));
      const auto path = dir / "c.ply";
      rangenav::io::write_ply(path, cloud, format, precision);
      const auto back = rangenav::io::read_ply(path);
      require_same_cloud(cloud, back);
      CHECK(back.is_organized());
      CHECK(std::isnan(back.at(2, 3).z()));  // point 11
      rangenav::io::write_ply(path, cloud_f, format, precision);
      require_same_cloud(cloud_f, rangenav::io::read_ply<float>(path));
      // Without the cloud's organisation comment the same vertices read as a flat cloud.
      std::string text = file_bytes(path);
      const auto comment = text.find("comment rangenav organized");
      REQUIRE(comment != std::string::npos);
      // "comment xrangenav organized ..." is just a comment.
      write_text(path, text.substr(0, comment + 8) + "x" + text.substr(comment + 8));
      const auto flat = rangenav::io::read_ply<float>(path);
      CHECK(flat.width == 12);
      CHECK(flat.height == 1);
      CHECK(same_vectors(flat.points, cloud_f.points));
    }
  }
  Cloud3d doubles;
  doubles.points = {{0.1, -1e-300, 12345678.123456789}, {1.0 / 3.0, 2e300, -0.0}};
  doubles.width = 2;
  for (const auto format : {PlyFormat::ascii, PlyFormat::binary_little_endian}) {
    rangenav::io::write_ply(dir / "d.ply", doubles, format);
    require_same_cloud(doubles, rangenav::io::read_ply(dir / "d.ply"));
    rangenav::io::write_ply(dir / "e.ply", Cloud3d{}, format);
    CHECK(rangenav::io::read_ply(dir / "e.ply").empty());
  }
}

TEST_CASE("ply reads any property types, skips lists and other elements, in ascii and binary") {
  ScratchDir dir("ply_fields");
  const std::string header_tail =
      " 1.0\n"
      "comment made by hand\n"
      "obj_info nothing\n"
      "element camera 1\n"
      "property list uchar float params\n"
      "element vertex 2\n"
      "property double x\n"
      "property char flag\n"
      "property float y\n"
      "property int z\n"
      "property list ushort int neighbours\n"
      "property ushort scalar_intensity\n"
      "property uchar red\n"
      "property uint16 green\n"
      "property uchar blue\n"
      "property float32 nx\n"
      "property float ny\n"
      "property float nz\n"
      "element face 2\n"
      "property list uchar int vertex_indices\n"
      "property uchar tag\n"
      "end_header\n";
  write_text(dir / "a.ply", "ply\nformat ascii" + header_tail +
                                "3 1 2 3\n"
                                "0.5 -1 1.25 -7 2 10 11 300 1 999 3 0 0 1\n"
                                "\n"
                                "-2e10 5 nan 2147483647 0 65535 255 0 7 0.5 0.5 0.70710677\n"
                                "3 0 1 1 9\n"
                                "0 8\n");
  const auto a = rangenav::io::read_ply(dir / "a.ply");
  REQUIRE(a.size() == 2);
  CHECK(a.width == 2);
  CHECK(!a.is_organized());
  CHECK(a.points[0] == rangenav::Point3d(0.5, 1.25, -7));
  CHECK(a.points[1].x() == -2e10);
  CHECK(std::isnan(a.points[1].y()));
  CHECK(a.points[1].z() == 2147483647.0);
  CHECK(a.intensities == std::vector<float>{300.f, 65535.f});
  CHECK(a.colors[0] == rangenav::Rgba{1, 255, 3, 255});  // green 999 saturates, no alpha: opaque
  CHECK(a.colors[1] == rangenav::Rgba{255, 0, 7, 255});
  CHECK(a.normals[1].z() == Approx(0.70710677));

  // The same file, packed little-endian.
  std::string body;
  const auto put = [&](auto v) { rd::append_le(body, v); };
  put(std::uint8_t{3}), put(1.f), put(2.f), put(3.f);
  put(0.5), put(std::int8_t{-1}), put(1.25f), put(std::int32_t{-7});
  put(std::uint16_t{2}), put(std::int32_t{10}), put(std::int32_t{11});
  put(std::uint16_t{300}), put(std::uint8_t{1}), put(std::uint16_t{999}), put(std::uint8_t{3});
  put(0.f), put(0.f), put(1.f);
  put(-2e10), put(std::int8_t{5}), put(std::numeric_limits<float>::quiet_NaN());
  put(std::int32_t{2147483647}), put(std::uint16_t{0}), put(std::uint16_t{65535});
  put(std::uint8_t{255}), put(std::uint16_t{0}), put(std::uint8_t{7});
  put(0.5f), put(0.5f), put(0.70710677f);
  put(std::uint8_t{3}), put(0), put(1), put(1), put(std::uint8_t{9});
  put(std::uint8_t{0}), put(std::uint8_t{8});
  write_text(dir / "b.ply", "ply\nformat binary_little_endian" + header_tail + body);
  require_same_cloud(a, rangenav::io::read_ply(dir / "b.ply"));

  // Float colours are fractions of 255; alpha is read when present.
  write_text(dir / "c.ply",
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
             "property float z\nproperty float red\nproperty float green\nproperty float blue\n"
             "property float alpha\nend_header\n1 2 3 1 0.5 -0.25 2\n");
  CHECK(rangenav::io::read_ply(dir / "c.ply").colors[0] == rangenav::Rgba{255, 128, 0, 255});
}

TEST_CASE("ply rejects malformed and unsupported files with messages naming the file and line") {
  ScratchDir dir("ply_bad");
  const auto p = dir / "bad.ply";
  const std::string prefix = "rangenav: ply: " + p.string() + ": ";
  const auto with = [&](const std::string& text) {
    write_text(p, text);
    return ply_error(p);
  };
  const std::string xyz_props =
      "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n";
  const std::string xyz = xyz_props + "end_header\n";

  CHECK(ply_error(dir / "missing.ply") ==
        "rangenav: ply: " + (dir / "missing.ply").string() + ": cannot open file for reading");
  CHECK(with("") == prefix + "not a PLY file (empty)");
  CHECK(with("# .PCD v0.7\nVERSION 0.7\n") ==
        prefix + "line 1: not a PLY file (first line is '# .PCD v0.7', expected 'ply')");
  CHECK(with("ply\nformat binary_big_endian 1.0\n" + xyz) ==
        prefix + "line 2: format binary_big_endian is unsupported (use ascii or " +
            "binary_little_endian)");
  CHECK(with("ply\nformat utf8 1.0\n") ==
        prefix + "line 2: unknown format 'utf8' (expected ascii or binary_little_endian)");
  CHECK(with("ply\nformat ascii 2.0\n") ==
        prefix + "line 2: unsupported version '2.0' (expected 1.0)");
  CHECK(with("ply\nelement vertex 1\n") == prefix + "line 2: element before the format line");
  CHECK(with("ply\nformat ascii 1.0\nproperty float x\n") ==
        prefix + "line 3: property before any element");
  CHECK(with("ply\nformat ascii 1.0\nelement vertex 1\nproperty float16 x\n") ==
        prefix + "line 4: unknown property type 'float16'");
  CHECK(with("ply\nformat ascii 1.0\nelement vertex 1\nproperty list float int x\n") ==
        prefix + "line 4: list count type 'float' is not an integer type");
  CHECK(with("ply\nformat ascii 1.0\nelement vertex many\n") ==
        prefix + "line 3: element needs a name and a non-negative count");
  CHECK(with("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n") ==
        prefix + "line 4: header ends without end_header");
  CHECK(with("ply\nformat ascii 1.0\nvertex 1\n") ==
        prefix + "line 3: unknown header keyword 'vertex'");
  CHECK(with("ply\nformat ascii 1.0\nelement face 0\nend_header\n") ==
        prefix + "line 4: no element vertex");
  CHECK(with("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
             "end_header\n") == prefix + "line 3: element vertex has no property 'z'");
  CHECK(with("ply\nformat ascii 1.0\nelement vertex 0\nproperty list uchar float x\n"
             "property float y\nproperty float z\nend_header\n") ==
        prefix + "line 3: vertex property 'x' is a list (expected a single value)");

  // ascii data
  CHECK(with("ply\nformat ascii 1.0\n" + xyz + "1 2 3\n") ==
        prefix + "line 8: data ends after 1 of 2 'vertex' elements");
  CHECK(with("ply\nformat ascii 1.0\n" + xyz + "1 2 3\n4 5\n") ==
        prefix + "line 9: vertex 1 has 2 values but its properties need 3");
  CHECK(with("ply\nformat ascii 1.0\n" + xyz + "1 2 3\n4 five 6\n") ==
        prefix + "line 9: vertex 1: y 'five' is not a valid value");
  CHECK(with("ply\nformat ascii 1.0\n" + xyz + "1 2 3\n4 5 6\n7 8 9\n") ==
        prefix + "line 10: more data lines than the header's elements");
  CHECK(with("ply\nformat ascii 1.0\n" + xyz_props + "element face 1\nproperty list uchar int v\n" +
             "end_header\n1 2 3\n4 5 6\n3 1 2\n") ==
        prefix + "line 12: face 0: list 'v' has 3 items but the line holds 2 more values");

  // binary data
  CHECK(with("ply\nformat binary_little_endian 1.0\n" + xyz + std::string(20, '\0')) ==
        prefix + "binary data ends inside element 'vertex' 1 of 2 (truncated file?)");
  std::string face_body(24, '\0');
  face_body += "\x03";
  face_body += std::string(8, '\0');
  CHECK(with("ply\nformat binary_little_endian 1.0\n" + xyz_props +
             "element face 1\nproperty list uchar int v\nend_header\n" + face_body) ==
        prefix + "binary data ends inside element 'face' 0 of 1 (truncated file?)");

  auto cloud = make_organised_test_cloud<float>();
  cloud.width = 5;
  CHECK_THROWS_WITH(rangenav::io::write_ply(dir / "w.ply", cloud),
                    "rangenav: write_ply: argument 'width*height' = 15 must equal the point "
                    "count 12");
}

TEST_CASE("ply reads small_gicp's CloudCompare clouds and writes them back bit-exactly") {
  ScratchDir dir("ply_real");
  struct Case {
    const char* file;
    std::size_t vertices;
    rangenav::Point3d lo, hi;
  };
  // Counts and bounds as PCL 1.13's reader reports them: an outdoor scan some 40 x 60 x 13 m.
  const Case cases[] = {
      {"small_gicp/source.ply",
       69792,
       {-23.7590199, -52.0011406, -3.02128983},
       {18.4799328, 6.50786924, 9.17280483}},
      {"small_gicp/target.ply",
       69088,
       {-23.3374786, -74.6816101, -2.95733595},
       {19.0246964, 8.91950989, 10.7959356}},
  };
  for (const auto& c : cases) {
    const auto path = data_file_or_skip(c.file);
    if (path.empty()) continue;
    INFO(c.file);
    const auto cloud = rangenav::io::read_ply<float>(path);
    REQUIRE(cloud.size() == c.vertices);
    CHECK(!cloud.is_organized());
    CHECK(finite_count(cloud) == c.vertices);
    REQUIRE(cloud.has_intensities());  // from scalar_intensity
    CHECK(!cloud.has_colors());
    const auto [lo, hi] = finite_bounds(cloud);
    for (int k = 0; k < 3; ++k) {
      CHECK(lo[k] == Approx(c.lo[k]).margin(1e-5));
      CHECK(hi[k] == Approx(c.hi[k]).margin(1e-5));
    }
    const auto [imin, imax] =
        std::minmax_element(cloud.intensities.begin(), cloud.intensities.end());
    CHECK(*imin >= 0.f);
    CHECK(*imax > *imin);

    // Written as float x y z intensity, the body is CloudCompare's body byte for byte.
    rangenav::io::write_ply(dir / "out.ply", cloud, PlyFormat::binary_little_endian);
    CHECK(body_of(file_bytes(dir / "out.ply")) == body_of(file_bytes(path)));
    for (const auto format : {PlyFormat::binary_little_endian, PlyFormat::ascii}) {
      rangenav::io::write_ply(dir / "out.ply", cloud, format);
      require_same_cloud(cloud, rangenav::io::read_ply<float>(dir / "out.ply"));
    }
    const auto as_double = rangenav::io::read_ply(path);
    rangenav::io::write_ply(dir / "out.ply", as_double);
    const auto back = rangenav::io::read_ply(dir / "out.ply");
    CHECK(std::memcmp(back.points.data(), as_double.points.data(),
                      as_double.size() * sizeof(as_double.points[0])) == 0);
  }
}
