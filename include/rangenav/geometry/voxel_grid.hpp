#pragma once
// Voxel-grid downsampling (paper 004 §3.2: every key frame is downsampled with a voxel filter
// before it is aligned): the finite points falling into one cubic voxel of edge `leaf_size` are
// replaced by their centroid. Deterministic output ordered by voxel key.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <unordered_map>
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
  // One accumulator per occupied voxel, found by hashing its key; consecutive points (the
  // pixels along a row of an organised frame) mostly share a voxel, so the last voxel is tried
  // first. The points of a voxel are summed in input order and the voxels sorted by key, which
  // keeps the output deterministic (ordered by voxel).
  struct Voxel {
    std::uint64_t key;
    cloud_point_t<C> sum;
    std::size_t count;
  };
  std::vector<Voxel> voxels;
  std::unordered_map<std::uint64_t, std::uint32_t> slot_of;
  std::uint64_t last_key = 0;
  std::uint32_t last_slot = std::numeric_limits<std::uint32_t>::max();
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
    if (!inside) continue;
    if (last_slot == std::numeric_limits<std::uint32_t>::max() || key != last_key) {
      const auto [it, fresh] = slot_of.try_emplace(key, static_cast<std::uint32_t>(voxels.size()));
      if (fresh) voxels.push_back({key, cloud_point_t<C>::Zero(), 0});
      last_key = key;
      last_slot = it->second;
    }
    Voxel& v = voxels[last_slot];
    v.sum += p;
    ++v.count;
  }
  std::sort(voxels.begin(), voxels.end(),
            [](const Voxel& a, const Voxel& b) { return a.key < b.key; });
  std::vector<cloud_point_t<C>> out;
  out.reserve(voxels.size());
  for (const Voxel& v : voxels)
    out.push_back(v.sum / static_cast<Scalar>(v.count));
  return out;
}

}  // namespace rangenav
