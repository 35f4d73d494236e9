#include <catch2/catch.hpp>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/io/carmen.hpp"
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
  TempDir() : ScratchDir("carmen") {}
};

std::vector<CarmenRecord> read_all(const std::filesystem::path& path,
                                   CarmenReaderOptions options = {}) {
  CarmenReader reader(path, options);
  std::vector<CarmenRecord> records;
  while (auto record = reader.next())
    records.push_back(std::move(*record));
  return records;
}

std::string message_of(const std::filesystem::path& path, CarmenReaderOptions options = {}) {
  try {
    (void)read_all(path, options);
  } catch (const io_error& e) {
    return e.what();
  }
  return "no error";
}

// The real logs are gzip-compressed: without zlib the tests that read them skip visibly.
std::filesystem::path gz_data_file_or_skip(const std::string& relative) {
#ifdef RANGENAV_HAVE_ZLIB
  return test::data_file_or_skip(relative);
#else
  std::cout << "[rangenav-skip] built without zlib, cannot read " << relative << '\n';
  return {};
#endif
}

// A FLASER line with n beams whose ranges are 1, 2, ..., n metres.
std::string flaser_line(std::size_t n) {
  std::string line = "FLASER ";
  line.append(std::to_string(n));
  for (std::size_t i = 1; i <= n; ++i)
    line.append(" ").append(std::to_string(i));
  line.append(" 0 0 0 0 0 0 10.5 host 0.5\n");
  return line;
}

// Every record type the reader knows, plus lines it must skip.
const std::string sample_log =
    "# CARMEN Logfile\n"
    "# message formats defined: PARAM SYNC ODOM RAWLASER1 FLASER RLASER\n"
    "\n"
    "PARAM robot_width 0.54 1134863807.659165 b21 1134863807.659162\n"
    "FLASER 5 1.0 2.5 81.91 nan 0.0 576.536523 0.106594 -2.255213 576.5 0.1 -2.25 "
    "1134864629.895182 b21 0.086295\n"
    "ODOM 1.5 -2 0.25 0.3 -0.1 0 1.13486e+09 pippo 12.25\n"
    "NEFF 27.6666 0 pippo 0\n"
    "TRUEPOS 1 2 3 4 5 6 7 host 8\n"
    "PARAM robot_front_laser_max 50 nohost 0\n"
    "\t FLASER  3 49.9 50 60   1 2 3 4 5 6 100 h 1\r\n"
    "RLASER 3 49.9 50 81.95 -1 -2 0.5 -1.5 -2.5 0.75 101 rear 2\n"
    "RAWLASER1 0 -1.5 3.0 0.75 30 0.01 0 5 1 2 3 40 0.5 5 10 20 30 40 50 102.5 laser 3\n"
    "ROBOTLASER1 0 -0.5 1 0.5 20 0.01 0 3 3 20 4 2 7 8 0.1 0.2 0.3 -0.4 1.5 -0.6 0.2 0.1 "
    "0.5 0.2 0 103.25 robot 4\n";

}  // namespace

TEST_CASE("CarmenReader reads every record type with exact fields", "[io][carmen]") {
  TempDir dir;
  const auto path = dir.write("sample.clf", sample_log);
  CarmenReader reader(path);
  CHECK(reader.params().empty());

  // FLASER: CARMEN's layout for 5 beams is -pi/2 + i * pi/4; default max range 81.9.
  auto record = reader.next();
  REQUIRE(record);
  REQUIRE(std::holds_alternative<CarmenLaser>(*record));
  {
    const auto& laser = std::get<CarmenLaser>(*record);
    CHECK(laser.type == CarmenLaserType::flaser);
    CHECK(laser.line == 5);
    CHECK(laser.timestamp == 1134864629.895182);
    CHECK(laser.scan.timestamp() == 1134864629.895182);
    CHECK(laser.host == "b21");
    CHECK(laser.logger_timestamp == 0.086295);
    REQUIRE(laser.laser_pose);
    CHECK(*laser.laser_pose == Pose2d{576.536523, 0.106594, -2.255213});
    REQUIRE(laser.odom_pose);
    CHECK(*laser.odom_pose == Pose2d{576.5, 0.1, -2.25});
    const auto& scan = laser.scan;
    REQUIRE(scan.size() == 5);
    CHECK(scan.angle_min() == Approx(-pi / 2));
    CHECK(scan.angle_increment() == Approx(pi / 4));
    CHECK(scan.range_max() == 81.9);
    CHECK(scan.range_min() == 0.0);
    CHECK(scan.range(0) == 1.0);
    CHECK(scan.range(1) == 2.5);
    CHECK(scan.range(2) == 81.91);
    CHECK(std::isnan(scan.range(3)));
    CHECK(scan.valid_indices() == std::vector<std::uint32_t>{0, 1});  // 81.91, nan, 0 invalid
    CHECK(scan.point(0).isApprox(Point2d(0, -1), 1e-12));             // beam 0 points right
    CHECK(scan.point(1).isApprox(Point2d(2.5 * std::cos(pi / 4), -2.5 * std::sin(pi / 4))));
    CHECK_FALSE(scan.has_intensities());
  }
  CHECK(reader.params().at("robot_width") == "0.54");

  record = reader.next();
  REQUIRE(record);
  REQUIRE(std::holds_alternative<CarmenOdometry>(*record));
  {
    const auto& odom = std::get<CarmenOdometry>(*record);
    CHECK(odom.pose == Pose2d{1.5, -2.0, 0.25});
    CHECK(odom.tv == 0.3);
    CHECK(odom.rv == -0.1);
    CHECK(odom.accel == 0.0);
    CHECK(odom.timestamp == 1.13486e+09);
    CHECK(odom.host == "pippo");
    CHECK(odom.logger_timestamp == 12.25);
    CHECK(odom.line == 6);
  }

  // NEFF and TRUEPOS are skipped; the PARAM before this FLASER sets its max range to 50, and the
  // leading whitespace, double spaces and "\r\n" are tolerated.
  record = reader.next();
  REQUIRE(record);
  {
    const auto& laser = std::get<CarmenLaser>(*record);
    CHECK(laser.line == 10);
    CHECK(laser.scan.range_max() == 50.0);
    CHECK(laser.scan.angle_increment() == Approx(pi / 2));
    CHECK(laser.scan.valid_indices() == std::vector<std::uint32_t>{0});
    CHECK(laser.host == "h");
    CHECK(laser.logger_timestamp == 1.0);
  }
  CHECK(reader.params().at("robot_front_laser_max") == "50");

  // RLASER does not use the front laser's PARAM.
  record = reader.next();
  REQUIRE(record);
  {
    const auto& laser = std::get<CarmenLaser>(*record);
    CHECK(laser.type == CarmenLaserType::rlaser);
    CHECK(laser.scan.range_max() == 81.9);
    CHECK(laser.scan.valid_indices() == std::vector<std::uint32_t>{0, 1});
    CHECK(*laser.laser_pose == Pose2d{-1, -2, 0.5});
    CHECK(*laser.odom_pose == Pose2d{-1.5, -2.5, 0.75});
    CHECK(laser.timestamp == 101.0);
    CHECK(laser.host == "rear");
  }

  // RAWLASER1: geometry and max range from the record; 5 remissions for 5 ranges -> intensities.
  record = reader.next();
  REQUIRE(record);
  {
    const auto& laser = std::get<CarmenLaser>(*record);
    CHECK(laser.type == CarmenLaserType::rawlaser1);
    CHECK(laser.line == 12);
    const auto& scan = laser.scan;
    REQUIRE(scan.size() == 5);
    CHECK(scan.angle_min() == -1.5);
    CHECK(scan.angle_increment() == 0.75);
    CHECK(scan.angle_max() == Approx(1.5));
    CHECK(scan.range_max() == 30.0);
    CHECK(scan.ranges() == std::vector<double>{1, 2, 3, 40, 0.5});
    CHECK(scan.valid_indices() == std::vector<std::uint32_t>{0, 1, 2, 4});
    CHECK(scan.intensities() == std::vector<double>{10, 20, 30, 40, 50});
    CHECK_FALSE(laser.laser_pose);
    CHECK_FALSE(laser.odom_pose);
    CHECK(laser.timestamp == 102.5);
    CHECK(laser.host == "laser");
    CHECK(laser.logger_timestamp == 3.0);
  }

  // ROBOTLASER1: 2 remissions for 3 ranges are not intensities; laser and robot poses.
  record = reader.next();
  REQUIRE(record);
  {
    const auto& laser = std::get<CarmenLaser>(*record);
    CHECK(laser.type == CarmenLaserType::robotlaser1);
    const auto& scan = laser.scan;
    CHECK(scan.ranges() == std::vector<double>{3, 20, 4});
    CHECK(scan.range_max() == 20.0);
    CHECK(scan.angle_min() == -0.5);
    CHECK(scan.angle_increment() == 0.5);
    CHECK(scan.valid_indices() == std::vector<std::uint32_t>{0, 2});
    CHECK_FALSE(scan.has_intensities());
    CHECK(*laser.laser_pose == Pose2d{0.1, 0.2, 0.3});
    CHECK(*laser.odom_pose == Pose2d{-0.4, 1.5, -0.6});
    CHECK(laser.timestamp == 103.25);
    CHECK(laser.host == "robot");
    CHECK(laser.logger_timestamp == 4.0);
  }
  CHECK_FALSE(reader.next());
  CHECK_FALSE(reader.next());  // stays at the end
  CHECK(reader.params().size() == 2);
}

TEST_CASE("FLASER beam layout follows CARMEN's readlog convention", "[io][carmen]") {
  TempDir dir;
  struct Case {
    std::size_t n;
    double increment;
  };
  for (const Case c :
       {Case{180, pi / 180}, Case{181, pi / 180}, Case{360, pi / 360}, Case{361, pi / 360},
        Case{400, pi / 720}, Case{401, pi / 720}, Case{91, pi / 90}}) {
    const auto lasers = read_carmen_lasers(dir.write("n.clf", flaser_line(c.n)));
    REQUIRE(lasers.size() == 1);
    const auto& scan = lasers[0].scan;
    INFO("n = " << c.n);
    CHECK(scan.size() == c.n);
    CHECK(scan.angle_min() == Approx(-pi / 2));
    CHECK(scan.angle_increment() == Approx(c.increment));
    CHECK(scan.range(c.n - 1) == static_cast<double>(c.n));
  }
  // 181 beams at 1 degree span exactly [-90, 90] degrees, so the last beam points left.
  const auto lasers = read_carmen_lasers(dir.write("181.clf", flaser_line(181)));
  CHECK(lasers[0].scan.angle_max() == Approx(pi / 2));
  CHECK(lasers[0].scan.point(180).isApprox(Point2d(0, 181), 1e-9));
}

TEST_CASE("CarmenReaderOptions: range_max overrides PARAM and record, range_min applies",
          "[io][carmen]") {
  TempDir dir;
  const auto path = dir.write("sample.clf", sample_log);
  const auto lasers = read_carmen_lasers(path, {.range_max = 2.0, .range_min = 1.0});
  REQUIRE(lasers.size() == 5);
  for (const auto& laser : lasers) {
    CHECK(laser.scan.range_max() == 2.0);
    CHECK(laser.scan.range_min() == 1.0);
  }
  // Valid means range_min <= r < range_max: 1.0 is kept, 2.0 and 0.5 are not.
  CHECK(lasers[0].scan.valid_indices() == std::vector<std::uint32_t>{0});
  CHECK(lasers[1].scan.valid_count() == 0);
  CHECK(lasers[3].scan.ranges() == std::vector<double>{1, 2, 3, 40, 0.5});
  CHECK(lasers[3].scan.valid_indices() == std::vector<std::uint32_t>{0});
}

TEST_CASE("CarmenReader rejects bad options with exact messages", "[io][carmen]") {
  TempDir dir;
  const auto path = dir.write("empty.clf", "");
  CHECK_THROWS_AS(CarmenReader(path, {.range_max = 0.0}), invalid_argument);
  CHECK_THROWS_WITH(CarmenReader(path, {.range_max = 0.0}),
                    "rangenav: CarmenReader: argument 'options.range_max' = 0 must be finite "
                    "and > 0");
  CHECK_THROWS_WITH((CarmenReader(path, {.range_max = 1.0, .range_min = 2.0})),
                    "rangenav: CarmenReader: argument 'options.range_max' = 1 must exceed "
                    "options.range_min = 2");
  CHECK_THROWS_WITH(CarmenReader(path, {.range_min = -1.0}),
                    "rangenav: CarmenReader: argument 'options.range_min' = -1 must be finite "
                    "and >= 0");
  // The options are checked before the file is opened.
  CHECK_THROWS_AS(CarmenReader(dir.path() / "missing.clf", {.range_max = -1.0}), invalid_argument);
}

TEST_CASE("CarmenReader: empty and comment-only files give no records", "[io][carmen]") {
  TempDir dir;
  CHECK(read_all(dir.write("empty.clf", "")).empty());
  CHECK(read_all(dir.write("comments.clf", "# only\n\n   \n#PARAM x 1\nNEFF 1\n")).empty());
}

TEST_CASE("CarmenReader: malformed lines raise io_error naming file and line", "[io][carmen]") {
  TempDir dir;
  const auto check = [&](const std::string& content, const std::string& expected) {
    const auto path = dir.write("bad.clf", content);
    CHECK(message_of(path) == "rangenav: carmen: " + path.string() + ":" + expected);
  };
  const std::string ok = "# header\nODOM 0 0 0 0 0 0 1 h 1\n";
  std::string short_flaser = "FLASER 361";
  for (int i = 0; i < 40 + 9; ++i)
    short_flaser += " 1";
  check(ok + short_flaser + "\n", "3: FLASER: expected 361 ranges, found 40");
  check(ok + "FLASER 3 1 2 3 4 0 0 0 0 0 0 1 h 1\n", "3: FLASER: expected 3 ranges, found 4");
  check(ok + "FLASER 3 1 2\n",
        "3: FLASER: too few fields: expected 12 after the beam count, found 2");
  check(ok + "FLASER\n", "3: FLASER: missing the beam count");
  check(ok + "FLASER x 1\n", "3: FLASER: field 2 is not a count: 'x'");
  check(ok + "FLASER -3 1\n", "3: FLASER: field 2 is not a count: '-3'");
  check(ok + "FLASER 3 1 2 abc 0 0 0 0 0 0 1 h 1\n", "3: FLASER: field 5 is not a number: 'abc'");
  check(ok + "FLASER 3 1 2 3 0 0 0 0 0 0 1.5.2 h 1\n",
        "3: FLASER: field 12 is not a number: '1.5.2'");
  check(ok + "FLASER 0 0 0 0 0 0 0 1 h 1\n",
        "3: FLASER: LaserScan: argument 'beam_count' = 0 must be > 0");
  check(ok + "ODOM 1 2 3\n", "3: ODOM: expected 9 fields, found 3");
  check(ok + "ODOM 1 2 3 4 5 6 7 h 8 9\n", "3: ODOM: expected 9 fields, found 10");
  check(ok + "ODOM 1 2 3 4 5 6 7 h x\n", "3: ODOM: field 10 is not a number: 'x'");
  check(ok + "RAWLASER1 0 -1.5 3 0.75 30 0.01 0 2 1 2 3 5 6 1 h 1\n",
        "3: RAWLASER1: expected 3 remissions, found 2");
  check(ok + "RAWLASER1 0 -1.5 3 0.75 30 0.01 0 5 1 2 0 1 h 1\n",
        "3: RAWLASER1: expected 5 ranges, found 2");
  check(ok + "RAWLASER1 0 -1.5 3 0.75 30 0.01\n",
        "3: RAWLASER1: too few fields: expected at least 12, found 6");
  check(ok + "RAWLASER1 0 -1.5 3 0 30 0.01 0 2 1 2 0 1 h 1\n",
        "3: RAWLASER1: LaserScan: argument 'angle_increment' = 0 must be finite and > 0");
  check(ok + "RAWLASER2 0 -1.5 3 0.5 0 0.01 0 2 1 2 0 1 h 1\n",
        "3: RAWLASER2: max range 0 must exceed range_min 0 (set CarmenReaderOptions::range_max "
        "to override)");
  check(ok + "ROBOTLASER1 0 -1.5 3 0.5 20 0.01 0 2 1 2 0 1 2 3 4 5 6 7 8 9 10 x 1 h 1\n",
        "3: ROBOTLASER1: field 23 is not a number: 'x'");
  check(ok + "PARAM robot_front_laser_max big h 1\n",
        "3: PARAM: robot_front_laser_max: value 'big' is not a positive number");
  check(ok + "PARAM lonely\n", "3: PARAM: expected a name and a value");
  // A truncated last line (no newline) says so.
  check(ok + "FLASER 3 1 2 3 0 0 0 0",
        "3: FLASER: too few fields: expected 12 after the "
        "beam count, found 7 (unterminated last line: "
        "truncated file?)");
  // A complete last line without a newline is fine.
  CHECK(read_all(dir.write("last.clf", ok + "ODOM 1 2 3 4 5 6 7 h 8")).size() == 2);
}

TEST_CASE("CarmenReader: a missing file raises io_error naming the path", "[io][carmen]") {
  TempDir dir;
  const auto path = dir.path() / "does_not_exist.clf";
  CHECK_THROWS_AS(CarmenReader(path), io_error);
  CHECK_THROWS_WITH(CarmenReader(path), "rangenav: carmen: " + path.string() +
                                            ": cannot open file: No such file or directory");
}

TEST_CASE("CarmenReader reads gzip logs, detected by magic bytes", "[io][carmen]") {
  TempDir dir;
  const auto plain = dir.write("sample.clf", sample_log);
  // A name without ".gz": detection must look at the content.
  const auto gz_path = dir.path() / "sample_gz.clf";
#ifdef RANGENAV_HAVE_ZLIB
  {
    gzFile gz = gzopen(gz_path.c_str(), "wb9");
    REQUIRE(gz != nullptr);
    REQUIRE(gzwrite(gz, sample_log.data(), static_cast<unsigned>(sample_log.size())) ==
            static_cast<int>(sample_log.size()));
    REQUIRE(gzclose(gz) == Z_OK);
  }
  const auto expected = read_carmen_lasers(plain);
  const auto got = read_carmen_lasers(gz_path);
  REQUIRE(got.size() == expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    CHECK(got[i].type == expected[i].type);
    CHECK(got[i].line == expected[i].line);
    CHECK(got[i].timestamp == expected[i].timestamp);
    CHECK(got[i].host == expected[i].host);
    CHECK(got[i].scan.range_max() == expected[i].scan.range_max());
    CHECK(got[i].scan.valid_indices() == expected[i].scan.valid_indices());
    CHECK(got[i].scan.intensities() == expected[i].scan.intensities());
  }
  CHECK(read_all(gz_path).size() == read_all(plain).size());

  // A gzip stream cut in half is reported, not silently shortened.
  std::string bytes;
  {
    std::ifstream in(gz_path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto cut = dir.write("cut.clf.gz", bytes.substr(0, bytes.size() / 2));
  CHECK(message_of(cut) == "rangenav: carmen: " + cut.string() + ": gzip: unexpected end of file");
#else
  const auto gz = dir.write("sample_gz.clf", std::string("\x1f\x8b\x08\x00", 4));
  CHECK(message_of(gz) == "rangenav: carmen: " + gz.string() +
                              ": gzip-compressed file, but rangenav was built without zlib "
                              "(RANGENAV_HAVE_ZLIB)");
  (void)plain;
#endif
}

namespace {

// "x y theta" as a log writes it (17 significant digits: the poses are read back exactly).
std::string pose_fields(const Pose2d& p) {
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "%.17g %.17g %.17g", p.x, p.y, p.theta);
  return buffer;
}

}  // namespace

TEST_CASE("read_carmen_scan_log keeps one laser with the odometry of its frame", "[io][carmen]") {
  // A robot turns on a circle; its front laser sits 0.3 m ahead of the axle and its rear laser
  // 0.2 m behind it, looking backwards. CARMEN writes each laser's pose (the robot's odometry
  // with the mounting offset) and the robot's odometry pose into every FLASER / RLASER record.
  const Pose2d front{0.3, 0.0, 0.0}, rear{-0.2, 0.0, pi};
  std::vector<Pose2d> robot;
  for (int i = 0; i < 4; ++i)
    robot.push_back({2.0 * std::sin(0.3 * i), 2.0 - 2.0 * std::cos(0.3 * i), 0.3 * i});
  std::string text = "# front and rear laser\n";
  const auto laser_line = [&](const char* tag, const Pose2d& laser, const Pose2d& odometry) {
    text.append(tag).append(" 3 1 2 3 ").append(pose_fields(laser)).append(" ");
    text.append(pose_fields(odometry)).append(" 100 host 0\n");
  };
  for (std::size_t i = 0; i < robot.size(); ++i) {
    laser_line("FLASER", robot[i] * front, robot[i]);
    if (i % 2 == 0) laser_line("RLASER", robot[i] * rear, robot[i]);
    text.append("ODOM ").append(pose_fields(robot[i])).append(" 0 0 0 100 host 0\n");
  }
  TempDir dir;
  const auto path = dir.write("two_lasers.clf", text);

  // The laser with the most records; the other's are counted, not mixed in.
  const CarmenScanLog log = read_carmen_scan_log(path);
  CHECK(log.laser == CarmenLaserType::flaser);
  REQUIRE(log.records.size() == 4);
  REQUIRE(log.odometry.size() == 4);
  CHECK(log.other_laser_records == 2);
  for (std::size_t i = 0; i < robot.size(); ++i) {
    CHECK(log.records[i].type == CarmenLaserType::flaser);
    REQUIRE(log.odometry[i]);
    CHECK(*log.odometry[i] == *log.records[i].laser_pose);
    // Ground truth: the laser frame moves by front⁻¹ (robot step) front, which differs from
    // the robot's step by the offset's lever arm on the turn.
    if (i == 0) continue;
    const Pose2d step = relative(*log.odometry[i - 1], *log.odometry[i]);
    const Pose2d truth = inverse(front) * relative(robot[i - 1], robot[i]) * front;
    CHECK(step.x == Approx(truth.x).margin(1e-12));
    CHECK(step.y == Approx(truth.y).margin(1e-12));
    CHECK(step.theta == Approx(truth.theta).margin(1e-12));
    const Pose2d robot_step = relative(robot[i - 1], robot[i]);
    CHECK(std::hypot(step.x - robot_step.x, step.y - robot_step.y) > 0.05);
  }

  // The rear laser on request: its own frame, looking backwards.
  const CarmenScanLog rear_log = read_carmen_scan_log(path, CarmenLaserType::rlaser);
  CHECK(rear_log.laser == CarmenLaserType::rlaser);
  REQUIRE(rear_log.records.size() == 2);
  CHECK(rear_log.other_laser_records == 4);
  const Pose2d rear_pose = *rear_log.odometry[1];
  CHECK(rear_pose.theta == Approx(normalize_angle(robot[2].theta + pi)));
  CHECK((rear_pose.position() - (robot[2] * rear).position()).norm() < 1e-12);
}

TEST_CASE("read_carmen_scan_log: raw lasers take the last ODOM before them in file order",
          "[io][carmen]") {
  // ROBOTLASER1 and RAWLASER1 of the same scans (two records each), ODOM between them, and
  // timestamps that run backwards: file order decides, not time.
  const std::string raw = "RAWLASER1 0 -1.5 3.0 1.5 30 0.01 0 3 1 2 3 0 ";
  const std::string robot_laser =
      "ROBOTLASER1 0 -1.5 3.0 1.5 30 0.01 0 3 1 2 3 0 0.5 0.25 0.125 0.25 0.25 0.125 0 0 0 0 0 ";
  std::string text;
  text.append(raw).append("50 a 0\n");
  text.append("ODOM 1.5 -2 0.25 0 0 0 40 a 0\n");
  text.append(raw).append("30 a 0\n").append(robot_laser).append("20 a 0\n");
  text.append("ODOM 2.5 -1 0.5 0 0 0 10 a 0\n");
  text.append(robot_laser).append("0 a 0\n").append(raw).append("0 a 0\n");
  TempDir dir;
  const auto path = dir.write("raw.clf", text);

  // Two ROBOTLASER1 records, three RAWLASER1: the raw laser has the most.
  const CarmenScanLog log = read_carmen_scan_log(path);
  CHECK(log.laser == CarmenLaserType::rawlaser1);
  CHECK(to_string(log.laser) == "RAWLASER1");
  REQUIRE(log.odometry.size() == 3);
  CHECK(log.other_laser_records == 2);
  CHECK_FALSE(log.odometry[0]);  // before the first ODOM record
  CHECK(log.odometry[1] == Pose2d{1.5, -2, 0.25});
  CHECK(log.odometry[2] == Pose2d{2.5, -1, 0.5});

  // ROBOTLASER1 carries its laser pose beside the robot pose: the laser pose is taken.
  const CarmenScanLog with_poses = read_carmen_scan_log(path, CarmenLaserType::robotlaser1);
  REQUIRE(with_poses.odometry.size() == 2);
  CHECK(with_poses.odometry[0] == Pose2d{0.5, 0.25, 0.125});
  CHECK(with_poses.odometry[1] == Pose2d{0.5, 0.25, 0.125});

  // A laser the log does not have, and an empty log: no records, no error.
  CHECK(read_carmen_scan_log(path, CarmenLaserType::flaser).records.empty());
  const CarmenScanLog empty = read_carmen_scan_log(dir.write("empty.clf", "# nothing\n"));
  CHECK(empty.records.empty());
  CHECK(empty.other_laser_records == 0);
}

TEST_CASE("carmen_laser_type and to_string name the record tags both ways", "[io][carmen]") {
  // The seven tags of the CARMEN log format, in CarmenLaserType's order.
  const std::vector<std::pair<std::string, CarmenLaserType>> tags{
      {"FLASER", CarmenLaserType::flaser},           {"RLASER", CarmenLaserType::rlaser},
      {"ROBOTLASER1", CarmenLaserType::robotlaser1}, {"RAWLASER1", CarmenLaserType::rawlaser1},
      {"RAWLASER2", CarmenLaserType::rawlaser2},     {"RAWLASER3", CarmenLaserType::rawlaser3},
      {"RAWLASER4", CarmenLaserType::rawlaser4}};
  REQUIRE(tags.size() == carmen_laser_type_count);
  for (const auto& [tag, type] : tags) {
    CHECK(carmen_laser_type(tag) == type);
    CHECK(to_string(type) == tag);
  }
  // Other words of a log, lower case, prefixes and a laser number the format lacks.
  for (const char* word : {"ODOM", "PARAM", "flaser", "FLASE", "FLASER1", "RAWLASER5", ""})
    CHECK_FALSE(carmen_laser_type(word));
  static_assert(carmen_laser_type("RLASER") == CarmenLaserType::rlaser);
}

TEST_CASE("CarmenReader reads the MIT CSAIL benchmark log", "[io][carmen][data]") {
  const auto path = gz_data_file_or_skip("carmen/mit-csail.clf.gz");
  if (path.empty()) return;
  const auto lasers = read_carmen_lasers(path);
  REQUIRE(lasers.size() == 1988);
  std::size_t valid = 0, no_return = 0;
  for (const auto& laser : lasers) {
    REQUIRE(laser.type == CarmenLaserType::flaser);
    REQUIRE(laser.scan.size() == 361);
    for (std::size_t i = 0; i < 361; ++i) {
      if (laser.scan.range(i) == 81.91) {
        ++no_return;
        REQUIRE_FALSE(laser.scan.is_valid(i));
      }
    }
    valid += laser.scan.valid_count();
  }
  // Counted independently with awk over the uncompressed log.
  CHECK(no_return == 23711);
  CHECK(valid == 693957);
  const auto& first = lasers.front();
  CHECK(first.timestamp == 1134864629.895182);
  CHECK(first.host == "b21");
  CHECK(first.logger_timestamp == 0.086295);
  CHECK(first.line == 4);
  CHECK(first.scan.range(0) == 1.40);
  CHECK(*first.laser_pose == Pose2d{576.536523, 0.106594, -2.255213});
  CHECK(*first.odom_pose == Pose2d{576.536523, 0.106594, -2.255213});
  CHECK(first.scan.angle_increment() == Approx(deg_to_rad(0.5)));
  CHECK(first.scan.angle_max() == Approx(pi / 2));
  const auto& last = lasers.back();
  CHECK(last.timestamp == 1134865053.892206);
  CHECK(last.logger_timestamp == 424.077432);
  CHECK(last.scan.range(0) == 3.98);
  CHECK(last.scan.range(360) == 2.21);
  CHECK(*last.odom_pose == Pose2d{597.816512, -3.220376, -1.412351});
  CHECK(last.line == 1991);
}

TEST_CASE("CarmenReader reads the four corrected Radish logs", "[io][carmen][data]") {
  struct Log {
    const char* name;
    std::size_t flaser, odom, beams, valid;
    double range_max;
  };
  // FLASER / ODOM counts from PROVENANCE.md; valid beams (0 < r < max range) counted with awk.
  // intel marks "no return" with 81.83 (4172 readings, the largest of the log) and says so
  // nowhere: the reader recognises that value as its saturation (tests/io/carmen_saturation.cpp).
  for (const Log log : {Log{"intel", 910, 14541, 180, 163800 - 4172, 81.83},
                        Log{"freiburg-079", 4791, 9725, 360, 1688756, 80.99},
                        Log{"freiburg-101", 292, 4569, 360, 92565, 80.99},
                        Log{"csail", 406, 2394, 361, 142659, 50.0}}) {
    const auto path =
        gz_data_file_or_skip(std::string("carmen_corrected/") + log.name + "-corrected.log.gz");
    if (path.empty()) return;
    INFO(log.name);
    CarmenReader reader(path);
    std::size_t flaser = 0, odom = 0, valid = 0;
    while (auto record = reader.next()) {
      if (const auto* laser = std::get_if<CarmenLaser>(&*record)) {
        ++flaser;
        CHECK(laser->scan.size() == log.beams);
        CHECK(laser->scan.range_max() == log.range_max);
        // Corrected logs store the corrected pose in both triplets.
        CHECK(*laser->laser_pose == *laser->odom_pose);
        valid += laser->scan.valid_count();
      } else {
        ++odom;
      }
    }
    CHECK(flaser == log.flaser);
    CHECK(odom == log.odom);
    CHECK(valid == log.valid);
  }
  // An explicit range_max below 81.83 drops the same readings.
  const auto intel = gz_data_file_or_skip("carmen_corrected/intel-corrected.log.gz");
  if (intel.empty()) return;
  std::size_t valid = 0;
  for (const auto& laser : read_carmen_lasers(intel, {.range_max = 81.0}))
    valid += laser.scan.valid_count();
  CHECK(valid == 163800 - 4172);
}
