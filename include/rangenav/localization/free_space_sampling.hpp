#pragma once
// Poses drawn uniformly over the free space of an occupancy grid: the uniform prior of global
// localization, shared by MonteCarloLocalization and DoorAwareMcl.

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <numbers>
#include <random>
#include <string_view>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/localization/particle_filter.hpp"
#include "rangenav/mapping/occupancy_grid.hpp"

namespace rangenav {

/// `count` poses uniform over the cells whose occupancy probability is below `free_probability`
/// (uniform within each cell) with uniform headings. Throws invalid_argument, naming `where`,
/// for a count outside [1, max_particle_count], a free_probability outside (0, 1] or a grid
/// without a free cell.
template <class Engine>
[[nodiscard]] std::vector<Pose2d> sample_free_space_poses(
    const OccupancyGrid& grid, std::size_t count, Engine& rng, double free_probability = 0.25,
    std::string_view where = "sample_free_space_poses") {
  detail::require_particle_count(where, "count", count);
  if (!(free_probability > 0 && free_probability <= 1))
    detail::throw_invalid_argument(where, "free_probability", free_probability,
                                   "must be in (0, 1]");
  const double l_free = log_odds(std::clamp(free_probability, 1e-6, 0.5));
  std::vector<OccupancyGrid::Index> free;
  for (int y = 0; y < grid.height(); ++y)
    for (int x = 0; x < grid.width(); ++x)
      if (grid.log_odds_at({x, y}) < l_free) free.emplace_back(x, y);
  if (free.empty()) detail::throw_invalid(where, "the grid has no free cell");
  std::uniform_int_distribution<std::size_t> pick(0, free.size() - 1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_real_distribution<double> heading(-std::numbers::pi, std::numbers::pi);
  std::vector<Pose2d> poses(count);
  for (auto& pose : poses) {
    const Point2d corner =
        grid.cell_center(free[pick(rng)]) - Point2d::Constant(grid.resolution() / 2);
    // Braced initialisation evaluates left to right: the draws keep a fixed order.
    pose = {corner.x() + unit(rng) * grid.resolution(), corner.y() + unit(rng) * grid.resolution(),
            normalize_angle(heading(rng))};
  }
  return poses;
}

}  // namespace rangenav
