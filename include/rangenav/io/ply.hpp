#pragma once
// PLY (Stanford polygon file format) clouds: read into and write from Cloud<3, Scalar>.
//
// Format: Greg Turk's PLY specification (1994), as written by CloudCompare, PCL, Open3D and
// MeshLab. A text header ("ply", "format ascii 1.0" or "format binary_little_endian 1.0",
// "element <name> <count>", "property <type> <name>", "property list <count type> <item type>
// <name>", comments, "end_header") is followed by the elements in header order, each instance
// one line of text or packed little-endian values. binary_big_endian is rejected.
//
// The "vertex" element gives the points: x y z (required), intensity or scalar_intensity, red green
// blue [alpha] (integer types saturated to 0..255, float types read as fractions 0..1; no alpha
// reads as opaque), nx ny nz or normal_x normal_y normal_z. Every other property and element
// (faces with list properties, edges, ...) is skipped. PLY has no notion of an organised cloud:
// the writer records width x height in a comment ("comment rangenav organized width W height H")
// that the reader honours, so organised clouds round-trip.

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "rangenav/core/cloud.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/io/detail/fields.hpp"
#include "rangenav/io/line_reader.hpp"
#include "rangenav/io/reader_limits.hpp"

namespace rangenav::io {

/// The body encoding of a PLY file.
enum class PlyFormat { ascii, binary_little_endian };

namespace detail {

inline constexpr std::string_view ply = "ply";

struct PlyProperty {
  std::string name;
  ValueType type = ValueType::float32;  ///< the value type (list items for a list)
  bool is_list = false;
  ValueType count_type = ValueType::uint8;  ///< a list's length type
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
  std::size_t line = 0;  ///< header line of the element
  [[nodiscard]] bool has_lists() const {
    for (const auto& p : properties)
      if (p.is_list) return true;
    return false;
  }
  /// Bytes per instance when no property is a list.
  [[nodiscard]] std::size_t record_size() const {
    std::size_t n = 0;
    for (const auto& p : properties)
      n += value_size(p.type);
    return n;
  }
};

struct PlyHeader {
  PlyFormat format = PlyFormat::ascii;
  std::vector<PlyElement> elements;
  std::size_t organized_width = 0;  ///< from "comment rangenav organized width W height H"
  std::size_t organized_height = 0;
  std::size_t data_offset = 0;
  std::size_t data_line = 0;  ///< number of the end_header line
};

inline bool ply_value_type(std::string_view name, ValueType& t) {
  struct Entry {
    std::string_view a, b;
    ValueType t;
  };
  static constexpr std::array<Entry, 8> table{{{"char", "int8", ValueType::int8},
                                               {"uchar", "uint8", ValueType::uint8},
                                               {"short", "int16", ValueType::int16},
                                               {"ushort", "uint16", ValueType::uint16},
                                               {"int", "int32", ValueType::int32},
                                               {"uint", "uint32", ValueType::uint32},
                                               {"float", "float32", ValueType::float32},
                                               {"double", "float64", ValueType::float64}}};
  for (const auto& e : table)
    if (name == e.a || name == e.b) {
      t = e.t;
      return true;
    }
  return false;
}

inline PlyHeader parse_ply_header(std::string_view text, const std::filesystem::path& path) {
  PlyHeader h;
  LineCursor cursor(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  const auto fail = [&](std::string_view msg) { throw_io(ply, path, cursor.line(), msg); };
  if (!cursor.next(line)) throw_io(ply, path, 0, "not a PLY file (empty)");
  if (line != "ply")
    fail("not a PLY file (first line is " + quote_token(line) + ", expected 'ply')");
  bool have_format = false;
  while (cursor.next(line)) {
    split_whitespace(line, tok);
    if (tok.empty()) continue;
    const std::string_view key = tok[0];
    if (key == "format") {
      if (tok.size() != 3) fail("format needs a type and a version");
      if (tok[1] == "ascii") {
        h.format = PlyFormat::ascii;
      } else if (tok[1] == "binary_little_endian") {
        h.format = PlyFormat::binary_little_endian;
      } else if (tok[1] == "binary_big_endian") {
        fail("format binary_big_endian is unsupported (use ascii or binary_little_endian)");
      } else {
        fail("unknown format " + quote_token(tok[1]) + " (expected ascii or binary_little_endian)");
      }
      if (tok[2] != "1.0") fail("unsupported version " + quote_token(tok[2]) + " (expected 1.0)");
      have_format = true;
    } else if (key == "comment") {
      std::size_t w = 0, ht = 0;
      if (tok.size() == 7 && tok[1] == "rangenav" && tok[2] == "organized" && tok[3] == "width" &&
          tok[5] == "height" && parse_number(tok[4], w) && parse_number(tok[6], ht)) {
        h.organized_width = w;
        h.organized_height = ht;
      }
    } else if (key == "obj_info") {
      continue;
    } else if (key == "element") {
      if (!have_format) fail("element before the format line");
      std::size_t count = 0;
      if (tok.size() != 3 || !parse_number(tok[2], count))
        fail("element needs a name and a non-negative count");
      h.elements.push_back({std::string(tok[1]), count, {}, cursor.line()});
    } else if (key == "property") {
      if (h.elements.empty()) fail("property before any element");
      PlyProperty p;
      std::size_t type_at = 1;
      if (tok.size() >= 2 && tok[1] == "list") {
        if (tok.size() != 5) fail("property list needs a count type, an item type and a name");
        p.is_list = true;
        if (!ply_value_type(tok[2], p.count_type) || is_floating(p.count_type))
          fail("list count type " + quote_token(tok[2]) + " is not an integer type");
        type_at = 3;
      } else if (tok.size() != 3) {
        fail("property needs a type and a name");
      }
      if (!ply_value_type(tok[type_at], p.type))
        fail("unknown property type " + quote_token(tok[type_at]));
      p.name = std::string(tok.back());
      h.elements.back().properties.push_back(std::move(p));
    } else if (key == "end_header") {
      if (!have_format) fail("end_header before the format line");
      h.data_offset = cursor.position();
      h.data_line = cursor.line();
      return h;
    } else {
      fail("unknown header keyword " + quote_token(key));
    }
  }
  throw_io(ply, path, cursor.line(), "header ends without end_header");
}

/// Indices into the vertex element's properties of what Cloud keeps; -1 when absent.
struct PlyVertexMap {
  std::array<int, 3> xyz{-1, -1, -1};
  int intensity = -1;
  std::array<int, 4> rgba{-1, -1, -1, -1};
  std::array<int, 3> normal{-1, -1, -1};
  [[nodiscard]] bool has_colors() const { return rgba[0] >= 0 && rgba[1] >= 0 && rgba[2] >= 0; }
  [[nodiscard]] bool has_normals() const {
    return normal[0] >= 0 && normal[1] >= 0 && normal[2] >= 0;
  }
};

inline PlyVertexMap ply_vertex_map(const PlyElement& v, const std::filesystem::path& path) {
  PlyVertexMap m;
  for (std::size_t i = 0; i < v.properties.size(); ++i) {
    const auto& p = v.properties[i];
    int* slot = nullptr;
    const std::string_view n = p.name;
    if (n == "x") slot = &m.xyz[0];
    if (n == "y") slot = &m.xyz[1];
    if (n == "z") slot = &m.xyz[2];
    if (n == "intensity" || (n == "scalar_intensity" && m.intensity < 0)) slot = &m.intensity;
    if (n == "red") slot = &m.rgba[0];
    if (n == "green") slot = &m.rgba[1];
    if (n == "blue") slot = &m.rgba[2];
    if (n == "alpha") slot = &m.rgba[3];
    if (n == "nx" || n == "normal_x") slot = &m.normal[0];
    if (n == "ny" || n == "normal_y") slot = &m.normal[1];
    if (n == "nz" || n == "normal_z") slot = &m.normal[2];
    if (slot == nullptr) continue;
    if (p.is_list)
      throw_io(ply, path, v.line,
               "vertex property " + quote_token(n) + " is a list (expected a single value)");
    *slot = static_cast<int>(i);
  }
  for (std::size_t k = 0; k < 3; ++k)
    if (m.xyz[k] < 0)
      throw_io(ply, path, v.line, std::string("element vertex has no property '") + "xyz"[k] + "'");
  return m;
}

/// Stores vertex i's mapped values, reading property j through value(j, out) for out of type
/// Scalar, float, or std::uint8_t (colour channels).
template <class Scalar, class Value>
void store_ply_vertex(const PlyVertexMap& m, std::size_t i, Cloud<3, Scalar>& cloud,
                      Value&& value) {
  for (std::size_t k = 0; k < 3; ++k)
    value(m.xyz[k], cloud.points[i][Eigen::Index(k)]);
  if (m.intensity >= 0) value(m.intensity, cloud.intensities[i]);
  if (m.has_colors()) {
    for (std::size_t k = 0; k < 3; ++k)
      value(m.rgba[k], cloud.colors[i][k]);
    if (m.rgba[3] >= 0)
      value(m.rgba[3], cloud.colors[i][3]);
    else
      cloud.colors[i][3] = 255;
  }
  if (m.has_normals())
    for (std::size_t k = 0; k < 3; ++k)
      value(m.normal[k], cloud.normals[i][Eigen::Index(k)]);
}

/// Sizes the cloud's points and the attributes the vertex map keeps to n.
template <class Scalar>
void resize_ply_cloud(const PlyVertexMap& m, std::size_t n, Cloud<3, Scalar>& cloud) {
  cloud.points.resize(n);
  if (m.intensity >= 0) cloud.intensities.resize(n);
  if (m.has_colors()) cloud.colors.resize(n);
  if (m.has_normals()) cloud.normals.resize(n);
}

/// Grows the cloud to hold vertex i of n as vertices arrive (amortised doubling): a header that
/// promises more vertices than the file holds allocates no more than the file holds.
template <class Scalar>
void grow_ply_cloud(const PlyVertexMap& m, std::size_t i, std::size_t n, Cloud<3, Scalar>& cloud) {
  if (i == cloud.points.size())
    resize_ply_cloud(m, std::min(n, std::max<std::size_t>(1024, 2 * i)), cloud);
}

/// A colour channel from a value of type t: integers saturate, floats are fractions of 255.
template <class In>
std::uint8_t ply_channel(In v, ValueType t) {
  if (is_floating(t)) return saturate_u8(static_cast<double>(v) * 255.0);
  return saturate_u8(v);
}

template <class Scalar>
void read_ply_binary(std::string_view bytes, const PlyHeader& h, std::size_t vertex_element,
                     const PlyVertexMap& m, const std::filesystem::path& path,
                     Cloud<3, Scalar>& cloud) {
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  std::size_t pos = h.data_offset;
  std::vector<std::size_t> offsets;
  for (std::size_t e = 0; e < h.elements.size(); ++e) {
    const PlyElement& el = h.elements[e];
    const bool keep = e == vertex_element;
    const auto truncated = [&](std::size_t instance) {
      throw_io(ply, path, 0,
               "binary data ends inside element '" + el.name + "' " + std::to_string(instance) +
                   " of " + std::to_string(el.count) + " (truncated file?)");
    };
    offsets.assign(el.properties.size(), 0);
    if (!el.has_lists()) {
      const std::size_t record = el.record_size();
      const std::size_t left = bytes.size() - pos;
      if (record != 0 && left / record < el.count) truncated(left / record);
      // record * count fits: it is at most `left`.
      std::size_t o = 0;
      for (std::size_t j = 0; j < el.properties.size(); ++j) {
        offsets[j] = o;
        o += value_size(el.properties[j].type);
      }
      if (keep) {
        resize_ply_cloud(m, el.count, cloud);  // the data holds them: checked above
        for (std::size_t i = 0; i < el.count; ++i) {
          const unsigned char* base = data + pos + i * record;
          store_ply_vertex(m, i, cloud, [&](int j, auto& out) {
            const auto& p = el.properties[static_cast<std::size_t>(j)];
            const unsigned char* at = base + offsets[static_cast<std::size_t>(j)];
            if constexpr (std::is_same_v<std::remove_reference_t<decltype(out)>, std::uint8_t>)
              out = p.type == ValueType::uint8 ? *at
                                               : ply_channel(load_as<double>(at, p.type), p.type);
            else
              out = load_as<std::remove_reference_t<decltype(out)>>(at, p.type);
          });
        }
      }
      pos += record * el.count;
      continue;
    }
    // Elements with list properties: walk instance by instance.
    for (std::size_t i = 0; i < el.count; ++i) {
      const std::size_t start = pos;
      for (std::size_t j = 0; j < el.properties.size(); ++j) {
        const auto& p = el.properties[j];
        offsets[j] = pos - start;
        if (p.is_list) {
          if (bytes.size() - pos < value_size(p.count_type)) truncated(i);
          const auto n = load_as<std::int64_t>(data + pos, p.count_type);
          pos += value_size(p.count_type);
          if (n < 0)
            throw_io(ply, path, 0,
                     "element '" + el.name + "' " + std::to_string(i) + ": list " +
                         quote_token(p.name) + " has a negative length " + std::to_string(n));
          if ((bytes.size() - pos) / value_size(p.type) < static_cast<std::uint64_t>(n))
            truncated(i);
          pos += static_cast<std::size_t>(n) * value_size(p.type);
        } else {
          if (bytes.size() - pos < value_size(p.type)) truncated(i);
          pos += value_size(p.type);
        }
      }
      if (keep) {
        grow_ply_cloud(m, i, el.count, cloud);
        store_ply_vertex(m, i, cloud, [&](int j, auto& out) {
          const auto& p = el.properties[static_cast<std::size_t>(j)];
          const unsigned char* at = data + start + offsets[static_cast<std::size_t>(j)];
          if constexpr (std::is_same_v<std::remove_reference_t<decltype(out)>, std::uint8_t>)
            out = ply_channel(load_as<double>(at, p.type), p.type);
          else
            out = load_as<std::remove_reference_t<decltype(out)>>(at, p.type);
        });
      }
    }
  }
}

template <class Scalar>
void read_ply_ascii(std::string_view text, const PlyHeader& h, std::size_t vertex_element,
                    const PlyVertexMap& m, const std::filesystem::path& path,
                    Cloud<3, Scalar>& cloud) {
  LineCursor cursor(text, h.data_offset, h.data_line);
  std::string_view line;
  std::vector<std::string_view> tok;
  std::vector<std::size_t> token_of;
  const auto next_instance = [&]() {
    while (cursor.next(line)) {
      split_whitespace(line, tok);
      if (!tok.empty()) return true;
    }
    return false;
  };
  for (std::size_t e = 0; e < h.elements.size(); ++e) {
    const PlyElement& el = h.elements[e];
    const bool keep = e == vertex_element;
    token_of.assign(el.properties.size(), 0);
    for (std::size_t i = 0; i < el.count; ++i) {
      const auto instance = [&] { return el.name + " " + std::to_string(i); };
      if (!next_instance())
        throw_io(ply, path, cursor.line(),
                 "data ends after " + std::to_string(i) + " of " + std::to_string(el.count) + " '" +
                     el.name + "' elements");
      std::size_t t = 0;
      for (std::size_t j = 0; j < el.properties.size(); ++j) {
        const auto& p = el.properties[j];
        token_of[j] = t;
        if (p.is_list) {
          std::int64_t n = 0;
          if (t >= tok.size() || !parse_as(tok[t], p.count_type, n) || n < 0)
            throw_io(ply, path, cursor.line(),
                     instance() + ": list length of " + quote_token(p.name) +
                         " is missing or not a valid count");
          if (static_cast<std::uint64_t>(n) > tok.size() - t - 1)
            throw_io(ply, path, cursor.line(),
                     instance() + ": list " + quote_token(p.name) + " has " + std::to_string(n) +
                         " items but the line holds " + std::to_string(tok.size() - t - 1) +
                         " more values");
          t += 1 + static_cast<std::size_t>(n);
        } else {
          ++t;
        }
      }
      if (t != tok.size())
        throw_io(ply, path, cursor.line(),
                 instance() + " has " + std::to_string(tok.size()) +
                     " values but its properties need " + std::to_string(t));
      if (!keep) continue;
      grow_ply_cloud(m, i, el.count, cloud);
      store_ply_vertex(m, i, cloud, [&](int j, auto& out) {
        const auto& p = el.properties[static_cast<std::size_t>(j)];
        const std::string_view token = tok[token_of[static_cast<std::size_t>(j)]];
        bool ok = false;
        if constexpr (std::is_same_v<std::remove_reference_t<decltype(out)>, std::uint8_t>) {
          double v = 0;
          ok = parse_as(token, p.type, v);
          out = ply_channel(v, p.type);
        } else {
          ok = parse_as(token, p.type, out);
        }
        if (!ok)
          throw_io(ply, path, cursor.line(),
                   instance() + ": " + p.name + " " + quote_token(token) + " is not a valid value");
      });
    }
  }
  if (next_instance())
    throw_io(ply, path, cursor.line(), "more data lines than the header's elements");
}

}  // namespace detail

/// Reads the vertices of a PLY file (ascii or binary_little_endian) into a Cloud; values are
/// converted to Scalar. Throws io_error naming the file (and the line for text) on malformed or
/// unsupported content, on a vertex count the file cannot hold or beyond `limits` (checked before
/// anything is allocated) and on an infinite value (NaN is kept, as a missing point).
template <std::floating_point Scalar = double>
Cloud<3, Scalar> read_ply(const std::filesystem::path& path, const ReaderLimits& limits = {}) {
  using namespace detail;
  limits.validate("read_ply");
  const std::string bytes = read_whole_file(ply, path, limits.max_bytes);
  const PlyHeader h = parse_ply_header(bytes, path);
  std::size_t vertex = h.elements.size();
  for (std::size_t e = 0; e < h.elements.size(); ++e)
    if (h.elements[e].name == "vertex") {
      vertex = e;
      break;
    }
  if (vertex == h.elements.size()) throw_io(ply, path, h.data_line, "no element vertex");
  const PlyElement& v = h.elements[vertex];
  const PlyVertexMap m = ply_vertex_map(v, path);
  const std::size_t n = v.count;
  // Checked before anything is allocated; the cloud itself is sized as the data proves to hold
  // the vertices (read_ply_binary, read_ply_ascii).
  check_cloud_size(ply, path, v.line, n,
                   cloud_bytes_per_point<Scalar>(m.intensity >= 0, m.has_colors(), m.has_normals()),
                   limits);
  Cloud<3, Scalar> cloud;
  std::size_t organized = 0;
  if (h.organized_height > 1 && checked_mul(h.organized_width, h.organized_height, organized) &&
      organized == n) {
    cloud.width = h.organized_width;
    cloud.height = h.organized_height;
  } else {
    cloud.width = n;
    cloud.height = 1;
  }
  if (h.format == PlyFormat::ascii)
    read_ply_ascii(bytes, h, vertex, m, path, cloud);
  else
    read_ply_binary(bytes, h, vertex, m, path, cloud);
  require_no_infinity(ply, path, cloud);
  return cloud;
}

/// Writes a cloud as a PLY vertex element: x y z, then intensity (float), red green blue alpha
/// (uchar) and nx ny nz when the cloud has them; an organised cloud's width x height goes into a
/// comment. Throws invalid_argument for an inconsistent cloud, io_error when the file cannot be
/// written.
template <std::floating_point Scalar>
void write_ply(const std::filesystem::path& path, const Cloud<3, Scalar>& cloud,
               PlyFormat format = PlyFormat::binary_little_endian,
               StoredScalar precision = StoredScalar::as_cloud) {
  using namespace detail;
  cloud.validate("write_ply");
  const bool wide = precision == StoredScalar::float64 ||
                    (precision == StoredScalar::as_cloud && sizeof(Scalar) > 4);
  const char* coord = wide ? "double" : "float";
  const std::size_t n = cloud.size();
  std::string out = "ply\nformat ";
  out.append(format == PlyFormat::ascii ? "ascii" : "binary_little_endian");
  out.append(" 1.0\ncomment written by rangenav\n");
  if (cloud.is_organized())
    out.append("comment rangenav organized width ")
        .append(std::to_string(cloud.width))
        .append(" height ")
        .append(std::to_string(cloud.height))
        .append("\n");
  out.append("element vertex ").append(std::to_string(n)).append("\n");
  for (const char* axis : {"x", "y", "z"})
    out.append("property ").append(coord).append(" ").append(axis).append("\n");
  if (cloud.has_intensities()) out.append("property float intensity\n");
  if (cloud.has_colors())
    for (const char* channel : {"red", "green", "blue", "alpha"})
      out.append("property uchar ").append(channel).append("\n");
  if (cloud.has_normals())
    for (const char* axis : {"nx", "ny", "nz"})
      out.append("property ").append(coord).append(" ").append(axis).append("\n");
  out.append("end_header\n");

  const bool text = format == PlyFormat::ascii;
  const auto coordinate = [&](Scalar v, bool first) {
    if (text) {
      if (!first) out.push_back(' ');
      if (wide)
        append_number(out, static_cast<double>(v));
      else
        append_number(out, static_cast<float>(v));
    } else if (wide) {
      append_le(out, static_cast<double>(v));
    } else {
      append_le(out, static_cast<float>(v));
    }
  };
  for (std::size_t i = 0; i < n; ++i) {
    for (Eigen::Index k = 0; k < 3; ++k)
      coordinate(cloud.points[i][k], k == 0);
    if (cloud.has_intensities()) {
      if (text) {
        out.push_back(' ');
        append_number(out, cloud.intensities[i]);
      } else {
        append_le(out, cloud.intensities[i]);
      }
    }
    if (cloud.has_colors())
      for (const std::uint8_t c : cloud.colors[i]) {
        if (text) {
          out.push_back(' ');
          append_number(out, static_cast<unsigned>(c));
        } else {
          out.push_back(static_cast<char>(c));
        }
      }
    if (cloud.has_normals())
      for (Eigen::Index k = 0; k < 3; ++k)
        coordinate(cloud.normals[i][k], false);
    if (text) out.push_back('\n');
  }
  write_whole_file(ply, path, out);
}

}  // namespace rangenav::io
