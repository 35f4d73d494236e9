#pragma once
// Voxel-grid downsampling (paper 004 §3.2: every key frame is downsampled with a voxel filter
// before it is aligned): the finite points falling into one cubic voxel of edge `leaf_size` are
// replaced by their centroid. Sort-based (no hash map): deterministic output ordered by voxel.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// Replaces the points of every voxel by their centroid. Non-finite points are skipped; the
/// voxel coordinates must fit in 21 bits per axis (|coordinate| < 2^20 * leaf_size), points
/// beyond that are skipped too. Throws invalid_argument unless leaf_size is finite and > 0.
template <PointCloud C>
[[nodiscard]] std::vector<cloud_point_t<C>> voxel_downsample(const C& cloud,
                                                             traits::scalar_t<C> leaf_size) {
  using Scalar = traits::scalar_t<C>;
  constexpr int D = traits::dimension_v<C>;
  detail::require_positive("voxel_downsample", "leaf_size", leaf_size);
  const std::size_t n = traits::size(cloud);
  constexpr std::int64_t half = std::int64_t(1) << 20;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keys;
  keys.reserve(n);
  const Scalar inv = Scalar(1) / leaf_size;
  for (std::size_t i = 0; i < n; ++i) {
    const cloud_point_t<C> p = traits::point(cloud, i);
    if (!p.allFinite()) continue;
    std::uint64_t key = 0;
    bool inside = true;
    for (int d = 0; d < D; ++d) {
      const Scalar c = std::floor(p[d] * inv);
      if (!(c > Scalar(-half) && c < Scalar(half - 1))) {
        inside = false;
        break;
      }
      key = (key << 21) | static_cast<std::uint64_t>(static_cast<std::int64_t>(c) + half);
    }
    if (inside) keys.emplace_back(key, static_cast<std::uint32_t>(i));
  }
  std::sort(keys.begin(), keys.end());
  std::vector<cloud_point_t<C>> out;
  for (std::size_t i = 0; i < keys.size();) {
    cloud_point_t<C> sum = cloud_point_t<C>::Zero();
    std::size_t j = i;
    for (; j < keys.size() && keys[j].first == keys[i].first; ++j)
      sum += cloud_point_t<C>(traits::point(cloud, keys[j].second));
    out.push_back(sum / static_cast<Scalar>(j - i));
    i = j;
  }
  return out;
}

}  // namespace rangenav
