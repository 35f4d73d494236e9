#pragma once
// Euclidean clustering (paper 004 §3.3: "First, Euclidean clustering is used to determine
// connected regions of the point cloud"): two points belong to one cluster when a chain of points
// with consecutive distances below `tolerance` joins them; clusters outside
// [min_cluster_size, max_cluster_size] are dropped (as PCL's EuclideanClusterExtraction does).
//
// Two ways to find the chains:
// - euclidean_clusters(search): radius queries on any neighbour-search object with the radius
//   query of the NearestNeighborSearch concept (search/nearest_neighbor_search.hpp: size(),
//   point(i), nearest(q), radius(q, radius_sq, out)); geometry/ does not include search/, so the
//   requirement is spelled out here: pass a rangenav::KdTree. Works on any cloud.
// - organized_euclidean_clusters(points, width, height): for an organised cloud (a depth camera's
//   width x height frame), the chains are followed between image neighbours only (the 8 pixels
//   around each pixel), in one O(n) union-find pass instead of one radius query per point, as
//   PCL's OrganizedConnectedComponentSegmentation does. Where the surface is sampled densely
//   enough that each point's nearest points within `tolerance` include an image neighbour (a
//   range camera's frame at tolerance above the pixel spacing), both give the same clusters; the
//   organised variant never joins two surfaces that are close in space but apart in the image
//   without a chain of image neighbours between them (e.g. through a depth discontinuity).

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numeric>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "rangenav/core/cloud.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// Parameters of Euclidean clustering (Eq. 1 of paper 001, the clustering of paper 004 §3.2).
struct EuclideanClusteringParams {
  double tolerance = 0.02;           ///< m, largest gap inside a cluster
  std::size_t min_cluster_size = 1;  ///< smaller clusters are dropped
  /// larger clusters are dropped
  std::size_t max_cluster_size = std::numeric_limits<std::size_t>::max();

  /// Throws invalid_argument for a non-positive tolerance or min_cluster_size > max_cluster_size.
  void validate(std::string_view where) const {
    detail::require_positive(where, "params.tolerance", tolerance);
    if (max_cluster_size < min_cluster_size)
      detail::throw_invalid_argument(
          where, "params.max_cluster_size", max_cluster_size,
          "must be >= params.min_cluster_size = " + std::to_string(min_cluster_size));
  }
};

namespace detail {
/// The neighbour type a search's nearest() answers with (rangenav::Neighbor<Scalar>).
template <class S>
using search_neighbor_t = typename std::remove_cvref_t<decltype(std::declval<const S&>().nearest(
    std::declval<const typename S::point_type&>()))>::value_type;
}  // namespace detail

// clang-format off
/// The part of NearestNeighborSearch that clustering needs: radius queries returning neighbours
/// with an `index` into the search's own point list.
template <class S>
concept RadiusSearch = requires { typename S::point_type; typename S::scalar_type; } &&
    requires(const S& s, const typename S::point_type& q, typename S::scalar_type r_sq,
             std::vector<detail::search_neighbor_t<S>>& out) {
      { s.size() } -> std::convertible_to<std::size_t>;
      { s.point(std::size_t{}) } -> std::convertible_to<typename S::point_type>;
      { s.radius(q, r_sq, out) } -> std::convertible_to<std::size_t>;
      { out.front().index } -> std::convertible_to<std::size_t>;
    };
// clang-format on

/// The clusters of the points indexed by `search`, each a list of point indices (search.point(i))
/// in breadth-first order from its smallest index; clusters ordered by size, largest first (ties:
/// smallest first index first). Throws invalid_argument for bad parameters.
template <RadiusSearch S>
[[nodiscard]] std::vector<std::vector<std::uint32_t>> euclidean_clusters(
    const S& search, const EuclideanClusteringParams& params = {}) {
  params.validate("euclidean_clusters");
  using Scalar = typename S::scalar_type;
  const Scalar tol_sq = static_cast<Scalar>(params.tolerance * params.tolerance);
  const std::size_t n = search.size();
  std::vector<std::uint8_t> visited(n, 0);
  std::vector<detail::search_neighbor_t<S>> neighbors;
  std::vector<std::vector<std::uint32_t>> clusters;
  std::vector<std::uint32_t> cluster;
  for (std::size_t seed = 0; seed < n; ++seed) {
    if (visited[seed]) continue;
    visited[seed] = 1;
    cluster.clear();
    cluster.push_back(static_cast<std::uint32_t>(seed));
    for (std::size_t head = 0; head < cluster.size(); ++head) {
      if constexpr (requires { search.radius(search.point(0), tol_sq, neighbors, false); })
        search.radius(search.point(cluster[head]), tol_sq, neighbors, false);  // unsorted
      else
        search.radius(search.point(cluster[head]), tol_sq, neighbors);
      for (const auto& nb : neighbors) {
        const auto j = static_cast<std::size_t>(nb.index);
        if (visited[j]) continue;
        visited[j] = 1;
        cluster.push_back(static_cast<std::uint32_t>(j));
      }
    }
    if (cluster.size() >= params.min_cluster_size && cluster.size() <= params.max_cluster_size)
      clusters.push_back(cluster);
  }
  std::stable_sort(clusters.begin(), clusters.end(),
                   [](const auto& a, const auto& b) { return a.size() > b.size(); });
  return clusters;
}

/// Euclidean clustering of an organised cloud of `width` x `height` points (row-major, non-finite
/// points are no points): two points are chained when they are image neighbours (8-neighbourhood)
/// closer than params.tolerance. Each cluster lists its point indices in increasing order;
/// clusters ordered by size, largest first (ties: smallest first index first), as
/// euclidean_clusters. When `finite_points` is given it receives the number of points (finite
/// pixels). Throws invalid_argument for bad parameters or when width * height is not
/// points.size().
template <class Scalar>
[[nodiscard]] std::vector<std::vector<std::uint32_t>> organized_euclidean_clusters(
    std::span<const Point<3, Scalar>> points, std::size_t width, std::size_t height,
    const EuclideanClusteringParams& params = {}, std::size_t* finite_points = nullptr) {
  constexpr std::string_view where = "organized_euclidean_clusters";
  params.validate(where);
  if (width * height != points.size())
    detail::throw_invalid_argument(where, "width*height", width * height,
                                   "must equal points.size() = " + std::to_string(points.size()));
  if (points.size() > std::numeric_limits<std::uint32_t>::max())
    detail::throw_invalid_argument(where, "points.size()", points.size(), "must fit 32 bits");
  constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();
  const Scalar tol_sq = static_cast<Scalar>(params.tolerance * params.tolerance);
  // A non-finite coordinate makes the squared distance NaN or infinite, never below tol_sq, so
  // `close` needs no finiteness test; only a pixel without any link is tested (finite: a
  // singleton, else no point).
  const Point<3, Scalar>* const p = points.data();
  const auto close = [&](std::size_t i, std::size_t j) {
    const Scalar dx = p[i].x() - p[j].x(), dy = p[i].y() - p[j].y(), dz = p[i].z() - p[j].z();
    return dx * dx + dy * dy + dz * dz < tol_sq;
  };
  const auto finite = [&](std::size_t i) {
    return std::isfinite(p[i].x()) && std::isfinite(p[i].y()) && std::isfinite(p[i].z());
  };
  // Row runs: maximal chains of horizontally linked pixels, numbered in pixel order (`runs` holds
  // each one's first and one-past-last pixel; every pixel of a run is a point). Union-find over
  // the run numbers, the larger root always hung under the smaller, so every root is its
  // component's first run (smallest pixel). No per-pixel array: the pass allocates O(runs).
  std::vector<std::pair<std::uint32_t, std::uint32_t>> runs;
  std::vector<std::uint32_t> parent;
  runs.reserve(4 * height);
  parent.reserve(4 * height);
  const auto find = [&](std::uint32_t i) {
    while (parent[i] != i)
      i = parent[i] = parent[parent[i]];
    return i;
  };
  // Links between two rows, run against run: a run above and a run below that touch (a pixel of
  // one among the three pixels under or over a pixel of the other) are tested only while they
  // are not yet in one component, and only until one link joins them (vertical, then the two
  // diagonals of each column of the touching span). A link between runs already joined cannot
  // change the components, so they are those of every 8-neighbour link tested; on a densely
  // sampled surface the run below meets the run above at its first column and every other
  // pixel pair is skipped, so the row pass below is the per-pixel cost: one horizontal test.
  const auto link_rows = [&](std::size_t above_begin, std::size_t above_end,
                             std::size_t below_begin, std::size_t below_end,
                             std::size_t row_above) {
    const auto w = static_cast<std::ptrdiff_t>(width);
    const auto up = static_cast<std::ptrdiff_t>(row_above), down = up + w;
    std::size_t first = below_begin;  // the first run below that can touch the current run above
    for (std::size_t a = above_begin; a < above_end; ++a) {
      const std::ptrdiff_t a0 = runs[a].first - up, a1 = runs[a].second - up;  // columns
      while (first < below_end && std::ptrdiff_t(runs[first].second) - down < a0)
        ++first;
      for (std::size_t b = first; b < below_end; ++b) {
        const std::ptrdiff_t b0 = runs[b].first - down, b1 = runs[b].second - down;
        if (b0 > a1) break;  // this and later runs below are past the run above
        std::uint32_t ra = find(static_cast<std::uint32_t>(a));
        std::uint32_t rb = find(static_cast<std::uint32_t>(b));
        if (ra == rb) continue;
        const auto linked = [&] {
          for (std::ptrdiff_t c = std::max(a0, b0 - 1); c < std::min(a1, b1 + 1); ++c) {
            const auto i = static_cast<std::size_t>(up + c), j = static_cast<std::size_t>(down + c);
            if (c >= b0 && c < b1 && close(i, j)) return true;
            if (c + 1 >= b0 && c + 1 < b1 && close(i, j + 1)) return true;
            if (c - 1 >= b0 && c - 1 < b1 && close(i, j - 1)) return true;
          }
          return false;
        };
        if (!linked()) continue;
        if (rb < ra) std::swap(ra, rb);
        parent[rb] = ra;
      }
    }
  };
  std::size_t above_begin = 0;
  for (std::size_t r = 0; r < height; ++r) {
    const std::size_t row = r * width, row_begin = runs.size();
    const Point<3, Scalar>* const last = p + row + width - 1;  // the row's last pixel
    for (std::size_t c = 0; c < width; ++c) {
      const std::size_t start = c;
      // The run's last pixel: one test per pixel, the previous point kept in registers. Two
      // pixels per round, the two points alternating between two sets of registers (carried in
      // one set, they took three register copies per pixel).
      const Point<3, Scalar>* q = p + row + c;
      Scalar ax = q->x(), ay = q->y(), az = q->z();
      const auto near = [tol_sq](Scalar dx, Scalar dy, Scalar dz) {
        return dx * dx + dy * dy + dz * dz < tol_sq;
      };
      while (q != last) {
        const Scalar bx = q[1].x(), by = q[1].y(), bz = q[1].z();
        if (!near(bx - ax, by - ay, bz - az)) break;
        if (++q == last) break;
        ax = q[1].x();
        ay = q[1].y();
        az = q[1].z();
        if (!near(ax - bx, ay - by, az - bz)) break;
        ++q;
      }
      c = static_cast<std::size_t>(q - p) - row;
      if (c == start && !finite(row + c)) continue;  // a lone pixel with no point
      parent.push_back(static_cast<std::uint32_t>(runs.size()));
      runs.emplace_back(static_cast<std::uint32_t>(row + start),
                        static_cast<std::uint32_t>(row + c + 1));
    }
    if (r > 0) link_rows(above_begin, row_begin, row_begin, runs.size(), row - width);
    above_begin = row_begin;
  }
  // Component sizes at the roots (parent[] of every run becomes its root), then one bucket per
  // admitted component in increasing root order (count[root] becomes its bucket), then the runs'
  // pixels appended run by run, which keeps every bucket in increasing index order.
  std::vector<std::uint32_t> count(runs.size(), 0);
  std::size_t total = 0;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    parent[k] = find(static_cast<std::uint32_t>(k));
    const std::uint32_t length = runs[k].second - runs[k].first;
    count[parent[k]] += length;
    total += length;
  }
  if (finite_points) *finite_points = total;
  std::vector<std::vector<std::uint32_t>> clusters;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    if (parent[k] != k) continue;
    const std::uint32_t size = count[k];
    count[k] = none;
    if (size >= params.min_cluster_size && size <= params.max_cluster_size) {
      count[k] = static_cast<std::uint32_t>(clusters.size());
      clusters.emplace_back().reserve(size);
    }
  }
  for (std::size_t k = 0; k < runs.size(); ++k)
    if (const std::uint32_t s = count[parent[k]]; s != none) {
      auto& cluster = clusters[s];
      const std::size_t at = cluster.size();
      cluster.resize(at + (runs[k].second - runs[k].first));
      std::iota(cluster.begin() + static_cast<std::ptrdiff_t>(at), cluster.end(), runs[k].first);
    }
  std::stable_sort(clusters.begin(), clusters.end(),
                   [](const auto& a, const auto& b) { return a.size() > b.size(); });
  return clusters;
}

/// organized_euclidean_clusters of an organised Cloud (its width x height points). Throws
/// invalid_argument when the cloud is not organised (height < 2).
template <class Scalar>
[[nodiscard]] std::vector<std::vector<std::uint32_t>> organized_euclidean_clusters(
    const Cloud<3, Scalar>& cloud, const EuclideanClusteringParams& params = {}) {
  if (!cloud.is_organized())
    detail::throw_invalid_argument("organized_euclidean_clusters", "cloud.height", cloud.height,
                                   "must be > 1 (an organised cloud)");
  return organized_euclidean_clusters(std::span<const Point<3, Scalar>>(cloud.points), cloud.width,
                                      cloud.height, params);
}

}  // namespace rangenav
