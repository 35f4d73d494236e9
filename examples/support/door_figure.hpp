#pragma once
// The picture of lesson 07: paper 001's Fig. 4 drawn from the lesson's map, detected doors and
// door-aware MCL's door estimates. Not library code: the lesson is what 07_doors.cpp computes.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "rangenav/io/svg.hpp"
#include "rangenav/localization/door_mcl.hpp"
#include "rangenav/mapping/doors.hpp"
#include "rangenav/mapping/occupancy_grid.hpp"

namespace examples {

/// Writes paper 001's Fig. 4 to `file` (creating its folder): the static `grid` with the `doors`'
/// angle ranges and the robot's `path`; below it the sensor model of door-aware MCL over the map,
/// p(z | x, m, doors) of a beam end point every 0.1 m with the doors at `states` (six grey levels,
/// darker = more likely, below 2 % of the peak blank), and the doors drawn at those states.
inline void draw_door_figure(const rangenav::OccupancyGrid& grid,
                             const std::vector<rangenav::DoorModel>& doors,
                             const std::vector<rangenav::Pose2d>& path,
                             const rangenav::DoorAwareState& states,
                             const std::filesystem::path& file) {
  using namespace rangenav;
  io::SvgDrawing svg;
  std::vector<Point2d> occupied;
  for (int y = 0; y < grid.height(); ++y)
    for (int x = 0; x < grid.width(); ++x)
      if (grid.is_occupied({x, y})) occupied.push_back(grid.cell_center({x, y}));
  svg.layer("static grid").points(occupied, {.stroke = "black", .point_radius_px = 1.0});
  svg.layer("doors (blue: min angle, red: max angle)");
  for (const DoorModel& d : doors) {
    svg.segment(d.hinge, d.leaf_end(d.opening_min), {.stroke = "blue", .stroke_width_px = 2});
    svg.segment(d.hinge, d.leaf_end(d.opening_max), {.stroke = "red", .stroke_width_px = 2});
    svg.circle(d.hinge, 0.05, {.stroke = "black", .fill = "black"});
  }
  svg.layer("robot path").path(path, {.stroke = "green"});

  const Point2d lo = grid.origin();
  const Point2d size = Point2d(grid.width(), grid.height()) * grid.resolution();
  const Point2d below(0, size.y() + 1.0);  // the second picture's offset
  const DoorAwareMcl model(grid, doors);
  std::vector<std::pair<Point2d, double>> samples;
  double peak = 0;
  for (double y = lo.y() + 0.05; y < lo.y() + size.y(); y += 0.1)
    for (double x = lo.x() + 0.05; x < lo.x() + size.x(); x += 0.1) {
      samples.emplace_back(Point2d(x, y) - below,
                           std::exp(model.end_point_log_likelihood({x, y}, states)));
      peak = std::max(peak, samples.back().second);
    }
  std::vector<std::vector<Point2d>> by_level(6);
  for (const auto& [q, p] : samples)
    if (p >= 0.02 * peak)
      by_level[std::min<std::size_t>(5, static_cast<std::size_t>(6 * p / peak))].push_back(q);
  svg.layer("likelihood field of the static map, estimated door states");
  for (std::size_t l = 0; l < 6; ++l) {  // 0.1 m is about 4.4 px in a 1000 px picture of 22 m
    const std::string grey = std::to_string(230 - 230 * (l + 1) / 6);
    svg.points(by_level[l],
               {.stroke = "rgb(" + grey + "," + grey + "," + grey + ")", .point_radius_px = 2.3});
  }
  svg.layer("estimated doors (30 deg open)");  // the states lesson 07 passes
  for (std::size_t k = 0; k < doors.size(); ++k)
    svg.segment(doors[k].hinge - below, doors[k].leaf_end(states.doors[k].mean) - below,
                {.stroke = "orange", .stroke_width_px = 1.5});
  if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path());
  svg.save(file);
}

}  // namespace examples
