#pragma once
// Helpers shared by the PCD and PLY readers and writers: whole-file reads and writes, the
// io_error message format, little-endian typed values, text numbers that round-trip, and the
// checks a reader makes before it allocates a cloud and before it returns one.

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <vector>

#include "rangenav/core/cloud.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/io/line_reader.hpp"
#include "rangenav/io/reader_limits.hpp"

namespace rangenav::io {

/// How a writer stores point and normal coordinates.
enum class StoredScalar {
  as_cloud,  ///< the cloud's own Scalar: lossless (float clouds as float32, double as float64)
  float32,   ///< float32, what PCL's PointXYZ and most viewers expect
  float64,   ///< float64
};

}  // namespace rangenav::io

namespace rangenav::io::detail {

/// Throws io_error("rangenav: <format>: <path>: line <line>: <message>"); line 0 omits the line.
[[noreturn]] inline void throw_io(std::string_view format, const std::filesystem::path& path,
                                  std::size_t line, std::string_view message) {
  std::string msg = "rangenav: ";
  msg.append(format).append(": ").append(path.string()).append(": ");
  if (line != 0) msg.append("line ").append(std::to_string(line)).append(": ");
  msg.append(message);
  throw io_error(msg);
}

/// The whole file in one read (binary bodies are then decoded from memory); a file larger than
/// `max_bytes` raises io_error before anything is allocated.
inline std::string read_whole_file(std::string_view format, const std::filesystem::path& path,
                                   std::size_t max_bytes = ReaderLimits{}.max_bytes) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw_io(format, path, 0, "is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw_io(format, path, 0, "cannot open file for reading");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw_io(format, path, 0, "cannot read file");
  if (static_cast<std::uintmax_t>(size) > max_bytes)
    throw_io(format, path, 0,
             exceeds_limit("file size", static_cast<std::size_t>(size), "max_bytes", max_bytes));
  in.seekg(0, std::ios::beg);
  std::string bytes(static_cast<std::size_t>(size), '\0');
  if (size > 0 && !in.read(bytes.data(), size)) throw_io(format, path, 0, "cannot read file");
  return bytes;
}

/// Writes head then body (a text header and a binary block) to a new file.
inline void write_whole_file(std::string_view format, const std::filesystem::path& path,
                             std::string_view head, std::string_view body = {}) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw_io(format, path, 0, "cannot open file for writing");
  out.write(head.data(), static_cast<std::streamsize>(head.size()));
  out.write(body.data(), static_cast<std::streamsize>(body.size()));
  out.flush();
  if (!out) throw_io(format, path, 0, "cannot write file");
}

// ---- typed values ---------------------------------------------------------------------------

/// The scalar types both formats use (PCD TYPE/SIZE pairs, PLY property types).
enum class ValueType : std::uint8_t {
  int8,
  uint8,
  int16,
  uint16,
  int32,
  uint32,
  int64,
  uint64,
  float32,
  float64
};

constexpr std::size_t value_size(ValueType t) {
  switch (t) {
    case ValueType::int8:
    case ValueType::uint8:
      return 1;
    case ValueType::int16:
    case ValueType::uint16:
      return 2;
    case ValueType::int32:
    case ValueType::uint32:
    case ValueType::float32:
      return 4;
    case ValueType::int64:
    case ValueType::uint64:
    case ValueType::float64:
      return 8;
  }
  return 0;
}

constexpr bool is_floating(ValueType t) {
  return t == ValueType::float32 || t == ValueType::float64;
}

/// Reads a little-endian T from p (any alignment).
template <class T>
T load_le(const unsigned char* p) {
  static_assert(std::is_arithmetic_v<T>);
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, p, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(bytes, bytes + sizeof(T));
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

/// Writes v little-endian to p (any alignment).
template <class T>
void store_le(unsigned char* p, T v) {
  static_assert(std::is_arithmetic_v<T>);
  std::memcpy(p, &v, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(p, p + sizeof(T));
}

/// Appends v little-endian to out.
template <class T>
void append_le(std::string& out, T v) {
  unsigned char bytes[sizeof(T)];
  store_le(bytes, v);
  out.append(reinterpret_cast<const char*>(bytes), sizeof(T));
}

/// The value of type t at p, converted to Out.
template <class Out>
Out load_as(const unsigned char* p, ValueType t) {
  switch (t) {
    case ValueType::int8:
      return static_cast<Out>(static_cast<std::int8_t>(*p));
    case ValueType::uint8:
      return static_cast<Out>(*p);
    case ValueType::int16:
      return static_cast<Out>(load_le<std::int16_t>(p));
    case ValueType::uint16:
      return static_cast<Out>(load_le<std::uint16_t>(p));
    case ValueType::int32:
      return static_cast<Out>(load_le<std::int32_t>(p));
    case ValueType::uint32:
      return static_cast<Out>(load_le<std::uint32_t>(p));
    case ValueType::int64:
      return static_cast<Out>(load_le<std::int64_t>(p));
    case ValueType::uint64:
      return static_cast<Out>(load_le<std::uint64_t>(p));
    case ValueType::float32:
      return static_cast<Out>(load_le<float>(p));
    case ValueType::float64:
      return static_cast<Out>(load_le<double>(p));
  }
  return Out{};
}

/// Calls store(i, value) for the n values of type t at src, src + stride, ..., each converted to
/// Out. The switch on the type sits outside the loop.
template <class Out, class Store>
void load_strided(const unsigned char* src, std::size_t stride, std::size_t n, ValueType t,
                  Store&& store) {
  const auto loop = [&]<class T>(std::type_identity<T>) {
    for (std::size_t i = 0; i < n; ++i)
      store(i, static_cast<Out>(load_le<T>(src + i * stride)));
  };
  switch (t) {
    case ValueType::int8:
      return loop(std::type_identity<std::int8_t>{});
    case ValueType::uint8:
      return loop(std::type_identity<std::uint8_t>{});
    case ValueType::int16:
      return loop(std::type_identity<std::int16_t>{});
    case ValueType::uint16:
      return loop(std::type_identity<std::uint16_t>{});
    case ValueType::int32:
      return loop(std::type_identity<std::int32_t>{});
    case ValueType::uint32:
      return loop(std::type_identity<std::uint32_t>{});
    case ValueType::int64:
      return loop(std::type_identity<std::int64_t>{});
    case ValueType::uint64:
      return loop(std::type_identity<std::uint64_t>{});
    case ValueType::float32:
      return loop(std::type_identity<float>{});
    case ValueType::float64:
      return loop(std::type_identity<double>{});
  }
}

/// An integer or floating-point value converted to 0..255 with saturation (NaN gives 0).
template <class T>
std::uint8_t saturate_u8(T v) {
  if constexpr (std::is_floating_point_v<T>) {
    if (!(v > T(0))) return 0;
    if (v >= T(255)) return 255;
    return static_cast<std::uint8_t>(std::lround(v));
  } else {
    if (v <= T(0)) return 0;
    if (v >= T(255)) return 255;
    return static_cast<std::uint8_t>(v);
  }
}

// ---- limits and finiteness ------------------------------------------------------------------

/// Bytes a Cloud<3, Scalar> holds per point with the given attributes.
template <class Scalar>
constexpr std::size_t cloud_bytes_per_point(bool intensities, bool colors, bool normals) {
  using P = typename Cloud<3, Scalar>::point_type;
  return sizeof(P) + (intensities ? sizeof(float) : 0) + (colors ? sizeof(Rgba) : 0) +
         (normals ? sizeof(P) : 0);
}

/// Throws io_error (naming `line` of the header, 0 for none) unless a cloud of `points` points of
/// `bytes_per_point` bytes fits the limits; called before the cloud is allocated.
inline void check_cloud_size(std::string_view format, const std::filesystem::path& path,
                             std::size_t line, std::size_t points, std::size_t bytes_per_point,
                             const ReaderLimits& limits) {
  if (points > limits.max_points)
    throw_io(format, path, line,
             exceeds_limit("point count", points, "max_points", limits.max_points));
  std::size_t bytes = 0;
  if (!checked_mul(points, bytes_per_point, bytes) || bytes > limits.max_bytes)
    throw_io(format, path, line,
             "a cloud of " + std::to_string(points) + " points of " +
                 std::to_string(bytes_per_point) +
                 " bytes exceeds ReaderLimits::max_bytes = " + std::to_string(limits.max_bytes));
}

/// Throws io_error naming the point and field when a coordinate, normal or intensity of `cloud`
/// is infinite (a value beyond Scalar's range reads as infinite). NaN is kept: it marks a missing
/// point (PCL's convention for organised clouds) or an unknown normal.
template <class Scalar>
void require_no_infinity(std::string_view format, const std::filesystem::path& path,
                         const Cloud<3, Scalar>& cloud) {
  const auto fail = [&](std::size_t i, std::string_view field, double value) {
    throw_io(format, path, 0,
             "point " + std::to_string(i) + ": " + std::string(field) + " = " +
                 (value > 0 ? "inf" : "-inf") +
                 " is not finite (a value beyond the range of the cloud's scalar type?)");
  };
  static constexpr std::array<std::string_view, 3> axes{"x", "y", "z"};
  static constexpr std::array<std::string_view, 3> normal_axes{"normal_x", "normal_y", "normal_z"};
  for (std::size_t i = 0; i < cloud.points.size(); ++i)
    for (Eigen::Index k = 0; k < 3; ++k)
      if (std::isinf(cloud.points[i][k]))
        fail(i, axes[static_cast<std::size_t>(k)], double(cloud.points[i][k]));
  for (std::size_t i = 0; i < cloud.normals.size(); ++i)
    for (Eigen::Index k = 0; k < 3; ++k)
      if (std::isinf(cloud.normals[i][k]))
        fail(i, normal_axes[static_cast<std::size_t>(k)], double(cloud.normals[i][k]));
  for (std::size_t i = 0; i < cloud.intensities.size(); ++i)
    if (std::isinf(cloud.intensities[i])) fail(i, "intensity", double(cloud.intensities[i]));
}

// ---- text -----------------------------------------------------------------------------------

/// Walks a buffer line by line, counting 1-based line numbers.
class LineCursor {
 public:
  explicit LineCursor(std::string_view text, std::size_t pos = 0, std::size_t line = 0)
      : text_(text), pos_(pos), line_(line) {}

  /// The next line without its '\n' (and '\r'); false at the end of the buffer.
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    const std::size_t end = text_.find('\n', pos_);
    const std::size_t stop = end == std::string_view::npos ? text_.size() : end;
    line = text_.substr(pos_, stop - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos_ = end == std::string_view::npos ? text_.size() : end + 1;
    ++line_;
    return true;
  }
  [[nodiscard]] std::size_t line() const { return line_; }     ///< number of the last line read
  [[nodiscard]] std::size_t position() const { return pos_; }  ///< offset after the last line

 private:
  std::string_view text_;
  std::size_t pos_;
  std::size_t line_;
};

/// Parses the whole token as T (integers in base 10, floating point in any std::from_chars form
/// including nan and inf); a leading '+' is accepted. False when the token is not such a number
/// or is out of T's range.
template <class T>
bool parse_number(std::string_view token, T& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const char* end = token.data() + token.size();
  const auto [ptr, ec] = std::from_chars(token.data(), end, value);
  return ec == std::errc{} && ptr == end;
}

/// Parses a token of declared type t and converts it to Out (float tokens are parsed at the
/// declared precision first, so ascii and binary files of the same data read the same values).
template <class Out>
bool parse_as(std::string_view token, ValueType t, Out& out) {
  switch (t) {
    case ValueType::float32: {
      float v;
      if (!parse_number(token, v)) return false;
      out = static_cast<Out>(v);
      return true;
    }
    case ValueType::float64: {
      double v;
      if (!parse_number(token, v)) return false;
      out = static_cast<Out>(v);
      return true;
    }
    case ValueType::uint8:
    case ValueType::uint16:
    case ValueType::uint32:
    case ValueType::uint64: {
      std::uint64_t v;
      if (!parse_number(token, v)) return false;
      if (value_size(t) < 8 && v >> (8 * value_size(t)) != 0) return false;
      out = static_cast<Out>(v);
      return true;
    }
    default: {
      std::int64_t v;
      if (!parse_number(token, v)) return false;
      const std::int64_t bound = value_size(t) < 8 ? std::int64_t{1} << (8 * value_size(t) - 1) : 0;
      if (bound != 0 && (v < -bound || v >= bound)) return false;
      out = static_cast<Out>(v);
      return true;
    }
  }
}

/// Appends the shortest text that parses back to exactly v ("nan", "-nan", "inf" for those).
template <class T>
void append_number(std::string& out, T v) {
  char buffer[64];
  const auto [ptr, ec] = std::to_chars(buffer, buffer + sizeof(buffer), v);
  out.append(buffer, ec == std::errc{} ? ptr : buffer);
}

/// Quotes a token for an error message, shortened if long.
inline std::string quote_token(std::string_view token) {
  std::string s = "'";
  if (token.size() > 40) {
    s.append(token.substr(0, 37)).append("...");
  } else {
    s.append(token);
  }
  return s + "'";
}

}  // namespace rangenav::io::detail
