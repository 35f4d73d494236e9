#pragma once
// CarmenReader: streams the laser and odometry records of a CARMEN log (.clf / .log, plain or
// gzip-compressed) line by line, as used by the Radish and Freiburg SLAM-benchmark data sets.
//
// Records understood (whitespace-separated fields; the record tag is field 1):
//   FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp
//   RLASER (same as FLASER, rear laser)
//   ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp
//   RAWLASER1..4 laser_type start_angle fov angular_resolution max_range accuracy
//       remission_mode n r1..rn m rem1..remm ipc_timestamp host logger_timestamp
//   ROBOTLASER1 laser_type start_angle fov angular_resolution max_range accuracy remission_mode
//       n r1..rn m rem1..remm laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv
//       forward_safety_dist side_safety_dist turn_axis ipc_timestamp host logger_timestamp
//   PARAM name value ...   (the value is the token after the name; the rest is ignored)
// Comments ('#'), blank lines and every other record type (NEFF, SYNC, TRUEPOS, ...) are skipped.
//
// FLASER/RLASER carry no beam layout: it follows CARMEN's readlog convention
// (carmen_laser_guess_fov / _angle_increment): start angle -pi/2 and an increment of 1 deg for
// 180/181 beams, 0.5 deg for 360/361, 0.25 deg for 400/401, otherwise pi/(n-1).
//
// Maximum range, first that applies (readings at or beyond it are invalid beams, not errors):
//   1. CarmenReaderOptions::range_max when set;
//   2. RAWLASER/ROBOTLASER: the record's max_range field;
//      FLASER/RLASER: the last PARAM robot_front_laser_max / robot_rear_laser_max seen so far;
//   3. 81.9 m, so the SICK "no return" reading 81.91 of the MIT and Freiburg logs is invalid.
// Note: intel-corrected.log marks "no return" with 81.83; pass range_max = 81.0 to drop those.
//
// A malformed line (too few fields, a non-numeric field, a count that does not match) raises
// io_error naming the file and the 1-based line, e.g.
//   rangenav: carmen: mit.clf:12: FLASER: expected 361 ranges, found 40

#include <cmath>
#include <cstddef>
#include <filesystem>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/io/line_reader.hpp"
#include "rangenav/scan/laser_scan.hpp"

namespace rangenav::io {

enum class CarmenLaserType {
  flaser,
  rlaser,
  robotlaser1,
  rawlaser1,
  rawlaser2,
  rawlaser3,
  rawlaser4
};

/// One laser record: the scan plus the poses the record carries.
struct CarmenLaser {
  CarmenLaserType type{CarmenLaserType::flaser};
  LaserScan<double> scan;            ///< scan.timestamp() is the ipc timestamp
  std::optional<Pose2d> laser_pose;  ///< FLASER/RLASER "x y theta", ROBOTLASER1 laser pose
  std::optional<Pose2d> odom_pose;   ///< FLASER/RLASER "odom_x odom_y odom_theta",
                                     ///< ROBOTLASER1 robot pose
  double timestamp{0.0};             ///< ipc timestamp (s)
  std::string host;
  double logger_timestamp{0.0};  ///< logger timestamp (s)
  std::size_t line{0};           ///< 1-based line in the log
};

/// One ODOM record.
struct CarmenOdometry {
  Pose2d pose;
  double tv{0.0};     ///< translational velocity (m/s)
  double rv{0.0};     ///< rotational velocity (rad/s)
  double accel{0.0};  ///< acceleration (m/s^2)
  double timestamp{0.0};
  std::string host;
  double logger_timestamp{0.0};
  std::size_t line{0};
};

using CarmenRecord = std::variant<CarmenLaser, CarmenOdometry>;

/// How the reader builds scans; see the maximum-range precedence at the top of this file.
struct CarmenReaderOptions {
  /// Overrides every other source of the maximum range when set (m, > range_min).
  std::optional<double> range_max{};
  /// Readings below it are invalid beams (m, >= 0).
  double range_min = 0.0;
};

/// Streaming reader: holds one buffer of the file at a time, never the whole log.
class CarmenReader {
 public:
  /// The maximum range when neither the options nor the log say otherwise (m).
  static constexpr double default_range_max = 81.9;

  /// Opens the log. Throws invalid_argument for bad options (checked first) and io_error when
  /// the file cannot be opened (or is gzip-compressed and zlib is missing).
  explicit CarmenReader(const std::filesystem::path& path, CarmenReaderOptions options = {})
      : options_(validated(options)), lines_(path, "carmen") {}

  /// The next laser or odometry record, or nullopt at the end of the file.
  std::optional<CarmenRecord> next() {
    std::string_view line;
    while (lines_.next(line)) {
      detail::split_whitespace(line, tokens_);
      if (tokens_.empty() || tokens_[0].front() == '#') continue;
      const std::string_view tag = tokens_[0];
      if (tag == "FLASER") return CarmenRecord{parse_old_laser(CarmenLaserType::flaser)};
      if (tag == "RLASER") return CarmenRecord{parse_old_laser(CarmenLaserType::rlaser)};
      if (tag == "ODOM") return CarmenRecord{parse_odometry()};
      if (tag == "ROBOTLASER1") return CarmenRecord{parse_new_laser(CarmenLaserType::robotlaser1)};
      if (tag == "RAWLASER1") return CarmenRecord{parse_new_laser(CarmenLaserType::rawlaser1)};
      if (tag == "RAWLASER2") return CarmenRecord{parse_new_laser(CarmenLaserType::rawlaser2)};
      if (tag == "RAWLASER3") return CarmenRecord{parse_new_laser(CarmenLaserType::rawlaser3)};
      if (tag == "RAWLASER4") return CarmenRecord{parse_new_laser(CarmenLaserType::rawlaser4)};
      if (tag == "PARAM") parse_param();
    }
    return std::nullopt;
  }

  /// The PARAM lines seen so far (name -> value).
  [[nodiscard]] const std::map<std::string, std::string>& params() const { return params_; }

  /// The path of the log.
  [[nodiscard]] const std::filesystem::path& path() const { return lines_.path(); }

 private:
  static CarmenReaderOptions validated(const CarmenReaderOptions& options) {
    ::rangenav::detail::require_non_negative("CarmenReader", "options.range_min",
                                             options.range_min);
    if (options.range_max) {
      ::rangenav::detail::require_positive("CarmenReader", "options.range_max", *options.range_max);
      if (!(*options.range_max > options.range_min))
        ::rangenav::detail::throw_invalid_argument(
            "CarmenReader", "options.range_max", *options.range_max,
            "must exceed options.range_min = " +
                ::rangenav::detail::format_value(options.range_min));
    }
    return options;
  }

  [[noreturn]] void fail(std::string_view message) const {
    lines_.fail_line(std::string(tokens_[0]) + ": " + std::string(message));
  }

  // Field numbers in messages are 1-based with the tag as field 1.
  double number(std::size_t index) const {
    double value = 0.0;
    if (!detail::parse_double(tokens_[index], value))
      fail("field " + std::to_string(index + 1) + " is not a number: '" +
           std::string(tokens_[index]) + "'");
    return value;
  }

  std::size_t count(std::size_t index) const {
    std::size_t value = 0;
    if (!detail::parse_count(tokens_[index], value))
      fail("field " + std::to_string(index + 1) + " is not a count: '" +
           std::string(tokens_[index]) + "'");
    return value;
  }

  Pose2d pose(std::size_t index) const {
    return {number(index), number(index + 1), number(index + 2)};
  }

  std::vector<double> numbers(std::size_t first, std::size_t n) const {
    std::vector<double> values(n);
    for (std::size_t i = 0; i < n; ++i)
      values[i] = number(first + i);
    return values;
  }

  // Reads "ipc_timestamp host logger_timestamp" starting at `index`.
  template <class Record>
  void stamp(Record& record, std::size_t index) const {
    record.timestamp = number(index);
    record.host = std::string(tokens_[index + 1]);
    record.logger_timestamp = number(index + 2);
    record.line = lines_.line_number();
  }

  LaserScan<double> make_scan(double angle_min, double angle_increment, double range_max,
                              std::vector<double> ranges, std::vector<double> intensities,
                              double timestamp) const {
    if (options_.range_max) range_max = *options_.range_max;
    if (!(std::isfinite(range_max) && range_max > options_.range_min))
      fail("max range " + ::rangenav::detail::format_value(range_max) + " must exceed range_min " +
           ::rangenav::detail::format_value(options_.range_min) +
           " (set CarmenReaderOptions::range_max to override)");
    const std::size_t n = ranges.size();
    try {
      return LaserScan<double>(
          ScanGeometry<double>{angle_min, angle_increment, n, options_.range_min, range_max},
          std::move(ranges), std::move(intensities), timestamp);
    } catch (const invalid_argument& e) {
      std::string_view what = e.what();
      if (what.starts_with("rangenav: ")) what.remove_prefix(10);
      fail(what);
    }
  }

  // carmen_laser_guess_angle_increment of CARMEN's readlog.
  static double old_laser_increment(std::size_t n) {
    constexpr double pi = std::numbers::pi;
    if (n == 180 || n == 181) return pi / 180.0;
    if (n == 360 || n == 361) return pi / 360.0;
    if (n == 400 || n == 401) return pi / 720.0;
    return n > 1 ? pi / static_cast<double>(n - 1) : pi;
  }

  // FLASER / RLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_ts host logger_ts
  CarmenLaser parse_old_laser(CarmenLaserType type) {
    constexpr std::size_t trailer = 9;
    if (tokens_.size() < 2) fail("missing the beam count");
    const std::size_t n = count(1);
    const std::size_t remaining = tokens_.size() - 2;
    if (remaining != n + trailer) {
      if (remaining < trailer)
        fail("too few fields: expected " + std::to_string(n + trailer) +
             " after the beam count, found " + std::to_string(remaining));
      fail("expected " + std::to_string(n) + " ranges, found " +
           std::to_string(remaining - trailer));
    }
    CarmenLaser laser;
    laser.type = type;
    std::vector<double> ranges = numbers(2, n);
    laser.laser_pose = pose(2 + n);
    laser.odom_pose = pose(5 + n);
    stamp(laser, 8 + n);
    const std::optional<double>& param =
        type == CarmenLaserType::flaser ? front_laser_max_ : rear_laser_max_;
    laser.scan =
        make_scan(-std::numbers::pi / 2, old_laser_increment(n), param.value_or(default_range_max),
                  std::move(ranges), {}, laser.timestamp);
    return laser;
  }

  // RAWLASERk / ROBOTLASER1: see the top of this file.
  CarmenLaser parse_new_laser(CarmenLaserType type) {
    const bool robot = type == CarmenLaserType::robotlaser1;
    const std::size_t trailer = robot ? 14 : 3;
    constexpr std::size_t head = 9;  // tag, 7 configuration fields, beam count
    if (tokens_.size() < head)
      fail("too few fields: expected at least " + std::to_string(head + trailer) + ", found " +
           std::to_string(tokens_.size() - 1));
    const std::size_t n = count(8);
    const std::size_t remaining = tokens_.size() - head;
    if (remaining < n + 1 + trailer) {
      if (remaining < 1 + trailer)
        fail("too few fields: expected " + std::to_string(n + 1 + trailer) +
             " after the beam count, found " + std::to_string(remaining));
      fail("expected " + std::to_string(n) + " ranges, found " +
           std::to_string(remaining - 1 - trailer));
    }
    const std::size_t m = count(head + n);
    if (remaining != n + 1 + m + trailer)
      fail("expected " + std::to_string(m) + " remissions, found " +
           std::to_string(remaining - n - 1 - trailer));
    for (std::size_t i = 1; i < 8; ++i)
      (void)number(i);  // the configuration must be numeric
    const double start_angle = number(2);
    const double angular_resolution = number(4);
    const double max_range = number(5);
    CarmenLaser laser;
    laser.type = type;
    std::vector<double> ranges = numbers(head, n);
    std::vector<double> remissions = numbers(head + n + 1, m);
    if (m != n) remissions.clear();
    std::size_t next_field = head + n + 1 + m;
    if (robot) {
      laser.laser_pose = pose(next_field);
      laser.odom_pose = pose(next_field + 3);
      for (std::size_t i = 6; i < 11; ++i)
        (void)number(next_field + i);
      next_field += 11;
    }
    stamp(laser, next_field);
    laser.scan = make_scan(start_angle, angular_resolution, max_range, std::move(ranges),
                           std::move(remissions), laser.timestamp);
    return laser;
  }

  // ODOM x y theta tv rv accel ipc_ts host logger_ts
  CarmenOdometry parse_odometry() {
    if (tokens_.size() != 10)
      fail("expected 9 fields, found " + std::to_string(tokens_.size() - 1));
    CarmenOdometry odom;
    odom.pose = pose(1);
    odom.tv = number(4);
    odom.rv = number(5);
    odom.accel = number(6);
    stamp(odom, 7);
    return odom;
  }

  void parse_param() {
    if (tokens_.size() < 3) fail("expected a name and a value");
    const std::string name(tokens_[1]);
    const std::string_view value = tokens_[2];
    std::optional<double>* laser_max = name == "robot_front_laser_max"  ? &front_laser_max_
                                       : name == "robot_rear_laser_max" ? &rear_laser_max_
                                                                        : nullptr;
    if (laser_max != nullptr) {
      double v = 0.0;
      if (!detail::parse_double(value, v) || !std::isfinite(v) || v <= 0.0)
        fail(name + ": value '" + std::string(value) + "' is not a positive number");
      *laser_max = v;
    }
    params_.insert_or_assign(name, std::string(value));
  }

  CarmenReaderOptions options_;
  LineReader lines_;
  std::vector<std::string_view> tokens_;
  std::map<std::string, std::string> params_;
  std::optional<double> front_laser_max_;
  std::optional<double> rear_laser_max_;
};

/// Every laser record of a log, in file order (odometry records are dropped).
inline std::vector<CarmenLaser> read_carmen_lasers(const std::filesystem::path& path,
                                                   CarmenReaderOptions options = {}) {
  CarmenReader reader(path, options);
  std::vector<CarmenLaser> lasers;
  while (auto record = reader.next())
    if (auto* laser = std::get_if<CarmenLaser>(&*record)) lasers.push_back(std::move(*laser));
  return lasers;
}

}  // namespace rangenav::io
