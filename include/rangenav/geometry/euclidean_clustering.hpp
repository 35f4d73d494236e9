#pragma once
// Euclidean clustering (paper 004 §3.3: "First, Euclidean clustering is used to determine
// connected regions of the point cloud"): two points belong to one cluster when a chain of points
// with consecutive distances below `tolerance` joins them; clusters outside
// [min_cluster_size, max_cluster_size] are dropped (as PCL's EuclideanClusterExtraction does).
//
// Runs on any neighbour-search object with the radius query of the NearestNeighborSearch concept
// (search/nearest_neighbor_search.hpp: size(), point(i), nearest(q), radius(q, radius_sq, out));
// geometry/ does not include search/, so the requirement is spelled out here: pass a
// rangenav::KdTree.

#include <algorithm>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"

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

}  // namespace rangenav
