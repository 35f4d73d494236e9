#pragma once
// The set-up and the picture of lesson 09: a square arena of low walls with an exit in the right
// wall, small boxes and cans on its floor, and the drawing of the runs through it. Not library
// code: the lesson is how 09_avoidance.cpp perceives and avoids them.

#include <cstddef>
#include <filesystem>
#include <vector>

#include "rangenav/io/svg.hpp"
#include "rangenav/sim/world.hpp"

namespace arena {

using namespace rangenav;

constexpr double side = 4.5;        ///< m, the arena is square
constexpr double exit_width = 1.1;  ///< m, gap in the right wall at the far corner

/// The arena with 0.8 m walls and `objects` on its floor: 14 x 10 cm boxes 8 cm high and cans of
/// 5 cm radius 10 cm high, in turn.
inline sim::World world(const std::vector<Point2d>& objects) {
  sim::World w;
  const double h = 0.8;  // movable walls
  w.add_wall({0, 0}, {side, 0}, h);
  w.add_wall({0, 0}, {0, side}, h);
  w.add_wall({0, side}, {side, side}, h);
  w.add_wall({side, 0}, {side, side - exit_width}, h);
  for (std::size_t i = 0; i < objects.size(); ++i)
    if (i % 2 == 0)
      w.add_box({objects[i], {0.14, 0.10}, 0.3 * static_cast<double>(i), 0.0, 0.08});
    else
      w.add_cylinder({objects[i], 0.05, 0.0, 0.10});
  w.build_index();
  return w;
}

/// Writes an SVG to `file`: the walls, the `objects` and the paths of the 2D and 3D runs.
inline void draw(const sim::World& world, const std::vector<Point2d>& objects,
                 const std::vector<Point2d>& path_2d, const std::vector<Point2d>& path_3d,
                 const std::filesystem::path& file) {
  io::SvgDrawing svg({.size_px = 700});
  for (const sim::Wall& w : world.walls())
    svg.layer("walls").segment(w.a, w.b, {.stroke = "black", .stroke_width_px = 2.5});
  for (const Point2d& o : objects)
    svg.layer("small objects").circle(o, 0.07, {.stroke = "#d35400", .fill = "#f5b041"});
  svg.layer("2D perception").polyline(path_2d, {.stroke = "crimson"});
  svg.layer("3D perception").polyline(path_3d, {.stroke = "#27ae60"});
  svg.save(file);
}

}  // namespace arena
