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
  // One accumulator per occupied voxel, found by its key. Consecutive points (the pixels
  // along a row of an organised frame) mostly share a voxel: while a point falls into the
  // current voxel's cell (a comparison with its bounds, no key computed), it is summed in
  // registers; on a change the voxel's slot is looked up in a small direct-mapped cache of
  // keys, then in the hash map. The points of a voxel are summed in input order and the
  // voxels sorted by key, which keeps the output deterministic (ordered by voxel).
  using Point = cloud_point_t<C>;
  struct Voxel {
    std::uint64_t key;
    Point sum;
    std::size_t count;
  };
  std::vector<Voxel> voxels;
  std::unordered_map<std::uint64_t, std::uint32_t> slot_of;
  constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();
  constexpr int cache_bits = 10;
  struct CacheEntry {
    std::uint64_t key = 0;
    std::uint32_t slot = std::numeric_limits<std::uint32_t>::max();  // empty
  };
  std::vector<CacheEntry> cache(std::size_t(1) << cache_bits);
  std::uint32_t slot = none;      // the current voxel
  Point run_sum = Point::Zero();  // voxels[slot].sum, being summed
  std::size_t run_count = 0;
  Point cell_min = Point::Zero(), cell_max = Point::Zero();  // its cell, in units of leaf_size
  const Scalar inv = Scalar(1) / leaf_size;
  // floor(p * inv) must lie in (-half, half - 1), i.e. p * inv in [1 - half, half - 1); NaN
  // and infinite coordinates fail the test as well.
  const Scalar lowest = Scalar(1 - half), highest = Scalar(half - 1);
  for (std::size_t i = 0; i < n; ++i) {
    const Point p = traits::point(cloud, i);
    const Point t = p * inv;
    // t in [cell_min, cell_max) <=> floor(t) == cell_min (the bounds are whole numbers).
    // (Bitwise, without branches: the test is taken for every point.)
    unsigned same = slot != none ? 1u : 0u;
    for (int d = 0; d < D; ++d)
      same &=
          static_cast<unsigned>(t[d] >= cell_min[d]) & static_cast<unsigned>(t[d] < cell_max[d]);
    if (same == 0) {
      std::uint64_t key = 0;
      bool inside = true;
      Point cell;
      for (int d = 0; d < D; ++d) {
        inside = inside && t[d] >= lowest && t[d] < highest;
        // floor(t) without a libm call: truncate, then step down for negative fractions.
        auto c = static_cast<std::int64_t>(inside ? t[d] : Scalar(0));
        c -= static_cast<std::int64_t>(t[d] < static_cast<Scalar>(c));
        cell[d] = static_cast<Scalar>(c);
        key = (key << 21) | static_cast<std::uint64_t>(c + half);
      }
      if (!inside) continue;
      if (slot != none) {
        voxels[slot].sum = run_sum;
        voxels[slot].count = run_count;
      }
      CacheEntry& entry = cache[(key * 0x9E3779B97F4A7C15ull) >> (64 - cache_bits)];
      if (entry.slot == none || entry.key != key) {
        const auto [it, fresh] =
            slot_of.try_emplace(key, static_cast<std::uint32_t>(voxels.size()));
        if (fresh) voxels.push_back({key, Point::Zero(), 0});
        entry = {key, it->second};
      }
      slot = entry.slot;
      run_sum = voxels[slot].sum;
      run_count = voxels[slot].count;
      cell_min = cell;
      cell_max = cell + Point::Ones();
    }
    run_sum += p;
    ++run_count;
  }
  if (slot != none) {
    voxels[slot].sum = run_sum;
    voxels[slot].count = run_count;
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
