#pragma once
// Trajectory files: timestamped poses, one per line, as SLAM evaluation tools read them.
//
//   TUM      "t tx ty tz qx qy qz qw"  (the TUM RGB-D benchmark format; evo, rpg tools)
//   xytheta  "t x y theta"             (planar poses, e.g. for the Freiburg SLAM benchmark)
//   KITTI    "r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz"  (the KITTI odometry benchmark's
//            poses: the 3x4 matrix [R | t] row by row, no timestamps; evo reads them too)
//
// read_transform_matrix reads one rigid transform written as a matrix: 3 or 4 lines of 4
// numbers ([R | t], then optionally 0 0 0 1), as ground-truth and calibration files give it
// (e.g. small_gicp's T_target_source.txt).
//
// Writers print timestamps with microsecond precision ("%.6f") and the pose fields with 9
// decimals, locale-independent; a planar pose goes to TUM with z = 0 and a rotation about z.
// Readers skip blank lines and '#' comments, read plain or gzip files (see LineReader), normalise
// quaternions and angles, and raise io_error naming the file and line for a malformed line (a
// non-finite number included) and for a file beyond their ReaderLimits (line length, records).

#include <Eigen/Geometry>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <istream>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/io/detail/rigid.hpp"
#include "rangenav/io/line_reader.hpp"
#include "rangenav/io/reader_limits.hpp"

namespace rangenav::io {

/// A planar pose with its timestamp (s).
struct StampedPose2d {
  double timestamp{0.0};  ///< time of the pose (s)
  Pose2d pose;            ///< x, y (m) and heading theta (rad)
};

/// A 3D rigid transform with its timestamp (s).
struct StampedTransform3d {
  double timestamp{0.0};                      ///< time of the pose (s)
  Transform3d pose{Transform3d::Identity()};  ///< the rigid transform (translation in m)
};

namespace detail {

inline constexpr int trajectory_time_decimals = 6;
inline constexpr int trajectory_pose_decimals = 9;

inline void check_trajectory_sizes(std::string_view where, std::size_t timestamps,
                                   std::size_t poses) {
  if (timestamps != poses)
    ::rangenav::detail::throw_invalid_argument(
        where, "poses.size()", poses,
        "must equal timestamps.size() = " + std::to_string(timestamps));
}

inline void require_finite_entry(std::string_view where, std::size_t index, bool finite) {
  if (!finite)
    ::rangenav::detail::throw_invalid_argument(where, "index", index,
                                               "holds a non-finite timestamp or pose");
}

inline void append_tum_line(std::string& line, double t, const Eigen::Vector3d& p,
                            Eigen::Quaterniond q) {
  if (q.w() < 0) q.coeffs() = -q.coeffs();  // q and -q are one rotation: print qw >= 0
  line.clear();
  append_fixed(line, t, trajectory_time_decimals);
  for (const double v : {p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w()}) {
    line.push_back(' ');
    append_fixed(line, v, trajectory_pose_decimals);
  }
  line.push_back('\n');
}

inline void write_checked(std::ostream& out, const std::string& line, std::string_view where) {
  out.write(line.data(), static_cast<std::streamsize>(line.size()));
  if (!out) throw io_error("rangenav: " + std::string(where) + ": write error");
}

inline std::ofstream open_for_writing(const std::filesystem::path& path, std::string_view where) {
  std::ofstream out(path, std::ios::binary);
  if (!out)
    throw io_error("rangenav: " + std::string(where) + ": " + path.string() +
                   ": cannot open file for writing");
  return out;
}

inline void close_checked(std::ofstream& out, const std::filesystem::path& path,
                          std::string_view where) {
  out.close();
  if (!out)
    throw io_error("rangenav: " + std::string(where) + ": " + path.string() + ": write error");
}

// Calls parse(tokens, fail) for every non-comment line of a text stream or file; `fail(message)`
// throws io_error naming the source and the line. A line longer than limits.max_line_bytes and
// more than limits.max_points data lines raise io_error too.
template <class Parse>
void for_each_data_line(std::istream& in, std::string_view name, std::string_view where,
                        const ReaderLimits& limits, Parse&& parse) {
  limits.validate(where);
  std::string line;
  std::vector<std::string_view> tokens;
  std::size_t number = 0, records = 0;
  bool too_long = false;
  while (read_bounded_line(in, line, limits.max_line_bytes, too_long)) {
    ++number;
    const auto fail = [&](std::string_view message) {
      throw io_error("rangenav: " + std::string(where) + ": " + std::string(name) + ":" +
                     std::to_string(number) + ": " + std::string(message));
    };
    if (too_long)
      fail("line longer than ReaderLimits::max_line_bytes = " +
           std::to_string(limits.max_line_bytes) + " bytes");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    split_whitespace(line, tokens);
    if (tokens.empty() || tokens[0].front() == '#') continue;
    if (++records > limits.max_points)
      fail(exceeds_limit("record count", records, "max_points", limits.max_points));
    parse(tokens, fail);
  }
  if (in.bad())
    throw io_error("rangenav: " + std::string(where) + ": " + std::string(name) + ": read error");
}

template <class Parse>
void for_each_data_line(const std::filesystem::path& path, std::string_view where,
                        const ReaderLimits& limits, Parse&& parse) {
  limits.validate(where);
  LineReader lines(path, where, limits.max_line_bytes);
  std::string_view line;
  std::vector<std::string_view> tokens;
  std::size_t records = 0;
  while (lines.next(line)) {
    split_whitespace(line, tokens);
    if (tokens.empty() || tokens[0].front() == '#') continue;
    const auto fail = [&](std::string_view message) { lines.fail_line(message); };
    if (++records > limits.max_points)
      fail(exceeds_limit("record count", records, "max_points", limits.max_points));
    parse(tokens, fail);
  }
}

// Parses exactly `count` numbers into `values`, or fails naming the field (1-based).
template <class Fail>
void parse_numbers(const std::vector<std::string_view>& tokens, std::size_t count, double* values,
                   const Fail& fail) {
  if (tokens.size() != count)
    fail("expected " + std::to_string(count) + " fields, found " + std::to_string(tokens.size()));
  for (std::size_t i = 0; i < count; ++i)
    if (!parse_double(tokens[i], values[i]) || !std::isfinite(values[i]))
      fail("field " + std::to_string(i + 1) + " is not a finite number: '" +
           std::string(tokens[i]) + "'");
}

inline constexpr auto parse_tum = [](const std::vector<std::string_view>& tokens,
                                     const auto& fail) -> StampedTransform3d {
  double v[8] = {};
  parse_numbers(tokens, 8, v, fail);
  Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);  // Eigen's constructor order is (w, x, y, z)
  const double norm = q.norm();
  // Printed quaternions are unit to their precision; anything else is a different format.
  if (!(std::abs(norm - 1.0) <= 1e-3))
    fail("quaternion norm " + ::rangenav::detail::format_value(norm) + " is not 1");
  q.normalize();
  StampedTransform3d stamped;
  stamped.timestamp = v[0];
  stamped.pose = Transform3d::Identity();
  stamped.pose.linear() = q.toRotationMatrix();
  stamped.pose.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
  return stamped;
};

inline constexpr auto parse_xytheta = [](const std::vector<std::string_view>& tokens,
                                         const auto& fail) -> StampedPose2d {
  double v[4] = {};
  parse_numbers(tokens, 4, v, fail);
  return {v[0], Pose2d{v[1], v[2], normalize_angle(v[3])}};
};

inline constexpr auto parse_kitti = [](const std::vector<std::string_view>& tokens,
                                       const auto& fail) -> Transform3d {
  double v[12] = {};
  parse_numbers(tokens, 12, v, fail);
  const Eigen::Matrix<double, 3, 4> m =
      Eigen::Map<const Eigen::Matrix<double, 3, 4, Eigen::RowMajor>>(v);
  return rigid_transform_or_fail(m, fail);
};

// Collects the rows of a matrix file: `rows` counts the data lines seen so far.
template <class Fail>
void parse_transform_row(const std::vector<std::string_view>& tokens,
                         Eigen::Matrix<double, 3, 4>& m, int& rows, const Fail& fail) {
  if (rows > 3) fail("more than 4 rows: not a 3x4 or 4x4 matrix");
  double v[4] = {};
  parse_numbers(tokens, 4, v, fail);
  const Eigen::RowVector4d row(v[0], v[1], v[2], v[3]);
  if (rows < 3)
    m.row(rows) = row;
  else if (!row.isApprox(Eigen::RowVector4d(0, 0, 0, 1), 1e-6))
    fail("last row is not (0, 0, 0, 1): not a rigid transform");
  ++rows;
}

// The transform of a matrix file's rows once all are read, or io_error naming `name`.
inline Transform3d finish_transform_matrix(const Eigen::Matrix<double, 3, 4>& m, int rows,
                                           std::string_view name) {
  const auto fail = [&](std::string_view message) {
    throw io_error("rangenav: transform_matrix: " + std::string(name) + ": " +
                   std::string(message));
  };
  if (rows < 3) fail("expected 3 or 4 rows of 4 numbers, found " + std::to_string(rows) + " rows");
  return rigid_transform_or_fail(m, fail);
}

// Every record of a stream (`source` = the stream and its name) or a file (`source` = the path),
// one parse(tokens, fail) per data line: the body of every trajectory reader.
template <class T, class Parse, class... Source>
std::vector<T> read_records(std::string_view where, const ReaderLimits& limits, const Parse& parse,
                            Source&&... source) {
  std::vector<T> records;
  for_each_data_line(
      std::forward<Source>(source)..., where, limits,
      [&](const auto& tokens, const auto& fail) { records.push_back(parse(tokens, fail)); });
  return records;
}

// The transform of a matrix stream (`source` = the stream and its name) or file (the path).
template <class... Source>
Transform3d read_matrix_rows(std::string_view name, Source&&... source) {
  Eigen::Matrix<double, 3, 4> m = Eigen::Matrix<double, 3, 4>::Zero();
  int rows = 0;
  for_each_data_line(
      std::forward<Source>(source)..., "transform_matrix", ReaderLimits{},
      [&](const auto& tokens, const auto& fail) { parse_transform_row(tokens, m, rows, fail); });
  return finish_transform_matrix(m, rows, name);
}

// Opens `path`, calls write(stream) and closes it, raising io_error when either fails: the body
// of every file writer.
template <class Write>
void write_file(const std::filesystem::path& path, std::string_view where, const Write& write) {
  auto out = open_for_writing(path, where);
  write(out);
  close_checked(out, path, where);
}

// The timestamps and poses of a stamped trajectory, as the span writers take them.
template <class Stamped>
auto split_stamped(std::span<const Stamped> trajectory) {
  std::pair<std::vector<double>, std::vector<decltype(Stamped::pose)>> split;
  split.first.reserve(trajectory.size());
  split.second.reserve(trajectory.size());
  for (const auto& s : trajectory) {
    split.first.push_back(s.timestamp);
    split.second.push_back(s.pose);
  }
  return split;
}

}  // namespace detail

// ---- TUM ------------------------------------------------------------------------------------

/// Writes "t tx ty tz qx qy qz qw" lines. Throws invalid_argument for mismatched sizes or a
/// non-finite entry.
inline void write_tum(std::ostream& out, std::span<const double> timestamps,
                      std::span<const Transform3d> poses) {
  detail::check_trajectory_sizes("write_tum", timestamps.size(), poses.size());
  std::string line;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    detail::require_finite_entry("write_tum", i,
                                 std::isfinite(timestamps[i]) && poses[i].matrix().allFinite());
    detail::append_tum_line(line, timestamps[i], poses[i].translation(),
                            Eigen::Quaterniond(poses[i].linear()));
    detail::write_checked(out, line, "write_tum");
  }
}

/// Writes planar poses as TUM lines (z = 0, rotation theta about z).
inline void write_tum(std::ostream& out, std::span<const double> timestamps,
                      std::span<const Pose2d> poses) {
  detail::check_trajectory_sizes("write_tum", timestamps.size(), poses.size());
  std::string line;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Pose2d& p = poses[i];
    detail::require_finite_entry("write_tum", i,
                                 std::isfinite(timestamps[i]) && std::isfinite(p.x) &&
                                     std::isfinite(p.y) && std::isfinite(p.theta));
    detail::append_tum_line(
        line, timestamps[i], Eigen::Vector3d(p.x, p.y, 0.0),
        Eigen::Quaterniond(Eigen::AngleAxisd(p.theta, Eigen::Vector3d::UnitZ())));
    detail::write_checked(out, line, "write_tum");
  }
}

/// Writes stamped transforms as TUM lines.
inline void write_tum(std::ostream& out, std::span<const StampedTransform3d> trajectory) {
  const auto [timestamps, poses] = detail::split_stamped(trajectory);
  write_tum(out, timestamps, poses);
}

/// Writes a TUM file; throws io_error when the file cannot be written.
inline void write_tum(const std::filesystem::path& path, std::span<const double> timestamps,
                      std::span<const Transform3d> poses) {
  detail::write_file(path, "write_tum",
                     [&](std::ostream& out) { write_tum(out, timestamps, poses); });
}

/// Writes planar poses as a TUM file (z = 0, rotation about z); throws io_error when the file
/// cannot be written.
inline void write_tum(const std::filesystem::path& path, std::span<const double> timestamps,
                      std::span<const Pose2d> poses) {
  detail::write_file(path, "write_tum",
                     [&](std::ostream& out) { write_tum(out, timestamps, poses); });
}

/// Writes a stamped trajectory as a TUM file; throws io_error when the file cannot be written.
inline void write_tum(const std::filesystem::path& path,
                      std::span<const StampedTransform3d> trajectory) {
  detail::write_file(path, "write_tum", [&](std::ostream& out) { write_tum(out, trajectory); });
}

/// Reads a TUM trajectory from a stream; `name` stands for the source in error messages.
inline std::vector<StampedTransform3d> read_tum(std::istream& in,
                                                std::string_view name = "<stream>",
                                                const ReaderLimits& limits = {}) {
  return detail::read_records<StampedTransform3d>("tum", limits, detail::parse_tum, in, name);
}

/// Reads a TUM trajectory file (plain or gzip).
inline std::vector<StampedTransform3d> read_tum(const std::filesystem::path& path,
                                                const ReaderLimits& limits = {}) {
  return detail::read_records<StampedTransform3d>("tum", limits, detail::parse_tum, path);
}

// ---- x y theta ------------------------------------------------------------------------------

/// Writes "t x y theta" lines. Throws invalid_argument for mismatched sizes or a non-finite
/// entry.
inline void write_xytheta(std::ostream& out, std::span<const double> timestamps,
                          std::span<const Pose2d> poses) {
  detail::check_trajectory_sizes("write_xytheta", timestamps.size(), poses.size());
  std::string line;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Pose2d& p = poses[i];
    detail::require_finite_entry("write_xytheta", i,
                                 std::isfinite(timestamps[i]) && std::isfinite(p.x) &&
                                     std::isfinite(p.y) && std::isfinite(p.theta));
    line.clear();
    detail::append_fixed(line, timestamps[i], detail::trajectory_time_decimals);
    for (const double v : {p.x, p.y, p.theta}) {
      line.push_back(' ');
      detail::append_fixed(line, v, detail::trajectory_pose_decimals);
    }
    line.push_back('\n');
    detail::write_checked(out, line, "write_xytheta");
  }
}

/// Writes a stamped planar trajectory as "t x y theta" lines.
inline void write_xytheta(std::ostream& out, std::span<const StampedPose2d> trajectory) {
  const auto [timestamps, poses] = detail::split_stamped(trajectory);
  write_xytheta(out, timestamps, poses);
}

/// Writes "t x y theta" lines to a file; throws io_error when the file cannot be written.
inline void write_xytheta(const std::filesystem::path& path, std::span<const double> timestamps,
                          std::span<const Pose2d> poses) {
  detail::write_file(path, "write_xytheta",
                     [&](std::ostream& out) { write_xytheta(out, timestamps, poses); });
}

/// Writes a stamped planar trajectory to a file; throws io_error when the file cannot be
/// written.
inline void write_xytheta(const std::filesystem::path& path,
                          std::span<const StampedPose2d> trajectory) {
  detail::write_file(path, "write_xytheta",
                     [&](std::ostream& out) { write_xytheta(out, trajectory); });
}

/// Reads "t x y theta" lines from a stream; theta is normalised to (-pi, pi].
inline std::vector<StampedPose2d> read_xytheta(std::istream& in, std::string_view name = "<stream>",
                                               const ReaderLimits& limits = {}) {
  return detail::read_records<StampedPose2d>("xytheta", limits, detail::parse_xytheta, in, name);
}

/// Reads an x-y-theta trajectory file (plain or gzip).
inline std::vector<StampedPose2d> read_xytheta(const std::filesystem::path& path,
                                               const ReaderLimits& limits = {}) {
  return detail::read_records<StampedPose2d>("xytheta", limits, detail::parse_xytheta, path);
}

// ---- KITTI ----------------------------------------------------------------------------------

/// Writes one "r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz" line per pose (9 decimals). Throws
/// invalid_argument for a non-finite pose.
inline void write_kitti(std::ostream& out, std::span<const Transform3d> poses) {
  std::string line;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    detail::require_finite_entry("write_kitti", i, poses[i].matrix().allFinite());
    line.clear();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) {
        if (r + c > 0) line.push_back(' ');
        detail::append_fixed(line, poses[i].matrix()(r, c), detail::trajectory_pose_decimals);
      }
    line.push_back('\n');
    detail::write_checked(out, line, "write_kitti");
  }
}

/// Writes a KITTI pose file; throws io_error when the file cannot be written.
inline void write_kitti(const std::filesystem::path& path, std::span<const Transform3d> poses) {
  detail::write_file(path, "write_kitti", [&](std::ostream& out) { write_kitti(out, poses); });
}

/// Reads KITTI pose lines from a stream; every rotation must be orthonormal to 1e-3 and is
/// re-orthonormalised. `name` stands for the source in error messages.
inline std::vector<Transform3d> read_kitti(std::istream& in, std::string_view name = "<stream>",
                                           const ReaderLimits& limits = {}) {
  return detail::read_records<Transform3d>("kitti", limits, detail::parse_kitti, in, name);
}

/// Reads a KITTI pose file (plain or gzip).
inline std::vector<Transform3d> read_kitti(const std::filesystem::path& path,
                                           const ReaderLimits& limits = {}) {
  return detail::read_records<Transform3d>("kitti", limits, detail::parse_kitti, path);
}

// ---- one transform as a matrix --------------------------------------------------------------

/// Reads one rigid transform written as 3 or 4 lines of 4 numbers ([R | t] row by row, then
/// optionally 0 0 0 1) from a stream; '#' comments and blank lines are skipped. Throws io_error
/// naming the source (and the line) for fewer than 3 or more than 4 rows, a row that is not 4
/// finite numbers, a fourth row other than 0 0 0 1, or a rotation that is not orthonormal to
/// 1e-3; the rotation is re-orthonormalised.
inline Transform3d read_transform_matrix(std::istream& in, std::string_view name = "<stream>") {
  return detail::read_matrix_rows(name, in, name);
}

/// Reads one rigid transform from a matrix file (plain or gzip), as the stream overload does.
inline Transform3d read_transform_matrix(const std::filesystem::path& path) {
  return detail::read_matrix_rows(path.string(), path);
}

}  // namespace rangenav::io
