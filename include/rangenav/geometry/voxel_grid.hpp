#pragma once
// Voxel-grid downsampling (paper 004 §3.2: every key frame is downsampled with a voxel filter
// before it is aligned): the finite points falling into one cubic voxel of edge `leaf_size` are
// replaced by their centroid. Deterministic output ordered by voxel key; the points of a voxel
// are summed in input order, serially or on several threads alike, so the thread count does not
// change a bit of the output.
//
// A voxel's key packs its cell, counted from the cell of the cloud's first finite point, into 21
// bits per axis, so a cloud may lie anywhere (a lidar map in UTM coordinates, millions of metres
// from 0). A cloud with a finite point 2^20 voxels or more from its first one (wider than 262 km
// at 0.25 m, an outlier, a leaf far too small) is filtered again without keys, over cells in an
// ordered map: the same voxels and output, slower. Nothing finite is dropped unless it lies 2^62
// voxels or more from 0.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/parallel.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

namespace detail {

/// Half the range of a voxel key's cell field (21 bits per axis, see the file comment).
inline constexpr std::int64_t voxel_key_half = std::int64_t(1) << 20;

/// Cells 2^62 or more from 0 fit no int64 difference: points there are skipped.
template <std::floating_point Scalar>
inline constexpr Scalar voxel_cell_limit = Scalar(std::int64_t(1) << 62);

/// floor(t) for |t| < 2^62, without a libm call: truncate, then step down for negative fractions.
template <std::floating_point Scalar>
[[nodiscard]] std::int64_t floor_to_int(Scalar t) {
  auto c = static_cast<std::int64_t>(t);
  return c - static_cast<std::int64_t>(t < static_cast<Scalar>(c));
}

/// A point's coordinates as an array (std::array: registers, where Eigen's vectors spill).
template <PointCloud C>
using voxel_coords_t =
    std::array<traits::scalar_t<C>, static_cast<std::size_t>(traits::dimension_v<C>)>;

/// The coordinates of point k of a cloud.
template <PointCloud C>
[[nodiscard]] voxel_coords_t<C> voxel_coords(const C& cloud, std::size_t k) {
  const auto& q = traits::point(cloud, k);
  voxel_coords_t<C> p;
  for (std::size_t d = 0; d < p.size(); ++d)
    p[d] = static_cast<traits::scalar_t<C>>(q[static_cast<Eigen::Index>(d)]);
  return p;
}

/// A voxel's centroid from the sum of its points' coordinates and their count.
template <class Point, std::floating_point Scalar, std::size_t D>
[[nodiscard]] Point voxel_centroid(const std::array<Scalar, D>& sum, std::size_t count) {
  Point p;
  for (std::size_t d = 0; d < D; ++d)
    p[static_cast<Eigen::Index>(d)] = sum[d];
  return p / static_cast<Scalar>(count);
}

/// Whether every coordinate is finite.
template <std::floating_point Scalar, std::size_t D>
[[nodiscard]] bool voxel_point_finite(const std::array<Scalar, D>& p) {
  return std::all_of(p.begin(), p.end(), [](Scalar x) { return std::isfinite(x); });
}

/// The cell floor(p * inv) of a point, per axis; nullopt when a coordinate is not finite or its
/// cell lies 2^62 or more from 0.
template <std::floating_point Scalar, std::size_t D>
[[nodiscard]] std::optional<std::array<std::int64_t, D>> voxel_cell(const std::array<Scalar, D>& p,
                                                                    Scalar inv) {
  std::array<std::int64_t, D> cell;
  for (std::size_t d = 0; d < D; ++d) {
    const Scalar t = p[d] * inv;
    if (!(t > -voxel_cell_limit<Scalar> && t < voxel_cell_limit<Scalar>)) return std::nullopt;
    cell[d] = floor_to_int(t);
  }
  return cell;
}

/// The key of a cell counted from the cell `origin`: cell - origin + half in 21 bits per axis,
/// for cell - origin in [1 - half, half - 2]; nullopt outside that range (see the file comment).
template <std::size_t D>
[[nodiscard]] std::optional<std::uint64_t> voxel_key(const std::array<std::int64_t, D>& cell,
                                                     const std::array<std::int64_t, D>& origin) {
  constexpr std::int64_t half = voxel_key_half;
  std::uint64_t key = 0;
  for (std::size_t d = 0; d < D; ++d) {
    const std::int64_t r = cell[d] - origin[d];  // both below 2^62 in magnitude
    if (r < 1 - half || r > half - 2) return std::nullopt;
    key = (key << 21) | static_cast<std::uint64_t>(r + half);
  }
  return key;
}

/// The origin cell of the keyed filter: that of the cloud's first finite point (zeros if none,
/// or when its cell does not fit an int64: that point then sends the cloud to the exact filter).
template <PointCloud C>
[[nodiscard]] std::array<std::int64_t, traits::dimension_v<C>> first_voxel_origin(
    const C& cloud, traits::scalar_t<C> leaf_size) {
  const traits::scalar_t<C> inv = traits::scalar_t<C>(1) / leaf_size;
  for (std::size_t i = 0; i < traits::size(cloud); ++i) {
    const auto p = voxel_coords(cloud, i);
    if (!voxel_point_finite(p)) continue;
    if (auto cell = voxel_cell(p, inv)) return *cell;
    break;  // its cell fits no int64
  }
  return {};
}

/// The voxel filter for a cloud the keys cannot hold (a finite point 2^20 or more voxels from
/// the first one): the same voxels, sums and order (by cell) as the keyed filter, over cells of
/// any size, in an ordered map; slower, and run only for such a cloud.
template <PointCloud C>
[[nodiscard]] std::vector<cloud_point_t<C>> voxel_downsample_exact(const C& cloud,
                                                                   traits::scalar_t<C> leaf_size) {
  using Scalar = traits::scalar_t<C>;
  constexpr int D = traits::dimension_v<C>;
  using Point = cloud_point_t<C>;
  const Scalar inv = Scalar(1) / leaf_size;
  std::map<std::array<std::int64_t, D>, std::pair<std::array<Scalar, D>, std::size_t>> voxels;
  for (std::size_t i = 0; i < traits::size(cloud); ++i) {
    const auto p = voxel_coords(cloud, i);
    const auto cell = voxel_cell(p, inv);
    if (!cell) continue;  // not finite, or 2^62 voxels or more from 0
    auto& [sum, count] = voxels[*cell];
    for (std::size_t d = 0; d < p.size(); ++d)
      sum[d] += p[d];
    ++count;
  }
  std::vector<Point> out;
  out.reserve(voxels.size());
  for (const auto& [cell, voxel] : voxels)
    out.push_back(voxel_centroid<Point>(voxel.first, voxel.second));
  return out;
}

/// The serial voxel filter with the voxel keys counted from the first finite point's cell;
/// nullopt when a finite point lies outside their range (see the file comment).
template <PointCloud C>
[[nodiscard]] std::optional<std::vector<cloud_point_t<C>>> voxel_pass_serial(
    const C& cloud, traits::scalar_t<C> leaf_size) {
  using Scalar = traits::scalar_t<C>;
  using Point = cloud_point_t<C>;
  constexpr std::size_t Dim = traits::dimension_v<C>;
  using Coords = voxel_coords_t<C>;
  const std::size_t n = traits::size(cloud);
  const Scalar inv = Scalar(1) / leaf_size;
  const auto origin = first_voxel_origin(cloud, leaf_size);
  // A point p lies in the cell c = floor(p * inv) (per axis). p * inv rounds monotonically in
  // p, so the cell is an interval of coordinates: [first(c), first(c + 1)) with first(c) the
  // smallest x whose product x * inv is >= c. Each voxel keeps those bounds (a few ulp steps
  // from c * leaf_size, found once per voxel), and the test "same voxel as before" that every
  // point takes is six comparisons, no product, with the same outcome as comparing
  // floor(p * inv) (tested against that definition).
  // The voxels of a frame share a few hundred distinct cell coordinates per axis: first(c) is
  // kept in a small direct-mapped table (libm's nextafter is a call, ~45 instructions).
  struct Bound {
    Scalar c = std::numeric_limits<Scalar>::quiet_NaN();  // empty: equal to no c
    Scalar x = 0;
  };
  std::array<Bound, 256> bounds{};
  const auto first_uncached = [inv, leaf_size](Scalar c) {
    constexpr Scalar inf = std::numeric_limits<Scalar>::infinity();
    Scalar x = c * leaf_size;
    if (x * inv >= c) {
      for (Scalar below = std::nextafter(x, -inf); below * inv >= c;
           below = std::nextafter(below, -inf))
        x = below;
    } else {
      do
        x = std::nextafter(x, inf);
      while (x * inv < c);
    }
    return x;
  };
  const auto first = [&](Scalar c) {
    Bound& b = bounds[static_cast<std::uint8_t>(static_cast<std::int64_t>(c))];
    if (!(b.c == c)) b = {c, first_uncached(c)};
    return b.x;
  };
  // One accumulator per occupied voxel. Consecutive points (the pixels along a row of an
  // organised frame) mostly share a voxel: they are summed in registers while they fall into
  // the voxel's bounds. On a change, the voxel before the current one is tried (a surface
  // that runs along a voxel face alternates between the two in the range noise), then the
  // point's key is looked up in a small direct-mapped cache of keys, then in the hash map. The
  // points of a voxel are summed in input order and the voxels sorted by key, which keeps the
  // output deterministic (ordered by voxel).
  struct Voxel {
    Coords sum;
    std::size_t count;
    Coords lower, upper;  // the cell: lower <= p < upper per axis
  };
  std::vector<Voxel> voxels;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keys;  // (key, voxel), to sort
  std::unordered_map<std::uint64_t, std::uint32_t> slot_of;
  constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();
  constexpr int cache_bits = 10;
  struct CacheEntry {
    std::uint64_t key = 0;
    std::uint32_t slot = std::numeric_limits<std::uint32_t>::max();  // empty
  };
  std::vector<CacheEntry> cache(std::size_t(1) << cache_bits);
  const auto contains = [](const Voxel& v, const Coords& p) {
    unsigned in = 1;  // bitwise, without branches
    for (std::size_t d = 0; d < Dim; ++d)
      in &= static_cast<unsigned>(p[d] >= v.lower[d]) & static_cast<unsigned>(p[d] < v.upper[d]);
    return in != 0;
  };
  std::uint32_t current = none, before = none;
  for (std::size_t i = 0; i < n;) {
    const Coords p = voxel_coords(cloud, i);
    std::uint32_t slot = before;
    if (slot == none || !contains(voxels[slot], p)) {
      const auto cell = voxel_cell(p, inv);
      const auto found = cell ? voxel_key(*cell, origin) : std::nullopt;
      if (!found) {  // not finite (skipped), or beyond the keys (the exact filter's work)
        if (voxel_point_finite(p)) return std::nullopt;
        ++i;
        continue;
      }
      const std::uint64_t key = *found;
      CacheEntry& entry = cache[(key * 0x9E3779B97F4A7C15ull) >> (64 - cache_bits)];
      if (entry.slot == none || entry.key != key) {
        const auto [it, fresh] =
            slot_of.try_emplace(key, static_cast<std::uint32_t>(voxels.size()));
        if (fresh) {
          Voxel v{};
          for (std::size_t d = 0; d < Dim; ++d) {
            const auto c = static_cast<Scalar>((*cell)[d]);
            v.lower[d] = first(c);
            v.upper[d] = first(c + 1);
          }
          voxels.push_back(v);
          keys.emplace_back(key, it->second);
        }
        entry = {key, it->second};
      }
      slot = entry.slot;
    }
    // The run of points in this voxel, summed in registers.
    Voxel& v = voxels[slot];
    const Coords lower = v.lower, upper = v.upper;
    Coords sum = v.sum;
    for (std::size_t d = 0; d < Dim; ++d)
      sum[d] += p[d];
    std::size_t j = i + 1;
    for (; j < n; ++j) {
      const Coords q = voxel_coords(cloud, j);
      unsigned in = 1;
      for (std::size_t d = 0; d < Dim; ++d)
        in &= static_cast<unsigned>(q[d] >= lower[d]) & static_cast<unsigned>(q[d] < upper[d]);
      if (in == 0) break;
      for (std::size_t d = 0; d < Dim; ++d)
        sum[d] += q[d];
    }
    v.sum = sum;
    v.count += j - i;
    before = slot == current ? before : current;
    current = slot;
    i = j;
  }
  std::sort(keys.begin(), keys.end());
  std::vector<Point> out;
  out.reserve(keys.size());
  for (const auto& [key, slot] : keys)
    out.push_back(voxel_centroid<Point>(voxels[slot].sum, voxels[slot].count));
  return out;
}

/// The serial voxel filter (see voxel_downsample): keyed from the first finite point's cell,
/// else exact.
template <PointCloud C>
[[nodiscard]] std::vector<cloud_point_t<C>> voxel_downsample_serial(const C& cloud,
                                                                    traits::scalar_t<C> leaf_size) {
  if (auto out = voxel_pass_serial(cloud, leaf_size)) return std::move(*out);
  return voxel_downsample_exact(cloud, leaf_size);
}

/// The voxel filter on several threads, with the serial filter's output: the key of every point
/// (in parallel), the points bucketed by key hash in input order, each bucket's voxels summed in
/// input order (in parallel), the voxels sorted by key.
template <PointCloud C>
[[nodiscard]] std::vector<cloud_point_t<C>> voxel_downsample_parallel(const C& cloud,
                                                                      traits::scalar_t<C> leaf_size,
                                                                      int num_threads) {
  using Scalar = traits::scalar_t<C>;
  constexpr int D = traits::dimension_v<C>;
  using Point = cloud_point_t<C>;
  const std::size_t n = traits::size(cloud);
  constexpr std::uint64_t outside = std::numeric_limits<std::uint64_t>::max();
  const Scalar inv = Scalar(1) / leaf_size;
  // The cell key of every point from the first finite point's cell, as the serial filter
  // computes it (outside: not finite, skipped). A finite point beyond the keys' range sends the
  // cloud to the exact filter, as in the serial filter (see the file comment).
  constexpr std::uint64_t beyond = outside - 1;
  const auto origin = first_voxel_origin(cloud, leaf_size);
  std::vector<std::uint64_t> keys(n);
  constexpr std::size_t block = 4096;
  for_each_block(n, block, num_threads, [&](std::size_t, std::size_t begin, std::size_t end, int) {
    for (std::size_t i = begin; i < end; ++i) {
      const auto p = voxel_coords(cloud, i);
      const auto cell = voxel_cell(p, inv);
      const auto key = cell ? voxel_key(*cell, origin) : std::nullopt;
      keys[i] = key ? *key : voxel_point_finite(p) ? beyond : outside;
    }
  });
  if (std::find(keys.begin(), keys.end(), beyond) != keys.end())
    return voxel_downsample_exact(cloud, leaf_size);
  // Buckets by key hash, points in input order inside each (a stable counting sort).
  const std::size_t buckets = 16 * static_cast<std::size_t>(num_threads);
  const auto bucket_of = [buckets](std::uint64_t key) {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> 32) % buckets;
  };
  std::vector<std::size_t> start(buckets + 1, 0);
  for (std::size_t i = 0; i < n; ++i)
    if (keys[i] != outside) ++start[bucket_of(keys[i]) + 1];
  for (std::size_t b = 0; b < buckets; ++b)
    start[b + 1] += start[b];
  std::vector<std::uint32_t> order(start[buckets]);
  {
    std::vector<std::size_t> next(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      if (keys[i] != outside) order[next[bucket_of(keys[i])]++] = static_cast<std::uint32_t>(i);
  }
  // Each bucket's voxels: (key, sum, count), the sum in input order.
  struct Voxel {
    std::uint64_t key;
    std::array<Scalar, static_cast<std::size_t>(D)> sum;
    std::size_t count;
  };
  std::vector<std::vector<Voxel>> voxels(buckets);
  for_each_block(buckets, 1, num_threads, [&](std::size_t b, std::size_t, std::size_t, int) {
    std::unordered_map<std::uint64_t, std::uint32_t> slot_of;
    std::vector<Voxel>& out = voxels[b];
    for (std::size_t k = start[b]; k < start[b + 1]; ++k) {
      const std::uint32_t i = order[k];
      const auto [it, fresh] = slot_of.try_emplace(keys[i], static_cast<std::uint32_t>(out.size()));
      if (fresh) out.push_back({keys[i], {}, 0});
      Voxel& v = out[it->second];
      const auto& p = traits::point(cloud, i);
      for (int d = 0; d < D; ++d)
        v.sum[static_cast<std::size_t>(d)] += static_cast<Scalar>(p[d]);
      ++v.count;
    }
  });
  std::vector<std::pair<std::uint64_t, Point>> centroids;
  for (const auto& bucket : voxels)
    for (const Voxel& v : bucket)
      centroids.emplace_back(v.key, voxel_centroid<Point>(v.sum, v.count));
  std::sort(centroids.begin(), centroids.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<Point> out;
  out.reserve(centroids.size());
  for (const auto& c : centroids)
    out.push_back(c.second);
  return out;
}

}  // namespace detail

/// Replaces the points of every voxel by their centroid, for a cloud anywhere in space (see the
/// file comment). Non-finite points are skipped, and so are points 2^62 voxels or more from 0.
/// With num_threads > 1 the work runs on that many threads (same output). Throws
/// invalid_argument unless leaf_size is finite and > 0 and num_threads >= 1.
template <PointCloud C>
[[nodiscard]] std::vector<cloud_point_t<C>> voxel_downsample(const C& cloud,
                                                             traits::scalar_t<C> leaf_size,
                                                             int num_threads = 1) {
  detail::require_positive("voxel_downsample", "leaf_size", leaf_size);
  detail::require_threads("voxel_downsample", num_threads);
  if (num_threads > 1 && parallel_enabled)
    return detail::voxel_downsample_parallel(cloud, leaf_size, num_threads);
  return detail::voxel_downsample_serial(cloud, leaf_size);
}

}  // namespace rangenav
