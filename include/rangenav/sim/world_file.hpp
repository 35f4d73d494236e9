#pragma once
// The world text format: one primitive per line, `#` starts a comment, blank lines are ignored,
// numbers in SI units (m, rad), fields separated by white space. Optional trailing fields take the
// defaults shown.
//
//   ceiling   <height>                                       # 0 = no ceiling
//   wall      <x1> <y1> <x2> <y2> [<height>=2.5]
//   polygon   <height> <x1> <y1> <x2> <y2> <x3> <y3> ...     # closed chain of walls, >= 3 vertices
//   box       <cx> <cy> <size_x> <size_y> <yaw> <z_min> <z_max>
//   cylinder  <cx> <cy> <radius> <z_min> <z_max>
//   door      <hinge_x> <hinge_y> <closed_yaw> <length> <opening> [<thickness>=0.04 <height>=2.0]
//   hole      <cx> <cy> <size_x> <size_y> <yaw> <depth>      # floor lowered by depth
//
// write_world() writes every number with 17 significant digits, so reading back gives the same
// world (polygons come back as their walls). Malformed lines raise io_error naming the source and
// the line number, and so do numbers and sizes beyond WorldFileLimits: every number must be finite
// and at most max_coordinate in magnitude, so that the world's extent (each value finite, their
// difference need not be: -1e308 to 1e308) and the ray-casting index built over it stay finite
// and bounded. The index of a world whose 2 m grid cells would exceed max_index_cells gets cells
// as coarse as that bound requires (the index changes the speed of ray casting, never a result).

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <istream>
#include <ostream>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/sim/world.hpp"

namespace rangenav::sim {

namespace detail_world_file {

[[noreturn]] inline void fail(std::string_view source, std::size_t line, std::string_view what) {
  std::string msg = "rangenav: ";
  msg.append(source).append(":").append(std::to_string(line)).append(": ").append(what);
  throw io_error(msg);
}

/// Joins pieces (avoids g++ 12's false -Wrestrict on `"literal" + std::string`).
inline std::string concat(std::initializer_list<std::string_view> pieces) {
  std::string out;
  for (const auto piece : pieces)
    out.append(piece);
  return out;
}

inline std::vector<std::string_view> split(std::string_view text) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && (text[i] == ' ' || text[i] == '\t' || text[i] == '\r'))
      ++i;
    const std::size_t start = i;
    while (i < text.size() && text[i] != ' ' && text[i] != '\t' && text[i] != '\r')
      ++i;
    if (i > start) out.push_back(text.substr(start, i - start));
  }
  return out;
}

}  // namespace detail_world_file

/// Upper bounds on what read_world() accepts.
struct WorldFileLimits {
  /// Largest magnitude of any number (m, rad); 1000 km holds any building or campus.
  double max_coordinate = 1e6;
  /// Most primitives (walls, boxes, cylinders, doors, holes; a polygon counts its walls).
  std::size_t max_primitives = std::size_t{1} << 20;
  /// Longest line (bytes).
  std::size_t max_line_bytes = std::size_t{1} << 24;
  /// Most cells of the ray-casting index (see the top of this file).
  std::size_t max_index_cells = std::size_t{1} << 16;

  /// Throws invalid_argument naming the first bad limit.
  void validate(std::string_view where) const {
    detail::require_positive(where, "limits.max_coordinate", max_coordinate);
    if (max_primitives == 0)
      detail::throw_invalid_argument(where, "limits.max_primitives", max_primitives, "must be > 0");
    if (max_line_bytes == 0)
      detail::throw_invalid_argument(where, "limits.max_line_bytes", max_line_bytes, "must be > 0");
    if (max_index_cells == 0)
      detail::throw_invalid_argument(where, "limits.max_index_cells", max_index_cells,
                                     "must be > 0");
  }
};

namespace detail_world_file {

/// std::getline with a bound: false at the end of the stream; `too_long` set when the line
/// exceeds `max_bytes` (the read then stops there).
inline bool read_line(std::istream& in, std::string& line, std::size_t max_bytes, bool& too_long) {
  line.clear();
  too_long = false;
  const std::istream::sentry ok(in, true);
  if (!ok) return false;
  std::streambuf* buffer = in.rdbuf();
  for (bool any = false;; any = true) {
    const int c = buffer->sbumpc();
    if (c == std::char_traits<char>::eof()) {
      in.setstate(any ? std::ios::eofbit : std::ios::eofbit | std::ios::failbit);
      return any;
    }
    if (c == '\n') return true;
    if (line.size() >= max_bytes) {
      too_long = true;
      return true;
    }
    line.push_back(static_cast<char>(c));
  }
}

/// The index cell size for `world`: 0 (World's own choice) unless 2 m cells, the coarsest it
/// picks, would exceed max_cells over the world's bounds; then cells just large enough.
inline double index_cell_size(const World& world, std::size_t max_cells) {
  if (world.primitive_count() == 0) return 0;
  const auto [lo, hi] = world.bounds();
  const Point2d extent = hi - lo;
  const double area = std::max(extent.x(), 2.0) * std::max(extent.y(), 2.0);
  const double cells = static_cast<double>(max_cells);
  return area / 4.0 > cells ? std::sqrt(area / cells) : 0.0;
}

}  // namespace detail_world_file

/// Reads a world in the text format from `in`; `source` names it in error messages. The index
/// is built. Throws io_error naming the source and line for a malformed line or a number, line or
/// primitive count beyond `limits`.
[[nodiscard]] inline World read_world(std::istream& in, std::string_view source = "<stream>",
                                      const WorldFileLimits& limits = {}) {
  using detail_world_file::concat;
  using detail_world_file::fail;
  limits.validate("read_world");
  World world;
  std::string line;
  std::size_t line_number = 0;
  bool too_long = false;
  while (detail_world_file::read_line(in, line, limits.max_line_bytes, too_long)) {
    ++line_number;
    if (too_long)
      fail(source, line_number,
           concat({"line longer than WorldFileLimits::max_line_bytes = ",
                   std::to_string(limits.max_line_bytes), " bytes"}));
    std::string_view text(line);
    if (const auto hash = text.find('#'); hash != std::string_view::npos)
      text = text.substr(0, hash);
    const auto tokens = detail_world_file::split(text);
    if (tokens.empty()) continue;
    const std::string_view kind = tokens[0];
    std::vector<double> v;
    for (std::size_t k = 1; k < tokens.size(); ++k) {
      double x = 0;
      const auto* first = tokens[k].data();
      const auto* last = first + tokens[k].size();
      const auto [ptr, ec] = std::from_chars(first, last, x);
      if (ec != std::errc() || ptr != last)
        fail(source, line_number, concat({"bad number '", tokens[k], "'"}));
      if (!(std::abs(x) <= limits.max_coordinate))
        fail(source, line_number,
             concat({"number ", std::to_string(k), " = '", tokens[k],
                     "' is not finite or exceeds WorldFileLimits::max_coordinate = ",
                     detail::format_value(limits.max_coordinate)}));
      v.push_back(x);
    }
    const auto need = [&](std::size_t lo, std::size_t hi) {
      if (v.size() < lo || v.size() > hi) {
        std::string counts = std::to_string(lo);
        if (hi > lo) counts.append(hi == lo + 1 ? " or " : " to ").append(std::to_string(hi));
        fail(source, line_number,
             concat({"'", kind, "' needs ", counts, " numbers, got ", std::to_string(v.size())}));
      }
    };
    const std::size_t adds = kind == "polygon" ? v.size() / 2 : 1;
    if (world.primitive_count() + world.holes().size() + adds > limits.max_primitives)
      fail(source, line_number,
           concat({"more than WorldFileLimits::max_primitives = ",
                   std::to_string(limits.max_primitives), " primitives"}));
    try {
      if (kind == "ceiling") {
        need(1, 1);
        world.set_ceiling_height(v[0]);
      } else if (kind == "wall") {
        need(4, 5);
        world.add_wall({v[0], v[1]}, {v[2], v[3]}, v.size() > 4 ? v[4] : 2.5);
      } else if (kind == "polygon") {
        if (v.size() < 7 || v.size() % 2 == 0)
          fail(source, line_number,
               concat({"'polygon' needs a height and at least 3 x y pairs, got ",
                       std::to_string(v.size()), " numbers"}));
        std::vector<Point2d> vertices;
        for (std::size_t k = 1; k + 1 < v.size(); k += 2)
          vertices.emplace_back(v[k], v[k + 1]);
        world.add_polygon(vertices, v[0]);
      } else if (kind == "box") {
        need(7, 7);
        world.add_box({{v[0], v[1]}, {v[2], v[3]}, v[4], v[5], v[6]});
      } else if (kind == "cylinder") {
        need(5, 5);
        world.add_cylinder({{v[0], v[1]}, v[2], v[3], v[4]});
      } else if (kind == "door") {
        need(5, 7);
        if (v.size() == 6) fail(source, line_number, "'door' thickness needs a height after it");
        Door door{{v[0], v[1]}, v[2], v[3], v[4]};
        if (v.size() == 7) {
          door.thickness = v[5];
          door.height = v[6];
        }
        world.add_door(door);
      } else if (kind == "hole") {
        need(6, 6);
        world.add_hole({{v[0], v[1]}, {v[2], v[3]}, v[4], v[5]});
      } else {
        fail(source, line_number, concat({"unknown primitive '", kind, "'"}));
      }
    } catch (const invalid_argument& e) {
      fail(source, line_number, e.what());
    }
  }
  world.build_index(detail_world_file::index_cell_size(world, limits.max_index_cells));
  return world;
}

/// Loads a world file (see the format above); throws io_error when it cannot be read.
[[nodiscard]] inline World load_world(const std::filesystem::path& path,
                                      const WorldFileLimits& limits = {}) {
  std::ifstream in(path);
  if (!in)
    throw io_error(
        detail_world_file::concat({"rangenav: cannot open world file '", path.string(), "'"}));
  return read_world(in, path.string(), limits);
}

/// Writes a world in the text format.
inline void write_world(std::ostream& out, const World& world) {
  std::ostringstream s;
  s.precision(17);
  s << "# rangenav world: walls, boxes, cylinders, doors, floor holes (SI units, radians)\n";
  if (world.ceiling_height() > 0) s << "ceiling " << world.ceiling_height() << '\n';
  for (const auto& w : world.walls())
    s << "wall " << w.a.x() << ' ' << w.a.y() << ' ' << w.b.x() << ' ' << w.b.y() << ' ' << w.height
      << '\n';
  for (const auto& b : world.boxes())
    s << "box " << b.center.x() << ' ' << b.center.y() << ' ' << b.size.x() << ' ' << b.size.y()
      << ' ' << b.yaw << ' ' << b.z_min << ' ' << b.z_max << '\n';
  for (const auto& c : world.cylinders())
    s << "cylinder " << c.center.x() << ' ' << c.center.y() << ' ' << c.radius << ' ' << c.z_min
      << ' ' << c.z_max << '\n';
  for (const auto& d : world.doors())
    s << "door " << d.hinge.x() << ' ' << d.hinge.y() << ' ' << d.closed_yaw << ' ' << d.length
      << ' ' << d.opening << ' ' << d.thickness << ' ' << d.height << '\n';
  for (const auto& h : world.holes())
    s << "hole " << h.center.x() << ' ' << h.center.y() << ' ' << h.size.x() << ' ' << h.size.y()
      << ' ' << h.yaw << ' ' << h.depth << '\n';
  out << s.str();
}

/// Saves a world file; throws io_error when it cannot be written.
inline void save_world(const std::filesystem::path& path, const World& world) {
  std::ofstream out(path);
  if (!out)
    throw io_error(
        detail_world_file::concat({"rangenav: cannot write world file '", path.string(), "'"}));
  write_world(out, world);
  if (!out)
    throw io_error(
        detail_world_file::concat({"rangenav: error writing world file '", path.string(), "'"}));
}

}  // namespace rangenav::sim
