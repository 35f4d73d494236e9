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
// the line number.

#include <charconv>
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

/// Reads a world in the text format from `in`; `source` names it in error messages. The index
/// is built.
[[nodiscard]] inline World read_world(std::istream& in, std::string_view source = "<stream>") {
  using detail_world_file::concat;
  using detail_world_file::fail;
  World world;
  std::string line;
  std::size_t line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
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
  world.build_index();
  return world;
}

/// Loads a world file (see the format above); throws io_error when it cannot be read.
[[nodiscard]] inline World load_world(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in)
    throw io_error(
        detail_world_file::concat({"rangenav: cannot open world file '", path.string(), "'"}));
  return read_world(in, path.string());
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
