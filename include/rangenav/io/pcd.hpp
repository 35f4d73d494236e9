#pragma once
// PCD (Point Cloud Library) files: read into and write from Cloud<3, Scalar>.
//
// Format: PCL's "PCD file format" specification (v0.7; v.5 / v.6 headers read too). A header of
// keyword lines (VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, VIEWPOINT, POINTS, DATA) is
// followed by the points, either as text (DATA ascii, one point per line), as packed little-endian
// records (DATA binary, point after point), or LZF-compressed (DATA binary_compressed: uint32
// compressed size, uint32 uncompressed size, then the LZF stream of the fields stored column-wise:
// all x, then all y, ...).
//
// Fields read: x y z (required), intensity, rgb or rgba (4 bytes, packed as b, g, r, a, stored as
// float or uint32; "rgb" has no alpha and reads as opaque), normal_x normal_y normal_z (all three).
// Every other field (curvature, padding "_", descriptors of any SIZE / TYPE / COUNT) is skipped.
// Organised clouds (HEIGHT > 1) stay organised, NaN points in place.

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rangenav/core/cloud.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/io/detail/fields.hpp"
#include "rangenav/io/detail/lzf.hpp"
#include "rangenav/io/reader_limits.hpp"

namespace rangenav::io {

/// The DATA section's encoding.
enum class PcdFormat { ascii, binary, binary_compressed };

/// One FIELDS entry with its SIZE, TYPE and COUNT.
struct PcdField {
  std::string name;       ///< e.g. "x", "y", "z", "intensity", "normal_x"
  std::size_t size = 4;   ///< bytes per element: 1, 2, 4 or 8
  char type = 'F';        ///< 'I' signed integer, 'U' unsigned integer, 'F' floating point
  std::size_t count = 1;  ///< elements per point
};

/// A parsed PCD header.
struct PcdHeader {
  std::string version;           ///< the VERSION value as written, e.g. "0.7"
  std::vector<PcdField> fields;  ///< FIELDS with their SIZE, TYPE and COUNT, in file order
  std::size_t width = 0;         ///< WIDTH: points per row (all points for an unorganised cloud)
  std::size_t height = 1;        ///< HEIGHT: rows; 1 for an unorganised cloud
  std::array<double, 7> viewpoint{0, 0, 0, 1, 0, 0, 0};  ///< tx ty tz qw qx qy qz
  std::size_t points = 0;             ///< POINTS: number of points, WIDTH * HEIGHT
  PcdFormat data = PcdFormat::ascii;  ///< the DATA line's encoding
  std::size_t data_offset = 0;        ///< byte offset of the data after the DATA line
  std::size_t data_line = 0;          ///< line number of the DATA line

  /// Bytes per point in DATA binary.
  [[nodiscard]] std::size_t point_size() const {
    std::size_t n = 0;
    for (const auto& f : fields)
      n += f.size * f.count;
    return n;
  }
  /// Index of the field called name, if any.
  [[nodiscard]] std::optional<std::size_t> field_index(std::string_view name) const {
    for (std::size_t i = 0; i < fields.size(); ++i)
      if (fields[i].name == name) return i;
    return std::nullopt;
  }
};

namespace detail {

inline constexpr std::string_view pcd = "pcd";

inline std::string_view pcd_format_name(PcdFormat f) {
  switch (f) {
    case PcdFormat::ascii:
      return "ascii";
    case PcdFormat::binary:
      return "binary";
    case PcdFormat::binary_compressed:
      return "binary_compressed";
  }
  return "?";
}

inline ValueType pcd_value_type(const PcdField& f) {
  if (f.type == 'F') return f.size == 4 ? ValueType::float32 : ValueType::float64;
  const bool u = f.type == 'U';
  switch (f.size) {
    case 1:
      return u ? ValueType::uint8 : ValueType::int8;
    case 2:
      return u ? ValueType::uint16 : ValueType::int16;
    case 4:
      return u ? ValueType::uint32 : ValueType::int32;
    default:
      return u ? ValueType::uint64 : ValueType::int64;
  }
}

/// Parses the header at the start of text (which need hold no more than the header). Throws
/// io_error naming path and line.
inline PcdHeader parse_pcd_header(std::string_view text, const std::filesystem::path& path) {
  PcdHeader h;
  LineCursor cursor(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  bool have_fields = false, have_size = false, have_type = false, have_count = false;
  bool have_width = false, have_points = false;
  std::size_t points_line = 0, fields_line = 0;
  std::vector<std::size_t> sizes, counts;
  std::vector<char> types;

  const auto fail = [&](std::string_view msg) { throw_io(pcd, path, cursor.line(), msg); };
  const auto one_count = [&](std::string_view key) {
    if (tok.size() != 2)
      fail(std::string(key) + " needs one value, got " + std::to_string(tok.size() - 1));
    std::size_t v = 0;
    if (!parse_number(tok[1], v))
      fail(std::string(key) + " " + quote_token(tok[1]) + " is not a non-negative integer");
    return v;
  };
  // "FIELDS has 3 names but SIZE has 2", checked as soon as both lines are known.
  const auto check_lengths = [&]() {
    if (!have_fields) return;
    const auto check = [&](bool have, std::size_t n, std::string_view key) {
      if (have && n != h.fields.size())
        fail("FIELDS has " + std::to_string(h.fields.size()) + " names but " + std::string(key) +
             " has " + std::to_string(n));
    };
    check(have_size, sizes.size(), "SIZE");
    check(have_type, types.size(), "TYPE");
    check(have_count, counts.size(), "COUNT");
    for (std::size_t i = 0; have_size && have_type && i < types.size(); ++i)
      if (types[i] == 'F' && sizes[i] != 4 && sizes[i] != 8)
        fail("field " + quote_token(h.fields[i].name) + " has TYPE F and SIZE " +
             std::to_string(sizes[i]) + " (F needs SIZE 4 or 8)");
  };

  while (cursor.next(line)) {
    split_whitespace(line, tok);
    if (tok.empty() || tok[0].front() == '#') continue;
    const std::string_view key = tok[0];
    if (key == "VERSION") {
      if (tok.size() != 2) fail("VERSION needs one value");
      h.version = std::string(tok[1]);
    } else if (key == "FIELDS" || key == "COLUMNS") {
      if (tok.size() < 2) fail("FIELDS has no names");
      h.fields.clear();
      for (std::size_t i = 1; i < tok.size(); ++i)
        h.fields.push_back({std::string(tok[i])});
      have_fields = true;
      fields_line = cursor.line();
      check_lengths();
    } else if (key == "SIZE") {
      sizes.clear();
      for (std::size_t i = 1; i < tok.size(); ++i) {
        std::size_t s = 0;
        if (!parse_number(tok[i], s) || (s != 1 && s != 2 && s != 4 && s != 8))
          fail("SIZE " + quote_token(tok[i]) + " is not 1, 2, 4 or 8");
        sizes.push_back(s);
      }
      have_size = true;
      check_lengths();
    } else if (key == "TYPE") {
      types.clear();
      for (std::size_t i = 1; i < tok.size(); ++i) {
        if (tok[i] != "F" && tok[i] != "I" && tok[i] != "U")
          fail("TYPE " + quote_token(tok[i]) + " is not F, I or U");
        types.push_back(tok[i].front());
      }
      have_type = true;
      check_lengths();
    } else if (key == "COUNT") {
      counts.clear();
      for (std::size_t i = 1; i < tok.size(); ++i) {
        std::size_t c = 0;
        if (!parse_number(tok[i], c) || c == 0)
          fail("COUNT " + quote_token(tok[i]) + " is not a positive integer");
        counts.push_back(c);
      }
      have_count = true;
      check_lengths();
    } else if (key == "WIDTH") {
      h.width = one_count("WIDTH");
      have_width = true;
    } else if (key == "HEIGHT") {
      h.height = one_count("HEIGHT");
    } else if (key == "POINTS") {
      h.points = one_count("POINTS");
      have_points = true;
      points_line = cursor.line();
    } else if (key == "VIEWPOINT") {
      if (tok.size() != 8)
        fail("VIEWPOINT needs 7 values (tx ty tz qw qx qy qz), got " +
             std::to_string(tok.size() - 1));
      for (std::size_t i = 0; i < 7; ++i)
        if (!parse_number(tok[i + 1], h.viewpoint[i]) || !std::isfinite(h.viewpoint[i]))
          fail("VIEWPOINT value " + quote_token(tok[i + 1]) + " is not a finite number");
    } else if (key == "DATA") {
      if (tok.size() != 2) fail("DATA needs one value (ascii, binary or binary_compressed)");
      if (tok[1] == "ascii") {
        h.data = PcdFormat::ascii;
      } else if (tok[1] == "binary") {
        h.data = PcdFormat::binary;
      } else if (tok[1] == "binary_compressed") {
        h.data = PcdFormat::binary_compressed;
      } else {
        fail("unknown DATA type " + quote_token(tok[1]) +
             " (expected ascii, binary or binary_compressed)");
      }
      if (!have_fields) fail("no FIELDS line before DATA");
      if (!have_size) fail("no SIZE line before DATA");
      if (!have_type) fail("no TYPE line before DATA");
      if (!have_width) fail("no WIDTH line before DATA");
      check_lengths();
      for (std::size_t i = 0; i < h.fields.size(); ++i) {
        h.fields[i].size = sizes[i];
        h.fields[i].type = types[i];
        h.fields[i].count = have_count ? counts[i] : 1;
      }
      std::size_t area = 0;
      if (!checked_mul(h.width, h.height, area))
        fail("WIDTH*HEIGHT = " + std::to_string(h.width) + "*" + std::to_string(h.height) +
             " overflows");
      if (!have_points) {
        h.points = area;
      } else if (h.points != area) {
        throw_io(pcd, path, points_line,
                 "POINTS " + std::to_string(h.points) + " does not equal WIDTH*HEIGHT = " +
                     std::to_string(h.width) + "*" + std::to_string(h.height));
      }
      // Every byte offset and count below derives from these sums: check them here, once.
      std::size_t point_size = 0, tokens = 0;
      for (const auto& f : h.fields) {
        std::size_t field_bytes = 0;
        if (!checked_mul(f.size, f.count, field_bytes) ||
            !checked_add(point_size, field_bytes, point_size) ||
            !checked_add(tokens, f.count, tokens))
          fail("field " + quote_token(f.name) + ": SIZE*COUNT = " + std::to_string(f.size) + "*" +
               std::to_string(f.count) + " overflows the point size");
      }
      std::size_t data_bytes = 0;
      if (!checked_mul(point_size, h.points, data_bytes))
        fail("POINTS*point size = " + std::to_string(h.points) + "*" + std::to_string(point_size) +
             " overflows");
      for (const char* axis : {"x", "y", "z"})
        if (!h.field_index(axis))
          throw_io(pcd, path, fields_line, std::string("FIELDS has no '") + axis + "'");
      h.data_offset = cursor.position();
      h.data_line = cursor.line();
      return h;
    } else {
      fail("unknown header keyword " + quote_token(key) + " (not a PCD file?)");
    }
  }
  throw_io(pcd, path, cursor.line(), "header ends without a DATA line");
}

/// Where each attribute of Cloud comes from: a field's position in a record (or column).
struct PcdSlot {
  bool present = false;
  std::size_t offset = 0;  ///< byte offset of the field within a point record
  std::size_t stride = 0;  ///< bytes of the whole field (size * count)
  std::size_t token = 0;   ///< index of its first token on an ascii line
  ValueType type = ValueType::float32;
  bool float_type = false;
};

struct PcdLayout {
  std::array<PcdSlot, 3> xyz;
  PcdSlot intensity;
  PcdSlot color;
  bool color_has_alpha = false;
  std::array<PcdSlot, 3> normal;
  bool has_normals = false;
  std::size_t tokens = 0;  ///< tokens per ascii line
};

inline PcdLayout pcd_layout(const PcdHeader& h, const std::filesystem::path& path) {
  PcdLayout l;
  std::size_t offset = 0, token = 0;
  const auto want_single = [&](const PcdField& f) {
    if (f.count != 1)
      throw_io(pcd, path, 0,
               "field " + quote_token(f.name) + " has COUNT " + std::to_string(f.count) +
                   " (expected 1)");
  };
  for (const auto& f : h.fields) {
    PcdSlot s{true, offset, f.size * f.count, token, pcd_value_type(f), f.type == 'F'};
    PcdSlot* target = nullptr;
    if (f.name == "x") target = &l.xyz[0];
    if (f.name == "y") target = &l.xyz[1];
    if (f.name == "z") target = &l.xyz[2];
    if (f.name == "intensity") target = &l.intensity;
    if (f.name == "normal_x") target = &l.normal[0];
    if (f.name == "normal_y") target = &l.normal[1];
    if (f.name == "normal_z") target = &l.normal[2];
    if (f.name == "rgb" || f.name == "rgba") {
      if (f.size != 4)
        throw_io(pcd, path, 0,
                 "field " + quote_token(f.name) + " has SIZE " + std::to_string(f.size) +
                     " (a packed colour needs SIZE 4)");
      target = &l.color;
      l.color_has_alpha = f.name == "rgba";
    }
    if (target != nullptr) {
      want_single(f);
      *target = s;
    }
    offset += f.size * f.count;
    token += f.count;
  }
  l.has_normals = l.normal[0].present && l.normal[1].present && l.normal[2].present;
  l.tokens = token;
  return l;
}

/// Packed PCL colour: the uint32 0xAARRGGBB, i.e. bytes b, g, r, a in little-endian order.
inline Rgba unpack_pcd_color(std::uint32_t v, bool has_alpha) {
  return {static_cast<std::uint8_t>(v >> 16), static_cast<std::uint8_t>(v >> 8),
          static_cast<std::uint8_t>(v),
          has_alpha ? static_cast<std::uint8_t>(v >> 24) : std::uint8_t{255}};
}

inline std::uint32_t pack_pcd_color(const Rgba& c) {
  return std::uint32_t{c[3]} << 24 | std::uint32_t{c[0]} << 16 | std::uint32_t{c[1]} << 8 | c[2];
}

template <class Scalar>
void resize_pcd_cloud(const PcdLayout& l, std::size_t n, Cloud<3, Scalar>& cloud) {
  cloud.points.resize(n);
  if (l.intensity.present) cloud.intensities.resize(n);
  if (l.color.present) cloud.colors.resize(n);
  if (l.has_normals) cloud.normals.resize(n);
}

/// Decodes fixed-size records. DATA binary: field s of point i is at base + i * point_size +
/// s.offset. binary_compressed (columns): the field's column starts at base + s.offset * n, so
/// point i's value is at base + s.offset * n + i * s.stride.
template <class Scalar>
void decode_pcd_records(const unsigned char* base, const PcdLayout& l, std::size_t point_size,
                        bool columns, Cloud<3, Scalar>& cloud) {
  const std::size_t n = cloud.points.size();
  const auto first = [&](const PcdSlot& s) { return base + s.offset * (columns ? n : 1); };
  const auto step = [&](const PcdSlot& s) { return columns ? s.stride : point_size; };
  for (Eigen::Index k = 0; k < 3; ++k) {
    const PcdSlot& s = l.xyz[static_cast<std::size_t>(k)];
    load_strided<Scalar>(first(s), step(s), n, s.type,
                         [&](std::size_t i, Scalar v) { cloud.points[i][k] = v; });
  }
  if (l.intensity.present)
    load_strided<float>(first(l.intensity), step(l.intensity), n, l.intensity.type,
                        [&](std::size_t i, float v) { cloud.intensities[i] = v; });
  if (l.color.present)
    load_strided<std::uint32_t>(first(l.color), step(l.color), n, ValueType::uint32,
                                [&](std::size_t i, std::uint32_t v) {
                                  cloud.colors[i] = unpack_pcd_color(v, l.color_has_alpha);
                                });
  if (l.has_normals)
    for (Eigen::Index k = 0; k < 3; ++k) {
      const PcdSlot& s = l.normal[static_cast<std::size_t>(k)];
      load_strided<Scalar>(first(s), step(s), n, s.type,
                           [&](std::size_t i, Scalar v) { cloud.normals[i][k] = v; });
    }
}

/// A packed colour token: an integer (PCL writes "rgb" as uint32 text even when its TYPE is F)
/// or, for TYPE F, a float whose bit pattern holds the colour.
inline bool parse_pcd_color(std::string_view token, ValueType t, std::uint32_t& bits) {
  std::int64_t integer = 0;
  if (parse_number(token, integer) && integer >= -2147483648LL && integer <= 4294967295LL) {
    bits = static_cast<std::uint32_t>(integer);
    return true;
  }
  float f = 0;
  if (t == ValueType::float32 && parse_number(token, f)) {
    bits = std::bit_cast<std::uint32_t>(f);
    return true;
  }
  return false;
}

template <class Scalar>
void decode_pcd_ascii(std::string_view text, const PcdHeader& h, const PcdLayout& l,
                      const std::filesystem::path& path, Cloud<3, Scalar>& cloud) {
  LineCursor cursor(text, h.data_offset, h.data_line);
  std::string_view line;
  std::vector<std::string_view> tok;
  tok.reserve(std::min<std::size_t>(l.tokens, 256));
  std::size_t i = 0;
  const auto bad = [&](const PcdSlot& s, std::string_view what) {
    throw_io(pcd, path, cursor.line(),
             "point " + std::to_string(i) + ": " + std::string(what) + " " +
                 quote_token(tok[s.token]) + " is not a valid value");
  };
  const auto value = [&](const PcdSlot& s, std::string_view what, auto& out) {
    if (!parse_as(tok[s.token], s.type, out)) bad(s, what);
  };
  while (cursor.next(line)) {
    split_whitespace(line, tok);
    if (tok.empty()) continue;
    if (i == h.points)
      throw_io(pcd, path, cursor.line(),
               "more data lines than the " + std::to_string(h.points) + " POINTS of the header");
    // Grown as lines arrive: a header promising more points than the file holds allocates no
    // more than the file holds.
    if (i == cloud.points.size())
      resize_pcd_cloud(l, std::min(h.points, std::max<std::size_t>(1024, 2 * i)), cloud);
    if (tok.size() != l.tokens)
      throw_io(pcd, path, cursor.line(),
               "point " + std::to_string(i) + " has " + std::to_string(tok.size()) +
                   " values but the fields need " + std::to_string(l.tokens));
    static constexpr std::array<const char*, 3> axes{"x", "y", "z"};
    static constexpr std::array<const char*, 3> normal_names{"normal_x", "normal_y", "normal_z"};
    for (std::size_t k = 0; k < 3; ++k)
      value(l.xyz[k], axes[k], cloud.points[i][Eigen::Index(k)]);
    if (l.intensity.present) value(l.intensity, "intensity", cloud.intensities[i]);
    if (l.color.present) {
      std::uint32_t bits = 0;
      if (!parse_pcd_color(tok[l.color.token], l.color.type, bits)) bad(l.color, "colour");
      cloud.colors[i] = unpack_pcd_color(bits, l.color_has_alpha);
    }
    if (l.has_normals)
      for (std::size_t k = 0; k < 3; ++k)
        value(l.normal[k], normal_names[k], cloud.normals[i][Eigen::Index(k)]);
    ++i;
  }
  if (i != h.points)
    throw_io(
        pcd, path, cursor.line(),
        "data ends after " + std::to_string(i) + " of " + std::to_string(h.points) + " points");
}

}  // namespace detail

/// Reads only the header of a PCD file. Throws io_error naming file and line for a malformed
/// header, and for a header line longer than limits.max_line_bytes or a header longer than
/// limits.max_bytes.
inline PcdHeader read_pcd_header(const std::filesystem::path& path,
                                 const ReaderLimits& limits = {}) {
  limits.validate("read_pcd_header");
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    detail::throw_io(detail::pcd, path, 0, "is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) detail::throw_io(detail::pcd, path, 0, "cannot open file for reading");
  std::string text, line;
  bool too_long = false;
  std::size_t number = 0;
  while (detail::read_bounded_line(in, line, limits.max_line_bytes, too_long)) {
    ++number;
    if (too_long)
      detail::throw_io(detail::pcd, path, number,
                       detail::exceeds_limit("header line length", line.size() + 1,
                                             "max_line_bytes", limits.max_line_bytes));
    if (text.size() + line.size() + 1 > limits.max_bytes)
      detail::throw_io(detail::pcd, path, number,
                       detail::exceeds_limit("header size", text.size() + line.size() + 1,
                                             "max_bytes", limits.max_bytes));
    text.append(line).push_back('\n');
    const auto start = line.find_first_not_of(" \t");
    if (start != std::string::npos && line.compare(start, 4, "DATA") == 0) break;
  }
  return detail::parse_pcd_header(text, path);
}

/// Reads a PCD file (DATA ascii, binary or binary_compressed) into a Cloud; fields are converted
/// to Scalar. Throws io_error naming the file (and the line for text) on any malformed content:
/// a count or size whose product overflows, a header that promises more data than the file holds,
/// a cloud beyond `limits` (checked before anything is allocated), an infinite value (NaN points
/// are kept: PCL marks missing points of organised clouds so).
template <std::floating_point Scalar = double>
Cloud<3, Scalar> read_pcd(const std::filesystem::path& path, const ReaderLimits& limits = {}) {
  using namespace detail;
  limits.validate("read_pcd");
  const std::string bytes = read_whole_file(pcd, path, limits.max_bytes);
  const PcdHeader h = parse_pcd_header(bytes, path);
  const PcdLayout l = pcd_layout(h, path);
  // parse_pcd_header checked that these products and sums fit std::size_t.
  const std::size_t point_size = h.point_size();
  const std::size_t need = point_size * h.points;
  const std::size_t have = bytes.size() - h.data_offset;
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data()) + h.data_offset;
  // Before allocating anything: the file must hold the data its header promises.
  std::size_t compressed = 0;
  switch (h.data) {
    case PcdFormat::ascii:  // the cloud grows as lines arrive (decode_pcd_ascii)
      break;
    case PcdFormat::binary:
      if (have < need)
        throw_io(pcd, path, 0,
                 "binary data has " + std::to_string(have) + " bytes but " +
                     std::to_string(h.points) + " points of " + std::to_string(point_size) +
                     " bytes need " + std::to_string(need) + " (truncated file?)");
      break;
    case PcdFormat::binary_compressed: {
      if (have < 8)
        throw_io(pcd, path, 0, "binary_compressed data ends before its 8-byte size header");
      compressed = load_le<std::uint32_t>(data);
      const std::size_t uncompressed = load_le<std::uint32_t>(data + 4);
      if (uncompressed != need)
        throw_io(pcd, path, 0,
                 "binary_compressed data unpacks to " + std::to_string(uncompressed) +
                     " bytes but " + std::to_string(h.points) + " points of " +
                     std::to_string(point_size) + " bytes need " + std::to_string(need));
      if (compressed > have - 8)
        throw_io(pcd, path, 0,
                 "binary_compressed data has " + std::to_string(have - 8) +
                     " compressed bytes but its header says " + std::to_string(compressed) +
                     " (truncated file?)");
      if (need > limits.max_bytes)
        throw_io(
            pcd, path, 0,
            exceeds_limit("binary_compressed unpacked size", need, "max_bytes", limits.max_bytes));
      // A 3-byte LZF back reference copies at most 264 bytes: no stream expands more.
      if (need / lzf_max_expansion > compressed)
        throw_io(pcd, path, 0,
                 "binary_compressed data is corrupt (" + std::to_string(compressed) +
                     " LZF bytes cannot unpack to " + std::to_string(need) + ")");
      break;
    }
  }
  check_cloud_size(
      pcd, path, h.data_line, h.points,
      cloud_bytes_per_point<Scalar>(l.intensity.present, l.color.present, l.has_normals), limits);
  Cloud<3, Scalar> cloud;
  cloud.width = h.width;
  cloud.height = h.height;
  if (h.data != PcdFormat::ascii) resize_pcd_cloud(l, h.points, cloud);
  switch (h.data) {
    case PcdFormat::ascii:
      decode_pcd_ascii(bytes, h, l, path, cloud);
      break;
    case PcdFormat::binary:
      decode_pcd_records(data, l, point_size, false, cloud);
      break;
    case PcdFormat::binary_compressed: {
      std::vector<std::uint8_t> columns(need);
      if (lzf_decompress(data + 8, compressed, columns.data(), columns.size()) != need)
        throw_io(pcd, path, 0,
                 "binary_compressed data is corrupt (LZF stream does not unpack to " +
                     std::to_string(need) + " bytes)");
      decode_pcd_records(columns.data(), l, point_size, true, cloud);
      break;
    }
  }
  require_no_infinity(pcd, path, cloud);
  return cloud;
}

/// Writes a cloud as PCD v0.7: fields x y z, then intensity, rgba (uint32) and normal_x
/// normal_y normal_z when the cloud has them; WIDTH / HEIGHT keep its organisation. Throws
/// invalid_argument for an inconsistent cloud, io_error when the file cannot be written.
template <std::floating_point Scalar>
void write_pcd(const std::filesystem::path& path, const Cloud<3, Scalar>& cloud,
               PcdFormat format = PcdFormat::binary,
               StoredScalar precision = StoredScalar::as_cloud) {
  using namespace detail;
  cloud.validate("write_pcd");
  const bool wide = precision == StoredScalar::float64 ||
                    (precision == StoredScalar::as_cloud && sizeof(Scalar) > 4);
  const std::size_t coord = wide ? 8 : 4;
  const std::size_t n = cloud.size();

  enum class Source { point, intensity, color, normal };
  struct Column {
    const char* name;
    std::size_t size;
    char type;
    Source source;
    Eigen::Index axis;
  };
  std::vector<Column> columns{{"x", coord, 'F', Source::point, 0},
                              {"y", coord, 'F', Source::point, 1},
                              {"z", coord, 'F', Source::point, 2}};
  if (cloud.has_intensities()) columns.push_back({"intensity", 4, 'F', Source::intensity, 0});
  if (cloud.has_colors()) columns.push_back({"rgba", 4, 'U', Source::color, 0});
  if (cloud.has_normals()) {
    columns.push_back({"normal_x", coord, 'F', Source::normal, 0});
    columns.push_back({"normal_y", coord, 'F', Source::normal, 1});
    columns.push_back({"normal_z", coord, 'F', Source::normal, 2});
  }
  std::string out = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS";
  for (const auto& c : columns)
    out.append(" ").append(c.name);
  out.append("\nSIZE");
  for (const auto& c : columns)
    out.append(" ").append(std::to_string(c.size));
  out.append("\nTYPE");
  for (const auto& c : columns)
    out.append(" ").push_back(c.type);
  out.append("\nCOUNT");
  for (std::size_t i = 0; i < columns.size(); ++i)
    out.append(" 1");
  out.append("\nWIDTH ").append(std::to_string(cloud.width));
  out.append("\nHEIGHT ").append(std::to_string(cloud.height));
  out.append("\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS ").append(std::to_string(n));
  out.append("\nDATA ").append(pcd_format_name(format)).append("\n");

  // Column c's value for point i, handed to emit as float, double or uint32.
  const auto visit = [&](const Column& c, std::size_t i, auto&& emit) {
    const auto coordinate = [&](Scalar v) {
      if (wide)
        emit(static_cast<double>(v));
      else
        emit(static_cast<float>(v));
    };
    switch (c.source) {
      case Source::point:
        return coordinate(cloud.points[i][c.axis]);
      case Source::intensity:
        return emit(cloud.intensities[i]);
      case Source::color:
        return emit(pack_pcd_color(cloud.colors[i]));
      case Source::normal:
        return coordinate(cloud.normals[i][c.axis]);
    }
  };

  if (format == PcdFormat::ascii) {
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t c = 0; c < columns.size(); ++c) {
        if (c != 0) out.push_back(' ');
        visit(columns[c], i, [&](auto v) { append_number(out, v); });
      }
      out.push_back('\n');
    }
    return write_whole_file(pcd, path, out);
  }
  std::size_t point_size = 0;
  for (const auto& c : columns)
    point_size += c.size;
  std::vector<unsigned char> records(point_size * n);
  unsigned char* p = records.data();
  const auto put = [&p](auto v) {
    store_le(p, v);
    p += sizeof(v);
  };
  if (format == PcdFormat::binary) {
    for (std::size_t i = 0; i < n; ++i)
      for (const auto& c : columns)
        visit(c, i, put);
    return write_whole_file(pcd, path, out,
                            {reinterpret_cast<const char*>(records.data()), records.size()});
  }
  for (const auto& c : columns)  // binary_compressed: column after column
    for (std::size_t i = 0; i < n; ++i)
      visit(c, i, put);
  std::vector<std::uint8_t> packed;
  lzf_compress(records.data(), records.size(), packed);
  if (packed.size() > 0xffffffffu || records.size() > 0xffffffffu)
    rangenav::detail::throw_invalid_argument("write_pcd", "cloud.size()", n,
                                             "is too large for binary_compressed (4 GiB limit)");
  append_le(out, static_cast<std::uint32_t>(packed.size()));
  append_le(out, static_cast<std::uint32_t>(records.size()));
  write_whole_file(pcd, path, out, {reinterpret_cast<const char*>(packed.data()), packed.size()});
}

}  // namespace rangenav::io
