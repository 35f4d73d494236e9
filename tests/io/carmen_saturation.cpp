// CARMEN logs that encode "no return" as the scanner's largest reading without saying so (issue 19
// §4): 50.0, 51.2, 32.767 m as well as the 81.91 of the shared logs. Synthetic logs of a robot
// driving through a room whose doorway opens onto nothing: every beam that leaves through the
// doorway carries the log's saturation value, every other beam the range to the wall the
// simulator's ray cast finds (rounded as the log prints it). The reader must recognise the
// value, so that no beam at it is valid, keep every real reading, and not take a real reading
// for a saturation value.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>
#include <variant>
#include <vector>

#include "rangenav/io/carmen.hpp"
#include "rangenav/sim/world.hpp"
#include "scratch_dir.hpp"

using namespace rangenav;
using namespace rangenav::io;

namespace {

constexpr double pi = std::numbers::pi;

struct TempDir : rangenav::test::ScratchDir {
  TempDir() : ScratchDir("carmen_sat") {}
};

/// A 10 x 6 m room; the wall at x = 10 has a 2 m doorway (y in [2, 4]) onto nothing.
sim::World room() {
  sim::World w;
  w.add_wall({0, 0}, {10, 0});
  w.add_wall({0, 6}, {10, 6});
  w.add_wall({0, 0}, {0, 6});
  w.add_wall({10, 0}, {10, 2});
  w.add_wall({10, 4}, {10, 6});
  w.build_index();
  return w;
}

struct Log {
  std::string text;
  std::size_t saturated = 0;  ///< beams that carry the saturation value
  std::size_t real = 0;       ///< beams with a real reading (> 0)
};

/// `scans` FLASER records of 181 beams, printed with `decimals` decimals; the first `still`
/// scans from the start pose (a robot that waits before it drives). Beams without a wall within
/// 100 m read `saturation`. `stamp(k)` is the timestamp of scan k.
template <class Stamp>
Log make_log(double saturation, int decimals, int scans, int still, Stamp&& stamp,
             double noise = 0.005) {
  const sim::World world = room();
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0.0, noise);
  Log log;
  log.text = "# synthetic log, no PARAM line\n";
  char buffer[64];
  for (int k = 0; k < scans; ++k) {
    const int moving = std::max(0, k - still);
    const Pose2d pose{2.0 + 0.15 * moving, 3.0 + 0.05 * std::sin(moving), 0.02 * moving};
    std::string line = "FLASER 181";
    for (int i = 0; i < 181; ++i) {
      const double bearing = pose.theta - pi / 2 + i * pi / 180;
      const auto hit =
          world.cast_ray_2d({pose.x, pose.y}, {std::cos(bearing), std::sin(bearing)}, 0.5, 100.0);
      double r = saturation;
      if (hit.hit() && (saturation <= 0 || hit.range < saturation)) {
        r = hit.range + n(rng);
        ++log.real;
      } else {
        ++log.saturated;
      }
      std::snprintf(buffer, sizeof(buffer), " %.*f", decimals, r);
      line += buffer;
    }
    for (int rep = 0; rep < 2; ++rep) {
      std::snprintf(buffer, sizeof(buffer), " %.6f %.6f %.6f", pose.x, pose.y, pose.theta);
      line += buffer;
    }
    std::snprintf(buffer, sizeof(buffer), " %.6f host %.6f\n", stamp(k), stamp(k));
    line += buffer;
    log.text += line;
  }
  return log;
}

struct Counts {
  std::size_t valid = 0;
  std::size_t valid_at_saturation = 0;
  std::size_t scans = 0;
  std::vector<double> range_max;
};

Counts read_counts(const std::filesystem::path& path, double saturation,
                   CarmenReaderOptions options = {}) {
  Counts c;
  for (const auto& laser : read_carmen_lasers(path, options)) {
    ++c.scans;
    c.valid += laser.scan.valid_count();
    c.range_max.push_back(laser.scan.range_max());
    for (const auto i : laser.scan.valid_indices())
      if (laser.scan.range(i) == saturation) ++c.valid_at_saturation;
  }
  return c;
}

}  // namespace

TEST_CASE("CARMEN saturation: each encoding is recognised, from the first scan on",
          "[io][carmen][saturation]") {
  TempDir dir;
  struct Encoding {
    double value;
    int decimals;
  };
  for (const Encoding e : {Encoding{50.0, 2}, Encoding{51.2, 2}, Encoding{32.767, 3},
                           Encoding{81.91, 2}, Encoding{50.0, 1}}) {
    INFO("saturation " << e.value << " printed with " << e.decimals << " decimals");
    // Five scans from the start pose first: they must not become walls at the saturation range.
    const Log log = make_log(e.value, e.decimals, 30, 5, [](int k) { return 100.0 + 0.1 * k; });
    REQUIRE(log.saturated > 30 * 10);  // the doorway is in view all along
    const auto path = dir.write("log.clf", log.text);
    CarmenReader reader(path);
    std::size_t scans = 0;
    Counts c;
    while (auto record = reader.next()) {
      const auto& laser = std::get<CarmenLaser>(*record);
      ++scans;
      c.valid += laser.scan.valid_count();
      for (const auto i : laser.scan.valid_indices())
        if (laser.scan.range(i) == e.value) ++c.valid_at_saturation;
      if (e.value < CarmenReader::default_range_max) CHECK(laser.scan.range_max() == e.value);
    }
    CHECK(scans == 30);
    CHECK(c.valid_at_saturation == 0);
    CHECK(c.valid == log.real);  // every real reading kept
    REQUIRE(reader.saturation(CarmenLaserType::flaser));
    CHECK(*reader.saturation(CarmenLaserType::flaser) == e.value);
    CHECK_FALSE(reader.saturation(CarmenLaserType::rlaser));

    // Off, or overridden by range_max: the readings at the value are beams like any other.
    if (e.value < CarmenReader::default_range_max) {
      const Counts off = read_counts(path, e.value, {.detect_saturation = false});
      CHECK(off.valid_at_saturation == log.saturated);
    }
    const Counts fixed = read_counts(path, e.value, {.range_max = 200.0});
    CHECK(fixed.valid_at_saturation == log.saturated);
    CHECK(fixed.range_max.front() == 200.0);
  }
}

TEST_CASE("CARMEN saturation: zero, negative and rounded timestamps read as they are",
          "[io][carmen][saturation]") {
  TempDir dir;
  for (const auto& [name, stamp] : std::vector<std::pair<std::string, double (*)(int)>>{
           {"zero", [](int) { return 0.0; }},
           {"negative", [](int k) { return -50.0 + 0.1 * k; }},
           {"rounded (repeated)", [](int k) { return std::round(1.13486e9 + 0.1 * k); }},
           {"decreasing", [](int k) { return 10.0 - k; }}}) {
    INFO(name);
    const Log log = make_log(50.0, 2, 12, 0, stamp);
    const auto path = dir.write("log.clf", log.text);
    const auto lasers = read_carmen_lasers(path);
    REQUIRE(lasers.size() == 12);
    std::size_t valid = 0;
    for (std::size_t k = 0; k < lasers.size(); ++k) {
      CHECK(lasers[k].timestamp == Approx(stamp(static_cast<int>(k))).margin(1e-6));
      CHECK(lasers[k].scan.range_max() == 50.0);
      valid += lasers[k].scan.valid_count();
    }
    CHECK(valid == log.real);
  }
}

TEST_CASE("CARMEN saturation: a real reading is not taken for one", "[io][carmen][saturation]") {
  TempDir dir;
  // No-return beams read 0 here: the largest readings are real walls, cm-rounded. A robot that
  // stands still repeats its farthest readings exactly, scan after scan: that is no evidence.
  const Log still = make_log(
      0.0, 2, 40, 40, [](int k) { return 0.1 * k; }, 0.0);
  const auto path = dir.write("still.clf", still.text);
  CarmenReader reader(path);
  std::size_t valid = 0;
  while (auto record = reader.next())
    valid += std::get<CarmenLaser>(*record).scan.valid_count();
  CHECK(valid == still.real);
  CHECK_FALSE(reader.saturation(CarmenLaserType::flaser));
  // Moving, the farthest reading changes from scan to scan.
  const Log moving = make_log(0.0, 2, 40, 0, [](int k) { return 0.1 * k; });
  CHECK(read_counts(dir.write("moving.clf", moving.text), 0.0).valid == moving.real);
}

TEST_CASE("CARMEN saturation: a larger reading revokes a value taken for one",
          "[io][carmen][saturation]") {
  TempDir dir;
  // Streaming without lookahead: three scans from different poses repeat 30.0 on several beams
  // (recognised), then a scan reads 35.0 (revoked: 30.0 was a real reading after all).
  std::string text;
  const auto flaser = [](double x, const std::string& ranges) {
    return "FLASER 6 " + ranges + " " + std::to_string(x) + " 0 0 " + std::to_string(x) +
           " 0 0 1 h 1\n";
  };
  for (int k = 0; k < 3; ++k)
    text += flaser(0.5 * k, "1 2 30 30 3 4");
  text += flaser(2.0, "1 2 30 30 35 4");
  text += flaser(2.5, "1 2 30 30 3 4");
  const auto path = dir.write("revoke.clf", text);
  const auto lasers = read_carmen_lasers(path, {.saturation_lookahead = 0});
  REQUIRE(lasers.size() == 5);
  CHECK(lasers[0].scan.valid_count() == 6);  // one scan of evidence: not yet
  CHECK(lasers[1].scan.valid_count() == 6);
  CHECK(lasers[2].scan.valid_count() == 4);  // the third: 30.0 is no-return from here on
  CHECK(lasers[3].scan.valid_count() == 6);  // 35.0: 30.0 was real, and so is 35.0
  CHECK(lasers[4].scan.valid_count() == 6);
  // With the lookahead (the default) the whole log is seen first: nothing is dropped.
  for (const auto& laser : read_carmen_lasers(path))
    CHECK(laser.scan.valid_count() == 6);
}

TEST_CASE(
    "CARMEN saturation: each laser has its own value; a malformed line is reported after "
    "the records before it",
    "[io][carmen][saturation]") {
  TempDir dir;
  const Log front = make_log(50.0, 2, 10, 0, [](int k) { return 1.0 * k; });
  // A rear laser on the same log whose no-return reads 0 (no saturation value).
  std::string text = front.text;
  for (int k = 0; k < 5; ++k)
    text += "RLASER 4 1.5 2.5 0 3.5 " + std::to_string(0.3 * k) + " 0 0 0 0 0 " +
            std::to_string(20 + k) + " h 1\n";
  text += "FLASER 2 1 nan_pose\n";
  const auto path = dir.write("two.clf", text);
  CarmenReader reader(path);
  std::size_t flaser = 0, rlaser = 0;
  std::string error;
  try {
    while (auto record = reader.next()) {
      const auto& laser = std::get<CarmenLaser>(*record);
      if (laser.type == CarmenLaserType::flaser) {
        ++flaser;
        CHECK(laser.scan.range_max() == 50.0);
      } else {
        ++rlaser;
        CHECK(laser.scan.range_max() == CarmenReader::default_range_max);
        CHECK(laser.scan.valid_count() == 3);
      }
    }
  } catch (const io_error& e) {
    error = e.what();
  }
  CHECK(flaser == 10);
  CHECK(rlaser == 5);
  CHECK(error == "rangenav: carmen: " + path.string() +
                     ":17: FLASER: too few fields: expected 11 after the beam count, found 2");
}
