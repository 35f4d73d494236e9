#pragma once
// The pictures of lesson 06: a simulated world's walls and doors, and the paths a pose tracker
// produced, one SVG layer each. Not library code: the lesson is how 06_hayai.cpp tracks.

#include <cmath>
#include <vector>

#include "rangenav/io/svg.hpp"
#include "rangenav/sim/world.hpp"

namespace examples {

/// The walls and the door leaves of `world`, in a layer "walls".
inline void draw_walls(rangenav::io::SvgDrawing& svg, const rangenav::sim::World& world) {
  using rangenav::Point2d;
  svg.layer("walls");
  for (const auto& w : world.walls())
    svg.segment(w.a, w.b, {.stroke = "#444"});
  for (const auto& d : world.doors()) {
    const auto leaf = d.leaf();
    const double c = std::cos(leaf.yaw), s = std::sin(leaf.yaw);
    const Point2d half(c * leaf.size.x() / 2, s * leaf.size.x() / 2);
    svg.segment(leaf.center - half, leaf.center + half, {.stroke = "#8b4513"});
  }
}

/// The paths of odometry alone, HAYAI alone and HAYAI fused with odometry by the tracker's EKF,
/// one layer each (orange, red, blue).
inline void draw_tracks(rangenav::io::SvgDrawing& svg,
                        const std::vector<rangenav::Pose2d>& odometry,
                        const std::vector<rangenav::Pose2d>& alone,
                        const std::vector<rangenav::Pose2d>& fused) {
  svg.layer("odometry").path(odometry, {.stroke = "orange"});
  svg.layer("hayai").path(alone, {.stroke = "crimson"});
  svg.layer("hayai + odometry (EKF)").path(fused, {.stroke = "royalblue"});
}

}  // namespace examples
