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
//   3. 81.9 m, so the SICK "no return" reading 81.91 of the MIT and Freiburg logs is invalid;
// and, unless range_max is set or detect_saturation is off, lowered to the log's saturation
// value when the reader recognises one (below).
//
// Saturation. Logs encode "no return" as the scanner's largest reading, and which one differs:
// 81.91 (MIT, Freiburg), 81.83 (Intel), 50.0, 51.2 or 32.767 m, mostly with no PARAM line that
// says so. Taken as a reading it becomes a wall of phantom points at that range. The reader
// recognises the value from the data of each laser (FLASER, RLASER, RAWLASERk, ROBOTLASER1 apart)
// rather than from a list of known values: it is the largest reading of the log, and it recurs
// exactly, on several beams of one scan, in scans taken from different poses. A real surface
// does neither: the farthest beam of a scan is one beam (its neighbours see the surface at other
// ranges), and its range changes when the robot moves. So a value is recognised once it has been
// the largest reading so far and the reading of at least 2 beams of each of
// `saturation_evidence` scans whose odometry poses (where the record has them) differ by more than
// 5 cm or 0.05 rad; a larger reading later revokes it (readings at the value in earlier scans were
// then dropped: the error is on the safe side, never a phantom wall). So that the value applies
// to a log's first scans too, the reader reads the first `saturation_lookahead` laser records
// before it returns any: their evidence decides for all of them. It holds their parsed fields
// only, and a malformed line met while reading ahead is reported once the records before it
// have been returned.
//
// Timestamps are read as they are: zero, negative, repeated or rounded timestamps are fine (some
// logs carry such); only non-finite ones are malformed.
//
// A malformed line (too few fields, a non-numeric or non-finite pose, timestamp or configuration
// field, a count that does not match) raises io_error naming the file and the 1-based line, e.g.
//   rangenav: carmen: mit.clf:12: FLASER: expected 361 ranges, found 40
// Ranges and remissions may be anything numeric: NaN, inf, 0 and out-of-range readings are invalid
// beams of the scan, not errors.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <deque>
#include <exception>
#include <filesystem>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/io/line_reader.hpp"
#include "rangenav/io/reader_limits.hpp"
#include "rangenav/scan/laser_scan.hpp"

namespace rangenav::io {

/// The record a CarmenLaser came from. Each is a separate laser for the saturation rule and the
/// maximum-range precedence described at the top of this file.
enum class CarmenLaserType {
  flaser,       ///< FLASER: front laser, beam layout guessed from the beam count
  rlaser,       ///< RLASER: rear laser, beam layout guessed from the beam count
  robotlaser1,  ///< ROBOTLASER1: laser with its own layout, laser pose and robot pose
  rawlaser1,    ///< RAWLASER1: laser 1 with its own layout, no pose
  rawlaser2,    ///< RAWLASER2: laser 2 with its own layout, no pose
  rawlaser3,    ///< RAWLASER3: laser 3 with its own layout, no pose
  rawlaser4     ///< RAWLASER4: laser 4 with its own layout, no pose
};

/// The number of CarmenLaserType values.
inline constexpr std::size_t carmen_laser_type_count = 7;

/// The record tag of a laser type ("FLASER", "RLASER", "ROBOTLASER1", "RAWLASER1", ...).
[[nodiscard]] constexpr std::string_view to_string(CarmenLaserType type) {
  constexpr std::array<std::string_view, carmen_laser_type_count> tags{
      "FLASER", "RLASER", "ROBOTLASER1", "RAWLASER1", "RAWLASER2", "RAWLASER3", "RAWLASER4"};
  const auto index = static_cast<std::size_t>(type);
  return index < tags.size() ? tags[index] : std::string_view("unknown");
}

/// The laser type of a record tag ("FLASER", "RAWLASER2", ...; case-sensitive as in the logs),
/// nullopt for any other word (ODOM, PARAM, a command-line typo).
[[nodiscard]] constexpr std::optional<CarmenLaserType> carmen_laser_type(std::string_view tag) {
  for (std::size_t t = 0; t < carmen_laser_type_count; ++t) {
    const auto type = static_cast<CarmenLaserType>(t);
    if (to_string(type) == tag) return type;
  }
  return std::nullopt;
}

/// One laser record: the scan plus the poses the record carries.
struct CarmenLaser {
  CarmenLaserType type{CarmenLaserType::flaser};  ///< the record tag the scan came from
  LaserScan<double> scan;                         ///< scan.timestamp() is the ipc timestamp
  std::optional<Pose2d> laser_pose;  ///< FLASER/RLASER "x y theta", ROBOTLASER1 laser pose
  std::optional<Pose2d> odom_pose;   ///< FLASER/RLASER "odom_x odom_y odom_theta",
                                     ///< ROBOTLASER1 robot pose
  double timestamp{0.0};             ///< ipc timestamp (s)
  std::string host;                  ///< host name field of the record (not interpreted)
  double logger_timestamp{0.0};      ///< logger timestamp (s)
  std::size_t line{0};               ///< 1-based line in the log
};

/// One ODOM record.
struct CarmenOdometry {
  Pose2d pose;                   ///< odometry pose "x y theta" (m, m, rad) in the odometry frame
  double tv{0.0};                ///< translational velocity (m/s)
  double rv{0.0};                ///< rotational velocity (rad/s)
  double accel{0.0};             ///< acceleration (m/s^2)
  double timestamp{0.0};         ///< ipc timestamp (s)
  std::string host;              ///< host name field of the record (not interpreted)
  double logger_timestamp{0.0};  ///< logger timestamp (s)
  std::size_t line{0};           ///< 1-based line in the log
};

/// One record of the log in file order: a laser scan or an odometry reading.
using CarmenRecord = std::variant<CarmenLaser, CarmenOdometry>;

/// How the reader builds scans; see the maximum-range precedence and the saturation rule at the
/// top of this file.
struct CarmenReaderOptions {
  /// Overrides every other source of the maximum range when set (m, > range_min).
  std::optional<double> range_max{};
  /// Readings below it are invalid beams (m, >= 0).
  double range_min = 0.0;
  /// Recognise each laser's saturation ("no return") value and treat it as the maximum range.
  bool detect_saturation = true;
  /// Scans that must show a value before it is recognised as the saturation value (>= 1).
  std::size_t saturation_evidence = 3;
  /// Laser records read before the first is returned, whose evidence decides for all (0: none).
  std::size_t saturation_lookahead = 1000;
  /// Longest line; read_carmen_lasers() also returns at most limits.max_points records.
  ReaderLimits limits{};
};

/// Streaming reader: holds one buffer of the file at a time and at most
/// options.saturation_lookahead parsed records, never the whole log.
class CarmenReader {
 public:
  /// The maximum range when neither the options nor the log say otherwise (m).
  static constexpr double default_range_max = 81.9;

  /// Opens the log. Throws invalid_argument for bad options (checked first) and io_error when
  /// the file cannot be opened (or is gzip-compressed and zlib is missing).
  explicit CarmenReader(const std::filesystem::path& path, CarmenReaderOptions options = {})
      : options_(validated(options)), lines_(path, "carmen", options_.limits.max_line_bytes) {}

  /// The next laser or odometry record, or nullopt at the end of the file. Throws io_error for
  /// a malformed line once every record before it has been returned.
  std::optional<CarmenRecord> next() {
    while (!finished_ && (pending_.empty() || holding())) {
      try {
        if (!parse_next()) finished_ = true;
      } catch (const error&) {
        error_ = std::current_exception();
        finished_ = true;
      }
    }
    if (pending_.empty()) {
      if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
      return std::nullopt;
    }
    return pop();
  }

  /// The PARAM lines read so far (name -> value); the reader may have read up to
  /// options.saturation_lookahead records beyond the last one it returned.
  [[nodiscard]] const std::map<std::string, std::string>& params() const { return params_; }

  /// The saturation value recognised so far for a laser type, if any (m).
  [[nodiscard]] std::optional<double> saturation(CarmenLaserType type) const {
    const Saturation& s = saturation_[static_cast<std::size_t>(type)];
    if (!options_.detect_saturation || !s.recognised(options_.saturation_evidence))
      return std::nullopt;
    return s.value;
  }

  /// The path of the log.
  [[nodiscard]] const std::filesystem::path& path() const { return lines_.path(); }

 private:
  /// The evidence for one laser's saturation value (see the top of this file).
  struct Saturation {
    double value = -std::numeric_limits<double>::infinity();  ///< largest reading so far
    std::size_t evidence = 0;  ///< scans at distinct poses with `value` on >= 2 beams
    std::optional<Pose2d> last_pose;

    [[nodiscard]] bool recognised(std::size_t needed) const { return evidence >= needed; }

    void observe(const std::vector<double>& ranges, const std::optional<Pose2d>& pose) {
      double top = -std::numeric_limits<double>::infinity();
      std::size_t hits = 0;
      for (const double r : ranges) {
        if (!(std::isfinite(r) && r > 0)) continue;
        if (r > top) {
          top = r;
          hits = 0;
        }
        hits += r == top ? 1 : 0;
      }
      if (top < value) return;
      if (top > value) {  // a larger reading: the previous value was not the saturation
        value = top;
        evidence = 0;
        last_pose.reset();
      }
      if (hits < 2) return;
      // The same reading from the same place is no evidence (a robot standing still).
      constexpr double moved_xy = 0.05, moved_theta = 0.05;
      if (pose && last_pose &&
          std::hypot(pose->x - last_pose->x, pose->y - last_pose->y) <= moved_xy &&
          std::abs(angle_difference(pose->theta, last_pose->theta)) <= moved_theta)
        return;
      ++evidence;
      last_pose = pose;
    }
  };

  /// A parsed record whose scan is built when it is returned (with the saturation value known
  /// by then).
  struct Pending {
    CarmenRecord record;
    ScanGeometry<double> geometry{};  ///< lasers: range_max before saturation
    std::vector<double> ranges, remissions;
  };

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
    if (options.saturation_evidence == 0)
      ::rangenav::detail::throw_invalid_argument("CarmenReader", "options.saturation_evidence",
                                                 options.saturation_evidence, "must be >= 1");
    options.limits.validate("CarmenReader");
    return options;
  }

  [[nodiscard]] bool detecting() const { return options_.detect_saturation && !options_.range_max; }

  // Holding back the first saturation_lookahead laser records: the evidence they hold decides
  // for them too.
  [[nodiscard]] bool holding() const {
    return detecting() && lasers_read_ < options_.saturation_lookahead;
  }

  CarmenRecord pop() {
    Pending p = std::move(pending_.front());
    pending_.pop_front();
    if (auto* laser = std::get_if<CarmenLaser>(&p.record)) {
      ScanGeometry<double> g = p.geometry;
      if (detecting()) {
        const Saturation& s = saturation_[static_cast<std::size_t>(laser->type)];
        if (s.recognised(options_.saturation_evidence) && s.value < g.range_max &&
            s.value > g.range_min)
          g.range_max = s.value;
      }
      // The geometry was validated when the line was parsed; a lower range_max above
      // range_min keeps it valid.
      laser->scan =
          LaserScan<double>(g, std::move(p.ranges), std::move(p.remissions), laser->timestamp);
    }
    return std::move(p.record);
  }

  // Parses the next record into pending_; false at the end of the file.
  bool parse_next() {
    std::string_view line;
    while (lines_.next(line)) {
      detail::split_whitespace(line, tokens_);
      if (tokens_.empty() || tokens_[0].front() == '#') continue;
      const std::string_view tag = tokens_[0];
      if (tag == "ODOM") return parse_odometry();
      if (tag == "PARAM") {
        parse_param();
      } else if (const auto type = carmen_laser_type(tag)) {
        // FLASER and RLASER are the old format (layout from the beam count, no laser pose).
        const bool old_format =
            *type == CarmenLaserType::flaser || *type == CarmenLaserType::rlaser;
        return old_format ? parse_old_laser(*type) : parse_new_laser(*type);
      }
    }
    return false;
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

  // A pose, timestamp, velocity or configuration field: NaN or inf there is a malformed line.
  double finite(std::size_t index) const {
    const double value = number(index);
    if (!std::isfinite(value))
      fail("field " + std::to_string(index + 1) + " is not a finite number: '" +
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
    return {finite(index), finite(index + 1), finite(index + 2)};
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
    record.timestamp = finite(index);
    record.host = std::string(tokens_[index + 1]);
    record.logger_timestamp = finite(index + 2);
    record.line = lines_.line_number();
  }

  // Validates the scan layout now, while the line is current, and queues the record.
  void queue_laser(CarmenLaser laser, double angle_min, double angle_increment, double range_max,
                   std::vector<double> ranges, std::vector<double> remissions) {
    if (options_.range_max) range_max = *options_.range_max;
    if (!(std::isfinite(range_max) && range_max > options_.range_min))
      fail("max range " + ::rangenav::detail::format_value(range_max) + " must exceed range_min " +
           ::rangenav::detail::format_value(options_.range_min) +
           " (set CarmenReaderOptions::range_max to override)");
    const ScanGeometry<double> geometry{angle_min, angle_increment, ranges.size(),
                                        options_.range_min, range_max};
    try {
      geometry.validate("LaserScan");
    } catch (const invalid_argument& e) {
      std::string_view what = e.what();
      if (what.starts_with("rangenav: ")) what.remove_prefix(10);
      fail(what);
    }
    if (detecting())
      saturation_[static_cast<std::size_t>(laser.type)].observe(ranges, laser.odom_pose);
    ++lasers_read_;
    pending_.push_back(
        {CarmenRecord{std::move(laser)}, geometry, std::move(ranges), std::move(remissions)});
  }

  // n + k as text, without overflowing for a crafted count.
  static std::string sum_text(std::size_t n, std::size_t k) {
    std::size_t sum = 0;
    if (detail::checked_add(n, k, sum)) return std::to_string(sum);
    return std::to_string(n) + " + " + std::to_string(k);
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
  bool parse_old_laser(CarmenLaserType type) {
    constexpr std::size_t trailer = 9;
    if (tokens_.size() < 2) fail("missing the beam count");
    const std::size_t n = count(1);
    // Compared without n + trailer, which a crafted count overflows.
    const std::size_t remaining = tokens_.size() - 2;
    if (remaining < trailer)
      fail("too few fields: expected " + sum_text(n, trailer) + " after the beam count, found " +
           std::to_string(remaining));
    if (n != remaining - trailer)
      fail("expected " + std::to_string(n) + " ranges, found " +
           std::to_string(remaining - trailer));
    CarmenLaser laser;
    laser.type = type;
    std::vector<double> ranges = numbers(2, n);
    laser.laser_pose = pose(2 + n);
    laser.odom_pose = pose(5 + n);
    stamp(laser, 8 + n);
    const std::optional<double>& param =
        type == CarmenLaserType::flaser ? front_laser_max_ : rear_laser_max_;
    queue_laser(std::move(laser), -std::numbers::pi / 2, old_laser_increment(n),
                param.value_or(default_range_max), std::move(ranges), {});
    return true;
  }

  // RAWLASERk / ROBOTLASER1: see the top of this file.
  bool parse_new_laser(CarmenLaserType type) {
    const bool robot = type == CarmenLaserType::robotlaser1;
    const std::size_t trailer = robot ? 14 : 3;
    constexpr std::size_t head = 9;  // tag, 7 configuration fields, beam count
    if (tokens_.size() < head)
      fail("too few fields: expected at least " + std::to_string(head + trailer) + ", found " +
           std::to_string(tokens_.size() - 1));
    const std::size_t n = count(8);
    // Every comparison subtracts from the fields present, which no crafted count overflows.
    const std::size_t remaining = tokens_.size() - head;
    if (remaining < 1 + trailer)
      fail("too few fields: expected " + sum_text(n, 1 + trailer) +
           " after the beam count, found " + std::to_string(remaining));
    if (n > remaining - 1 - trailer)
      fail("expected " + std::to_string(n) + " ranges, found " +
           std::to_string(remaining - 1 - trailer));
    const std::size_t m = count(head + n);
    if (m != remaining - 1 - trailer - n)
      fail("expected " + std::to_string(m) + " remissions, found " +
           std::to_string(remaining - n - 1 - trailer));
    for (std::size_t i = 1; i < 8; ++i)
      (void)finite(i);  // the configuration must be numeric and finite
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
        (void)finite(next_field + i);
      next_field += 11;
    }
    stamp(laser, next_field);
    queue_laser(std::move(laser), start_angle, angular_resolution, max_range, std::move(ranges),
                std::move(remissions));
    return true;
  }

  // ODOM x y theta tv rv accel ipc_ts host logger_ts
  bool parse_odometry() {
    if (tokens_.size() != 10)
      fail("expected 9 fields, found " + std::to_string(tokens_.size() - 1));
    CarmenOdometry odom;
    odom.pose = pose(1);
    odom.tv = finite(4);
    odom.rv = finite(5);
    odom.accel = finite(6);
    stamp(odom, 7);
    pending_.push_back({CarmenRecord{std::move(odom)}, {}, {}, {}});
    return true;
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
  std::array<Saturation, carmen_laser_type_count> saturation_{};
  std::deque<Pending> pending_;
  std::size_t lasers_read_{0};
  bool finished_{false};
  std::exception_ptr error_;
};

namespace detail {

// Reads every record of a log, calling on_laser(laser) for each laser record and on_odometry(odom)
// for each ODOM record in file order. Throws io_error when the log holds more than
// options.limits.max_points laser records.
template <class OnLaser, class OnOdometry>
void for_each_carmen_record(const std::filesystem::path& path, const CarmenReaderOptions& options,
                            OnLaser&& on_laser, OnOdometry&& on_odometry) {
  CarmenReader reader(path, options);
  std::size_t lasers = 0;
  while (auto record = reader.next()) {
    if (auto* odometry = std::get_if<CarmenOdometry>(&*record)) {
      on_odometry(*odometry);
      continue;
    }
    auto& laser = std::get<CarmenLaser>(*record);
    if (lasers == options.limits.max_points)
      throw io_error(
          "rangenav: carmen: " + path.string() + ":" + std::to_string(laser.line) + ": " +
          exceeds_limit("laser record count", lasers + 1, "max_points", options.limits.max_points));
    ++lasers;
    on_laser(laser);
  }
}

}  // namespace detail

/// Every laser record of a log, in file order (odometry records are dropped). Throws io_error
/// when the log holds more than options.limits.max_points laser records.
inline std::vector<CarmenLaser> read_carmen_lasers(const std::filesystem::path& path,
                                                   CarmenReaderOptions options = {}) {
  std::vector<CarmenLaser> lasers;
  detail::for_each_carmen_record(
      path, options, [&](CarmenLaser& laser) { lasers.push_back(std::move(laser)); },
      [](const CarmenOdometry&) {});
  return lasers;
}

/// The odometry of the frame a record's scan is in: the laser pose when the record carries one
/// (FLASER / RLASER "x y theta", ROBOTLASER1's laser pose: CARMEN's odometry of the robot with
/// the laser's mounting offset applied), else the robot's odometry pose, else nullopt. SLAM and
/// localisation of the scans need this one: with the robot's pose, a laser mounted ahead of the
/// axle would see every turn of angle a as an unexplained sideways step of offset x a.
[[nodiscard]] inline std::optional<Pose2d> laser_odometry(const CarmenLaser& laser) {
  return laser.laser_pose ? laser.laser_pose : laser.odom_pose;
}

/// The scans of one laser of a log, with the odometry of that laser's frame
/// (read_carmen_scan_log()).
struct CarmenScanLog {
  CarmenLaserType laser{CarmenLaserType::flaser};  ///< the laser whose records these are
  std::vector<CarmenLaser> records;                ///< its records, in file order
  /// Per record: laser_odometry(record); for a record without poses (RAWLASERk) the pose of the
  /// last ODOM record before it in the file (the robot's: the log does not say where that laser
  /// is mounted), nullopt before the first ODOM record.
  std::vector<std::optional<Pose2d>> odometry;
  std::size_t other_laser_records = 0;  ///< records of the log's other lasers, left out
};

/// The records of one laser of a CARMEN log, ready for SLAM or localisation: `laser` when given,
/// else the laser with the most records (on a tie the first in CarmenLaserType's order: a front
/// laser before a rear one, a record with poses before a raw one). A log may carry a front and a
/// rear laser, or one laser twice (ROBOTLASER1 and RAWLASER1 of the same scans); their scans are
/// in different frames and must not be fed to one mapper. The odometry is matched to the scans
/// by file order, never by timestamp (logs carry zero, repeated or rounded ones). Throws
/// io_error as read_carmen_lasers(); a log without records of the laser gives empty records.
[[nodiscard]] inline CarmenScanLog read_carmen_scan_log(
    const std::filesystem::path& path, std::optional<CarmenLaserType> laser = std::nullopt,
    CarmenReaderOptions options = {}) {
  std::vector<CarmenLaser> lasers;
  std::vector<std::optional<Pose2d>> last_odometry;  // per laser record
  std::optional<Pose2d> odometry;
  detail::for_each_carmen_record(
      path, options,
      [&](CarmenLaser& l) {
        lasers.push_back(std::move(l));
        last_odometry.push_back(odometry);
      },
      [&](const CarmenOdometry& o) { odometry = o.pose; });
  CarmenScanLog log;
  if (laser) {
    log.laser = *laser;
  } else {
    std::array<std::size_t, carmen_laser_type_count> count{};
    for (const auto& l : lasers)
      ++count[static_cast<std::size_t>(l.type)];
    log.laser = static_cast<CarmenLaserType>(std::max_element(count.begin(), count.end()) -
                                             count.begin());  // the first of equal counts
  }
  for (std::size_t i = 0; i < lasers.size(); ++i) {
    if (lasers[i].type != log.laser) {
      ++log.other_laser_records;
      continue;
    }
    const auto own = laser_odometry(lasers[i]);
    log.odometry.push_back(own ? own : last_odometry[i]);
    log.records.push_back(std::move(lasers[i]));
  }
  return log;
}

}  // namespace rangenav::io
