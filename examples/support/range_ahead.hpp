#pragma once
// The range straight ahead of the robot in an egocentric map or a scan: how lesson 04 (and
// tools/area_of_interest, which varies its scanner's nod) asks whether a map holds an obstacle.
// Not library code.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

#include "rangenav/scan/laser_scan.hpp"

namespace examples {

/// The nearest valid reading within one bin of bearing 0 in a VirtualMap (infinity if none).
template <class Map>
double range_ahead(const Map& map) {
  double best = std::numeric_limits<double>::infinity();
  const std::size_t k = map.bin_index(0.0);
  for (std::size_t j = k + map.size() - 1; j <= k + map.size() + 1; ++j)
    if (!map.bin(j % map.size()).dummy) best = std::min(best, map.bin(j % map.size()).range);
  return best;
}

/// The nearest valid reading within one beam of bearing 0 in a scan (infinity if none).
inline double range_ahead(const rangenav::LaserScan<double>& scan) {
  const auto i = static_cast<std::size_t>(std::llround(-scan.angle_min() / scan.angle_increment()));
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t j = i - 1; j <= i + 1; ++j)
    if (scan.is_valid(j)) best = std::min(best, scan.range(j));
  return best;
}

}  // namespace examples
