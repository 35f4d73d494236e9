#include <catch2/catch.hpp>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "rangenav/io/carmen.hpp"
#include "rangenav/io/mrpt_pose.hpp"
#include "rangenav/io/trajectory.hpp"
#include "scratch_dir.hpp"
#include "test_support.hpp"

#ifdef RANGENAV_HAVE_ZLIB
#include <zlib.h>
#endif

using namespace rangenav;
using namespace rangenav::io;

namespace {

constexpr double pi = std::numbers::pi;

/// A scratch directory for this file's tests (tests/io/scratch_dir.hpp).
struct TempDir : rangenav::test::ScratchDir {
  TempDir() : ScratchDir("trajectory") {}
};

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

template <class Read>
std::string message_of(Read&& read) {
  try {
    (void)read();
  } catch (const error& e) {
    return e.what();
  }
  return "no error";
}

Transform3d random_transform(std::mt19937& engine) {
  std::uniform_real_distribution<double> coordinate(-500.0, 500.0);
  std::normal_distribution<double> normal;
  Eigen::Quaterniond q(normal(engine), normal(engine), normal(engine), normal(engine));
  q.normalize();
  Transform3d t = Transform3d::Identity();
  t.linear() = q.toRotationMatrix();
  t.translation() = Eigen::Vector3d(coordinate(engine), coordinate(engine), coordinate(engine));
  return t;
}

}  // namespace

TEST_CASE("write_tum prints 't tx ty tz qx qy qz qw' with fixed decimals", "[io][trajectory]") {
  std::ostringstream out;
  Transform3d quarter_turn = Transform3d::Identity();
  quarter_turn.linear() = Eigen::AngleAxisd(pi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  quarter_turn.translation() = Eigen::Vector3d(1.0, -2.0, 0.5);
  Transform3d minus_quarter = Transform3d::Identity();
  minus_quarter.linear() = Eigen::AngleAxisd(-pi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const std::vector<double> timestamps{1134864629.895182, 0.0000004};
  write_tum(out, timestamps, std::vector<Transform3d>{quarter_turn, minus_quarter});
  // qw >= 0: a quarter turn either way has qw = cos(pi/4).
  CHECK(out.str() ==
        "1134864629.895182 1.000000000 -2.000000000 0.500000000 0.000000000 0.000000000 "
        "0.707106781 0.707106781\n"
        "0.000000 0.000000000 0.000000000 0.000000000 0.000000000 0.000000000 -0.707106781 "
        "0.707106781\n");

  // A planar pose: z = 0 and a rotation about z.
  std::ostringstream planar;
  write_tum(planar, std::vector<double>{2.5}, std::vector<Pose2d>{{1.0, -2.0, pi / 2}});
  CHECK(planar.str() ==
        "2.500000 1.000000000 -2.000000000 0.000000000 0.000000000 0.000000000 0.707106781 "
        "0.707106781\n");
}

TEST_CASE("TUM round trip reproduces the poses to the printed precision", "[io][trajectory]") {
  TempDir dir;
  std::mt19937 engine(7);
  std::uniform_real_distribution<double> time(0.0, 2e9);
  std::vector<StampedTransform3d> written(200);
  for (auto& s : written)
    s = {time(engine), random_transform(engine)};
  const auto path = dir.path() / "poses.tum";
  write_tum(path, written);
  const auto read = read_tum(path);
  REQUIRE(read.size() == written.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    // 6 decimals for time (plus the double spacing at 2e9 s), 9 for the pose fields.
    CHECK(std::abs(read[i].timestamp - written[i].timestamp) <= 0.5e-6 + 5e-7);
    CHECK((read[i].pose.translation() - written[i].pose.translation()).cwiseAbs().maxCoeff() <=
          0.5e-9 + 1e-13);
    CHECK((read[i].pose.linear() - written[i].pose.linear()).cwiseAbs().maxCoeff() <= 1e-8);
    CHECK(is_rigid(read[i].pose, 1e-12));
  }
}

TEST_CASE("planar poses through TUM come back as rotations about z", "[io][trajectory]") {
  std::stringstream file;
  const std::vector<Pose2d> poses{{1.0, 2.0, 3.0}, {-4.0, 0.5, -3.1}, {0.0, 0.0, pi}};
  write_tum(file, std::vector<double>{1.0, 2.0, 3.0}, poses);
  const auto read = read_tum(file);
  REQUIRE(read.size() == 3);
  for (std::size_t i = 0; i < 3; ++i) {
    const auto& t = read[i].pose;
    CHECK(t.translation().z() == 0.0);
    CHECK(t.translation().x() == Approx(poses[i].x).margin(1e-9));
    CHECK(t.translation().y() == Approx(poses[i].y).margin(1e-9));
    const Eigen::Vector3d axis_z = t.linear() * Eigen::Vector3d::UnitZ();
    CHECK(axis_z.isApprox(Eigen::Vector3d::UnitZ(), 1e-9));
    const double yaw = std::atan2(t.linear()(1, 0), t.linear()(0, 0));
    CHECK(std::abs(angle_difference(yaw, poses[i].theta)) <= 1e-8);
  }
}

TEST_CASE("write_xytheta prints 't x y theta' and reads back", "[io][trajectory]") {
  std::ostringstream out;
  write_xytheta(out, std::vector<double>{12.0000016, 3.25},
                std::vector<Pose2d>{{1.0, -2.0, 0.5}, {-1e-10, 1234.5678901234, -pi}});
  CHECK(out.str() ==
        "12.000002 1.000000000 -2.000000000 0.500000000\n"
        "3.250000 0.000000000 1234.567890123 -3.141592654\n");  // no "-0.000000000"

  TempDir dir;
  std::mt19937 engine(11);
  std::uniform_real_distribution<double> coordinate(-100.0, 100.0);
  std::uniform_real_distribution<double> angle(-pi, pi);
  std::vector<StampedPose2d> written(300);
  double t = 1134864629.895182;
  for (auto& s : written) {
    s = {t, Pose2d{coordinate(engine), coordinate(engine), angle(engine)}};
    t += 0.213457;
  }
  const auto path = dir.path() / "poses.txt";
  write_xytheta(path, written);
  const auto read = read_xytheta(path);
  REQUIRE(read.size() == written.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    CHECK(std::abs(read[i].timestamp - written[i].timestamp) <= 0.5e-6 + 3e-7);
    CHECK(std::abs(read[i].pose.x - written[i].pose.x) <= 0.5e-9 + 1e-13);
    CHECK(std::abs(read[i].pose.y - written[i].pose.y) <= 0.5e-9 + 1e-13);
    CHECK(std::abs(angle_difference(read[i].pose.theta, written[i].pose.theta)) <= 0.5e-9 + 1e-13);
  }
}

TEST_CASE("read_xytheta normalises angles and skips comments and blank lines", "[io][trajectory]") {
  std::istringstream in("# t x y theta\n\n1 2 3 4\r\n  \n2 0 0 -7\n");
  const auto read = read_xytheta(in);
  REQUIRE(read.size() == 2);
  CHECK(read[0].timestamp == 1.0);
  CHECK(read[0].pose.x == 2.0);
  CHECK(read[0].pose.y == 3.0);
  CHECK(read[0].pose.theta == Approx(4.0 - 2 * pi));
  CHECK(read[1].pose.theta == Approx(-7.0 + 2 * pi));
  std::istringstream empty("");
  CHECK(read_xytheta(empty).empty());
  std::istringstream empty_tum("# nothing\n");
  CHECK(read_tum(empty_tum).empty());
}

TEST_CASE("trajectory readers: malformed lines raise io_error naming file and line",
          "[io][trajectory]") {
  TempDir dir;
  const auto tum = [&](const std::string& content) {
    const auto path = dir.write("bad.tum", content);
    return message_of([&] { return read_tum(path); });
  };
  const std::string prefix = "rangenav: tum: " + (dir.path() / "bad.tum").string() + ":";
  CHECK(tum("# header\n1 2 3 4 0 0 0 1\n1 2 3 4 0 0 0\n") ==
        prefix + "3: expected 8 fields, found 7");
  CHECK(tum("1 2 3 4 0 0 0 1 9\n") == prefix + "1: expected 8 fields, found 9");
  CHECK(tum("1 x 3 4 0 0 0 1\n") == prefix + "1: field 2 is not a finite number: 'x'");
  CHECK(tum("1 2 3 nan 0 0 0 1\n") == prefix + "1: field 4 is not a finite number: 'nan'");
  CHECK(tum("1 2 3 4 0 0 0 2\n") == prefix + "1: quaternion norm 2 is not 1");
  CHECK(tum("1 2 3 4 0 0 0 1\n2 2 3 4 0 0") ==
        prefix + "2: expected 8 fields, found 6 (unterminated last line: truncated file?)");

  const auto xyt_path = dir.write("bad.txt", "1 2 3\n");
  CHECK(message_of([&] { return read_xytheta(xyt_path); }) ==
        "rangenav: xytheta: " + xyt_path.string() + ":1: expected 4 fields, found 3");
  std::istringstream stream("1 2 3 4\n5 6 7 y\n");
  CHECK(message_of([&] { return read_xytheta(stream, "poses.txt"); }) ==
        "rangenav: xytheta: poses.txt:2: field 4 is not a finite number: 'y'");

  const auto missing = dir.path() / "missing.tum";
  CHECK(message_of([&] { return read_tum(missing); }) ==
        "rangenav: tum: " + missing.string() + ": cannot open file: No such file or directory");
  CHECK(read_tum(dir.write("empty.tum", "")).empty());
}

TEST_CASE("trajectory writers check their arguments", "[io][trajectory]") {
  std::ostringstream out;
  const std::vector<double> two{1.0, 2.0};
  const std::vector<Pose2d> one{{0.0, 0.0, 0.0}};
  CHECK(message_of([&] {
          write_xytheta(out, two, one);
          return 0;
        }) ==
        "rangenav: write_xytheta: argument 'poses.size()' = 1 must equal "
        "timestamps.size() = 2");
  CHECK(message_of([&] {
          write_tum(out, std::vector<double>{1.0},
                    std::vector<Pose2d>{{0.0, std::numeric_limits<double>::quiet_NaN(), 0.0}});
          return 0;
        }) == "rangenav: write_tum: argument 'index' = 0 holds a non-finite timestamp or pose");
  CHECK(out.str().empty());
  TempDir dir;
  const auto nowhere = dir.path() / "no_such_dir" / "poses.tum";
  CHECK(message_of([&] {
          write_tum(nowhere, std::vector<double>{1.0}, std::vector<Transform3d>{});
          return 0;
        }) == "rangenav: write_tum: " + nowhere.string() + ": cannot open file for writing");
}

// ---- KITTI poses and single matrices ---------------------------------------------------------

TEST_CASE("KITTI round trip reproduces the poses to the printed precision", "[io][trajectory]") {
  TempDir dir;
  std::mt19937 engine(11);
  std::vector<Transform3d> written(200);
  for (auto& t : written)
    t = random_transform(engine);
  const auto path = dir.path() / "poses.txt";
  write_kitti(path, written);
  // Twelve fields per line, the rows of [R | t].
  std::istringstream first_line(read_text(path).substr(0, read_text(path).find('\n')));
  std::vector<double> fields{std::istream_iterator<double>(first_line), {}};
  REQUIRE(fields.size() == 12);
  CHECK(std::abs(fields[3] - written[0].translation().x()) <= 0.5e-9 + 1e-13);
  CHECK(std::abs(fields[4] - written[0].linear()(1, 0)) <= 0.5e-9);
  const auto read = read_kitti(path);
  REQUIRE(read.size() == written.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    CHECK((read[i].translation() - written[i].translation()).cwiseAbs().maxCoeff() <=
          0.5e-9 + 1e-13);
    CHECK((read[i].linear() - written[i].linear()).cwiseAbs().maxCoeff() <= 1e-8);
    CHECK(is_rigid(read[i], 1e-12));
  }
}

TEST_CASE("read_kitti rejects malformed and non-rigid lines naming file and line",
          "[io][trajectory]") {
  TempDir dir;
  const auto kitti = [&](const std::string& content) {
    const auto path = dir.write("bad.txt", content);
    return message_of([&] { return read_kitti(path); });
  };
  const std::string prefix = "rangenav: kitti: " + (dir.path() / "bad.txt").string() + ":";
  const std::string identity = "1 0 0 0 0 1 0 0 0 0 1 0\n";
  CHECK(kitti(identity + "1 0 0 0 0 1 0 0 0 0 1\n") == prefix + "2: expected 12 fields, found 11");
  CHECK(kitti("1 0 0 0 0 1 0 0 0 0 1 inf\n") ==
        prefix + "1: field 12 is not a finite number: 'inf'");
  // A scaled rotation and a reflection are not rigid.
  CHECK(kitti("2 0 0 0 0 2 0 0 0 0 2 0\n") ==
        prefix + "1: rotation is not orthonormal: not a rigid transform");
  CHECK(kitti("1 0 0 0 0 1 0 0 0 0 -1 0\n") ==
        prefix + "1: rotation is not orthonormal: not a rigid transform");
  std::istringstream stream("# poses\n" + identity + "\n" + identity);
  CHECK(read_kitti(stream, "poses.txt").size() == 2);
  CHECK(read_kitti(dir.write("empty.txt", "")).empty());
}

TEST_CASE("read_transform_matrix reads 3x4 and 4x4 rigid matrices", "[io][trajectory]") {
  const Transform3d truth = [] {
    std::mt19937 engine(5);
    return random_transform(engine);
  }();
  std::ostringstream text;
  text.precision(17);
  text << "# T_target_source\n";
  for (int r = 0; r < 3; ++r)
    text << truth.matrix()(r, 0) << ' ' << truth.matrix()(r, 1) << ' ' << truth.matrix()(r, 2)
         << "  " << truth.matrix()(r, 3) << "\n";
  for (const std::string& last_row : {std::string(), std::string("0 0 0 1\n")}) {
    std::istringstream in(text.str() + last_row);
    const Transform3d read = read_transform_matrix(in);
    CHECK((read.matrix() - truth.matrix()).cwiseAbs().maxCoeff() <= 1e-12);
  }

  const auto bad = [](const std::string& content) {
    std::istringstream in(content);
    return message_of([&] { return read_transform_matrix(in, "T.txt"); });
  };
  const std::string rows = "1 0 0 1\n0 1 0 2\n0 0 1 3\n";
  CHECK(bad("1 0 0 1\n0 1 0 2\n") ==
        "rangenav: transform_matrix: T.txt: expected 3 or 4 rows of 4 numbers, found 2 rows");
  CHECK(bad(rows + "0 0 0 2\n") ==
        "rangenav: transform_matrix: T.txt:4: last row is not (0, 0, 0, 1): not a rigid transform");
  CHECK(bad(rows + "0 0 0 1\n0 0 0 1\n") ==
        "rangenav: transform_matrix: T.txt:5: more than 4 rows: not a 3x4 or 4x4 matrix");
  CHECK(bad("1 0 0 1\n0 1 0 2 7\n0 0 1 3\n") ==
        "rangenav: transform_matrix: T.txt:2: expected 4 fields, found 5");
  CHECK(bad("1 0 0 1\n0 1 0 nan\n0 0 1 3\n") ==
        "rangenav: transform_matrix: T.txt:2: field 4 is not a finite number: 'nan'");
  CHECK(bad("1 0 0 1\n1 1 0 2\n0 0 1 3\n") ==
        "rangenav: transform_matrix: T.txt: rotation is not orthonormal: not a rigid transform");
}

TEST_CASE("read_transform_matrix reads small_gicp's KITTI ground truth", "[io][trajectory][data]") {
  const auto path = test::data_file_or_skip("small_gicp/T_target_source.txt");
  if (path.empty()) return;
  const Transform3d t = read_transform_matrix(path);
  // The file's printed values (six significant digits), and a rigid result.
  CHECK(t.translation().isApprox(Eigen::Vector3d(0.488882, 0.121214, -0.0253342), 1e-6));
  CHECK(std::abs(t.linear()(0, 1) - 0.0121483) <= 1e-6);
  CHECK(std::abs(t.linear()(2, 2) - 0.999996) <= 1e-6);
  CHECK(is_rigid(t, 1e-12));
  const auto missing = path.parent_path() / "no_such_matrix.txt";
  CHECK(message_of([&] { return read_transform_matrix(missing); }) ==
        "rangenav: transform_matrix: " + missing.string() +
            ": cannot open file: No such file or directory");
}

TEST_CASE("the MIT CSAIL log's poses survive an xytheta round trip", "[io][trajectory][data]") {
#ifdef RANGENAV_HAVE_ZLIB
  const auto log = test::data_file_or_skip("carmen/mit-csail.clf.gz");
#else
  std::cout << "[rangenav-skip] built without zlib, cannot read carmen/mit-csail.clf.gz\n";
  const std::filesystem::path log;
#endif
  if (log.empty()) return;
  std::vector<StampedPose2d> trajectory;
  for (const auto& laser : read_carmen_lasers(log))
    trajectory.push_back({laser.timestamp, *laser.laser_pose});
  REQUIRE(trajectory.size() == 1988);
  TempDir dir;
  const auto path = dir.path() / "mit.txt";
  write_xytheta(path, trajectory);
  // The log prints 6 decimals, so its values come out exactly (first FLASER line of the log).
  const std::string text = read_text(path);
  CHECK(text.substr(0, text.find('\n')) ==
        "1134864629.895182 576.536523000 0.106594000 -2.255213000");
  const auto read = read_xytheta(path);
  REQUIRE(read.size() == trajectory.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    CHECK(read[i].timestamp == trajectory[i].timestamp);
    CHECK(read[i].pose.x == trajectory[i].pose.x);
    CHECK(read[i].pose.y == trajectory[i].pose.y);
    CHECK(read[i].pose.theta == Approx(trajectory[i].pose.theta).margin(1e-15));
  }
  CHECK(read.back().timestamp == 1134865053.892206);
}

// ---- MRPT pose files (io/mrpt_pose.hpp) -----------------------------------------------------

namespace {

// The 64 bytes of an MRPT pose file: the 4x4 matrix column-major as little-endian float32.
std::string mrpt_pose_bytes(const Eigen::Matrix4d& m) {
  std::string bytes;
  for (int col = 0; col < 4; ++col)
    for (int row = 0; row < 4; ++row)
      io::detail::append_le(bytes, static_cast<float>(m(row, col)));
  return bytes;
}

}  // namespace

TEST_CASE("read_mrpt_pose reads the pbmap demo's gzip-compressed camera poses",
          "[io][mrpt_pose][data]") {
#ifdef RANGENAV_HAVE_ZLIB
  const auto pose0 = test::data_file_or_skip("mrpt_pbmap/pose0.mat");
  const auto pose3 = test::data_file_or_skip("mrpt_pbmap/pose3.mat");
#else
  std::cout << "[rangenav-skip] built without zlib, cannot read mrpt_pbmap/pose0.mat\n";
  const std::filesystem::path pose0, pose3;
#endif
  if (pose0.empty() || pose3.empty()) return;
  // Translations as listed in ../shared/data/PROVENANCE.md.
  const Transform3d t0 = read_mrpt_pose(pose0);
  CHECK(t0.translation().isApprox(Eigen::Vector3d(-0.2176, -0.2287, 0.9001), 1e-3));
  const Transform3d t3 = read_mrpt_pose(pose3);
  CHECK(t3.translation().isApprox(Eigen::Vector3d(-0.2556, -0.6393, 1.5184), 1e-3));
  for (const auto& t : {t0, t3}) {
    const Eigen::Matrix3d r = t.linear();
    CHECK((r.transpose() * r).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
    CHECK(r.determinant() == Approx(1));
  }
  // Column-major: the file's second float is R(1, 0), not R(0, 1).
  CHECK(t0.linear()(1, 0) == Approx(-0.039822936).margin(1e-6));
  CHECK(t0.linear()(0, 1) == Approx(-0.01463264).margin(1e-6));
  // The camera looks down its z axis, which points roughly along the world's -z here.
  CHECK(t0.linear()(2, 2) == Approx(-0.9712442).margin(1e-6));
}

TEST_CASE("read_mrpt_pose round-trips plain and gzip files", "[io][mrpt_pose]") {
  std::mt19937 engine(7);
  TempDir dir;
  for (int k = 0; k < 5; ++k) {
    const Transform3d truth = random_transform(engine);
    const std::string bytes = mrpt_pose_bytes(truth.matrix());
    const auto plain = dir.write("plain.mat", bytes);
    const Transform3d read = read_mrpt_pose(plain);
    CHECK(read.linear().isApprox(truth.linear(), 1e-6));
    CHECK(read.translation().isApprox(truth.translation(), 1e-6));
#ifdef RANGENAV_HAVE_ZLIB
    const auto gz_path = dir.path() / "pose.mat";
    gzFile gz = gzopen(gz_path.c_str(), "wb9");
    REQUIRE(gz != nullptr);
    REQUIRE(gzwrite(gz, bytes.data(), static_cast<unsigned>(bytes.size())) == 64);
    gzclose(gz);
    CHECK(read_mrpt_pose(gz_path).isApprox(read, 1e-15));
#endif
  }
}

TEST_CASE("read_mrpt_pose rejects bad files with the file's name", "[io][mrpt_pose]") {
  TempDir dir;
  const auto message = [&](const std::string& name, const std::string& bytes) {
    const auto path = dir.write(name, bytes);
    return message_of([&] { return read_mrpt_pose(path); });
  };
  const std::string good = mrpt_pose_bytes(Eigen::Matrix4d::Identity());
  const std::string prefix = "rangenav: MRPT pose: " + (dir.path() / "").string();
  CHECK(message("short.mat", good.substr(0, 60)) ==
        prefix + "short.mat: expected 64 bytes (16 float32, a 4x4 matrix), got 60");
  CHECK(message("long.mat", good + "1234") ==
        prefix + "long.mat: expected 64 bytes (16 float32, a 4x4 matrix), got more");
  CHECK(message("empty.mat", "") ==
        prefix + "empty.mat: expected 64 bytes (16 float32, a 4x4 matrix), got 0");
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m(3, 0) = 0.5;
  CHECK(message("row.mat", mrpt_pose_bytes(m)) ==
        prefix + "row.mat: last row is not (0, 0, 0, 1): not a rigid transform");
  m = 2 * Eigen::Matrix4d::Identity();
  m(3, 3) = 1;
  CHECK(message("scaled.mat", mrpt_pose_bytes(m)) ==
        prefix + "scaled.mat: rotation is not orthonormal: not a rigid transform");
  m = Eigen::Matrix4d::Identity();
  m(0, 3) = std::numeric_limits<double>::quiet_NaN();
  CHECK(message("nan.mat", mrpt_pose_bytes(m)) == prefix + "nan.mat: non-finite matrix element");
  CHECK(message_of([&] { return read_mrpt_pose(dir.path() / "missing.mat"); }) ==
        prefix + "missing.mat: cannot open file for reading");
#ifdef RANGENAV_HAVE_ZLIB
  const auto gz_path = dir.path() / "full.mat";
  gzFile gz = gzopen(gz_path.c_str(), "wb9");
  REQUIRE(gz != nullptr);
  REQUIRE(gzwrite(gz, good.data(), static_cast<unsigned>(good.size())) == 64);
  gzclose(gz);
  const std::string compressed = read_text(gz_path);
  CHECK(message("truncated.mat", compressed.substr(0, compressed.size() / 2)) ==
        prefix + "truncated.mat: gzip: truncated compressed data");
  std::string corrupt = compressed;
  corrupt[12] = static_cast<char>(corrupt[12] ^ 0x55);
  corrupt[13] = static_cast<char>(corrupt[13] ^ 0x55);
  CHECK_THROWS_AS(read_mrpt_pose(dir.write("corrupt.mat", corrupt)), io_error);
#else
  CHECK(message("gz.mat", std::string("\x1f\x8b\x08\x00", 4)) ==
        prefix +
            "gz.mat: gzip-compressed file, but rangenav was built without zlib "
            "(RANGENAV_HAVE_ZLIB)");
#endif
}
