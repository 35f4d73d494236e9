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

struct EuclideanClusteringParams {
  double tolerance = 0.02;  ///< m, largest gap inside a cluster
  std::size_t min_cluster_size = 1;
  std::size_t max_cluster_size = std::numeric_limits<std::size_t>::max();

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
  const auto close = [&](std::size_t i, std::size_t j) {
    return (points[i] - points[j]).squaredNorm() < tol_sq;
  };
  const auto finite = [&](std::size_t i) {
    return std::isfinite(points[i].x()) && std::isfinite(points[i].y()) &&
           std::isfinite(points[i].z());
  };
  // Row runs: maximal chains of horizontally linked pixels, numbered in pixel order (`runs` holds
  // each one's first and one-past-last pixel). Union-find over the run numbers, the larger root
  // always hung under the smaller, so every root is its component's first run (smallest pixel).
  // Only two rows are held at a time (the run of each pixel, none for a pixel with no point, and
  // whether it is linked to its right neighbour): the pass allocates O(width + runs), not O(n).
  std::vector<std::pair<std::uint32_t, std::uint32_t>> runs;
  std::vector<std::uint32_t> parent;
  runs.reserve(4 * height);
  parent.reserve(4 * height);
  std::vector<std::uint32_t> run_above(width), run_below(width);
  std::vector<std::uint8_t> right_above(width), right_below(width);
  const auto row_runs = [&](std::size_t r, std::vector<std::uint32_t>& run,
                            std::vector<std::uint8_t>& right) {
    const std::size_t row = r * width;
    std::size_t start = 0;  // column of the current run's first pixel
    for (std::size_t c = 0; c < width; ++c) {
      const std::size_t i = row + c;
      const bool linked = c + 1 < width && close(i, i + 1);
      right[c] = linked ? 1 : 0;
      if (linked) continue;
      if (start == c && !finite(i)) {  // a lone pixel with no point
        run[c] = none;
      } else {
        const auto id = static_cast<std::uint32_t>(runs.size());
        runs.emplace_back(static_cast<std::uint32_t>(row + start),
                          static_cast<std::uint32_t>(i + 1));
        parent.push_back(id);
        std::fill(run.begin() + static_cast<std::ptrdiff_t>(start),
                  run.begin() + static_cast<std::ptrdiff_t>(c + 1), id);
      }
      start = c + 1;
    }
  };
  const auto find = [&](std::uint32_t i) {
    while (parent[i] != i)
      i = parent[i] = parent[parent[i]];
    return i;
  };
  // The last pair of runs united: consecutive pixels of two overlapping runs repeat it.
  std::uint32_t last_a = none, last_b = none;
  const auto unite = [&](std::uint32_t a, std::uint32_t b) {
    if (a == last_a && b == last_b) return;
    last_a = a;
    last_b = b;
    a = find(a);
    b = find(b);
    if (a < b)
      parent[b] = a;
    else if (b < a)
      parent[a] = b;
  };
  // Links to the next row: first the vertical ones (vert[c]: pixel c of this row is linked to
  // the one below), then the diagonals, each tested only when no path of two tested links
  // already joins its ends (for i -> below+1: i - below - below+1 or i - i+1 - below+1), which
  // on a densely sampled surface leaves about one vertical test per pixel; the components are
  // the same as with every 8-neighbour link tested.
  std::vector<std::uint8_t> vert(width);
  if (height > 0) row_runs(0, run_above, right_above);
  for (std::size_t r = 0; r + 1 < height; ++r) {
    row_runs(r + 1, run_below, right_below);
    const std::size_t row = r * width;
    for (std::size_t c = 0; c < width; ++c) {
      const std::size_t i = row + c, below = i + width;
      vert[c] = run_above[c] != none && run_below[c] != none && close(i, below) ? 1 : 0;
      if (vert[c]) unite(run_above[c], run_below[c]);
    }
    for (std::size_t c = 0; c < width; ++c) {
      const std::size_t i = row + c, below = i + width;
      if (run_above[c] == none) continue;
      if (c + 1 < width && !(vert[c] && right_below[c]) && !(right_above[c] && vert[c + 1]) &&
          run_below[c + 1] != none && close(i, below + 1))
        unite(run_above[c], run_below[c + 1]);
      if (c > 0 && !(vert[c] && right_below[c - 1]) && !(right_above[c - 1] && vert[c - 1]) &&
          run_below[c - 1] != none && close(i, below - 1))
        unite(run_above[c], run_below[c - 1]);
    }
    std::swap(run_above, run_below);
    std::swap(right_above, right_below);
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
