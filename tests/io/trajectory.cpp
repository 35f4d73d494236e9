#include <catch2/catch.hpp>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "rangenav/io/carmen.hpp"
#include "rangenav/io/trajectory.hpp"
#include "scratch_dir.hpp"
#include "test_support.hpp"

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
