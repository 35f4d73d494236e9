#pragma once
// Local shape of a cloud from the PCA of each point's k nearest neighbours (geometry/pca.hpp): the
// surface normals that point-to-plane ICP needs and the regularised covariances of Generalized-ICP.
//
//   normal       the eigenvector of the smallest eigenvalue, turned towards the origin of the
//                cloud's frame (the sensor); zero where the neighbourhood does not define one
//                (fewer than D + 1 neighbours, all of them at one spot).
//   covariance   Segal et al. 2009, Sec. III-B: C = V diag(eps, 1, 1) V^T (2D: diag(eps, 1)) with
//                V the eigenvectors, i.e. unit variance along the surface and eps across it,
//                whatever the sampling density; the identity where there is no surface.
//
// Neighbourhood size k: 10 resolves the surface of a cloud downsampled to a few points per
// surface patch of the voxel size (a 3D plane needs 3 points, a covariance 6 values; about 10
// leaves a margin against range noise without reaching across an edge): small_gicp's
// preprocessing default. Segal et al. and PCL use 20 (their clouds are not downsampled first).
//
// The kNN queries (neighbor_lists, search/nearest_neighbor_search.hpp) and the fits run on up to
// num_threads threads; every point is computed independently, so the result does not depend on
// the thread count. A caller that has the lists already (align() hands the target's to ICP too)
// passes them instead of k.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/parallel.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/pca.hpp"
#include "rangenav/search/kd_tree.hpp"
#include "rangenav/search/nearest_neighbor_search.hpp"

namespace rangenav {

/// The neighbours of estimate_normals / estimate_covariances when none is given (see the file
/// comment).
inline constexpr std::size_t default_shape_neighbors = 10;

/// The normal-direction variance eps of Generalized-ICP's regularised covariances (Segal et al.
/// 2009; PCL's and small_gicp's value): the surface is 1000 times thinner than it is wide.
inline constexpr double default_gicp_epsilon = 1e-3;

namespace detail {

/// Calls out(i, &normal) for every point i of the search structure with the PCA normal of its
/// neighbour list, or out(i, nullptr) when it holds fewer than D + 1 points or they coincide.
template <NearestNeighborSearch S, class Out>
void for_each_local_normal(const S& search, const NeighborLists<typename S::scalar_type>& lists,
                           int num_threads, const Out& out) {
  constexpr int D = S::dimension;
  using Scalar = typename S::scalar_type;
  constexpr std::size_t block = 256;
  for_each_block(
      search.size(), block, num_threads, [&](std::size_t, std::size_t begin, std::size_t end, int) {
        for (std::size_t i = begin; i < end; ++i) {
          const std::span<const std::uint32_t> list = lists.of(i);
          if (list.size() < static_cast<std::size_t>(D + 1)) {
            out(i, static_cast<const Point<D, Scalar>*>(nullptr));
            continue;
          }
          const PcaFit<D, Scalar> fit = fit_moments<D, Scalar>(
              list.size(), [&](std::size_t m) -> decltype(auto) { return search.point(list[m]); });
          if (!(fit.covariance.cwiseAbs().maxCoeff() > Scalar(0))) {
            out(i, static_cast<const Point<D, Scalar>*>(nullptr));
            continue;
          }
          const Point<D, Scalar> n = smallest_eigenvector<D, Scalar>(fit.covariance);
          out(i, n.allFinite() ? &n : nullptr);
        }
      });
}

template <NearestNeighborSearch S>
void require_lists(std::string_view where, const S& search,
                   const NeighborLists<typename S::scalar_type>& lists) {
  if (lists.size() != search.size())
    throw_invalid_argument(where, "lists.size()", lists.size(),
                           "must equal the search structure's size");
}

template <class Scalar>
void require_epsilon(std::string_view where, Scalar epsilon) {
  if (!(epsilon > Scalar(0) && epsilon <= Scalar(1)))
    throw_invalid_argument(where, "epsilon", epsilon, "must be in (0, 1]");
}

template <NearestNeighborSearch S>
void require_neighbors(std::string_view where, std::size_t k) {
  if (k < static_cast<std::size_t>(S::dimension + 1))
    throw_invalid_argument(where, "k", k, "must be >= dimension + 1");
}

}  // namespace detail

/// Unit normals of the points of a search structure, indexed like search.point(i) (hence by
/// Correspondence::model_index when it is ICP's model). Throws invalid_argument unless
/// k >= D + 1 and num_threads >= 1.
template <NearestNeighborSearch S>
[[nodiscard]] std::vector<Point<S::dimension, typename S::scalar_type>> estimate_normals(
    const S& search, std::size_t k = default_shape_neighbors, int num_threads = 1) {
  detail::require_neighbors<S>("estimate_normals", k);
  detail::require_threads("estimate_normals", num_threads);
  return estimate_normals(search, neighbor_lists(search, k, num_threads), num_threads);
}

/// As above, from the neighbour lists of the search structure's points (neighbor_lists(search,
/// k)): one k-NN pass can serve the normals and ICP (align.hpp). Throws invalid_argument unless
/// the lists are the structure's size and num_threads >= 1.
template <NearestNeighborSearch S>
[[nodiscard]] std::vector<Point<S::dimension, typename S::scalar_type>> estimate_normals(
    const S& search, const NeighborLists<typename S::scalar_type>& lists, int num_threads = 1) {
  constexpr int D = S::dimension;
  using Scalar = typename S::scalar_type;
  detail::require_lists("estimate_normals", search, lists);
  detail::require_threads("estimate_normals", num_threads);
  std::vector<Point<D, Scalar>> normals(search.size(), Point<D, Scalar>::Zero());
  detail::for_each_local_normal(
      search, lists, num_threads, [&](std::size_t i, const Point<D, Scalar>* normal) {
        if (normal == nullptr) return;
        normals[i] = normal->dot(search.point(i)) > Scalar(0) ? -*normal : *normal;
      });
  return normals;
}

/// Generalized-ICP covariances of the points of a search structure, indexed like
/// search.point(i) (see the file comment). Throws invalid_argument unless k >= D + 1,
/// num_threads >= 1 and 0 < epsilon <= 1.
template <NearestNeighborSearch S>
[[nodiscard]] std::vector<Eigen::Matrix<typename S::scalar_type, S::dimension, S::dimension>>
estimate_covariances(
    const S& search, std::size_t k = default_shape_neighbors, int num_threads = 1,
    typename S::scalar_type epsilon = static_cast<typename S::scalar_type>(default_gicp_epsilon)) {
  constexpr std::string_view where = "estimate_covariances";
  detail::require_neighbors<S>(where, k);
  detail::require_threads(where, num_threads);
  detail::require_epsilon(where, epsilon);
  return estimate_covariances(search, neighbor_lists(search, k, num_threads), num_threads, epsilon);
}

/// As above, from the neighbour lists of the search structure's points (neighbor_lists(search,
/// k)). Throws invalid_argument unless the lists are the structure's size, num_threads >= 1 and
/// 0 < epsilon <= 1.
template <NearestNeighborSearch S>
[[nodiscard]] std::vector<Eigen::Matrix<typename S::scalar_type, S::dimension, S::dimension>>
estimate_covariances(
    const S& search, const NeighborLists<typename S::scalar_type>& lists, int num_threads = 1,
    typename S::scalar_type epsilon = static_cast<typename S::scalar_type>(default_gicp_epsilon)) {
  constexpr int D = S::dimension;
  using Scalar = typename S::scalar_type;
  using Matrix = Eigen::Matrix<Scalar, D, D>;
  constexpr std::string_view where = "estimate_covariances";
  detail::require_lists(where, search, lists);
  detail::require_threads(where, num_threads);
  detail::require_epsilon(where, epsilon);
  std::vector<Matrix> covariances(search.size(), Matrix::Identity());
  // V diag(eps, 1, 1) V^T = I - (1 - eps) n n^T for the unit normal n (V orthonormal).
  detail::for_each_local_normal(
      search, lists, num_threads, [&](std::size_t i, const Point<D, Scalar>* normal) {
        if (normal == nullptr) return;
        covariances[i] = Matrix::Identity() - (Scalar(1) - epsilon) * *normal * normal->transpose();
      });
  return covariances;
}

/// Unit normals of the points of a cloud, one per point in cloud order (zero for a non-finite
/// point); builds a KdTree of the cloud. See estimate_normals(search, ...).
template <PointCloud C>
[[nodiscard]] std::vector<cloud_point_t<C>> estimate_normals(
    const C& cloud, std::size_t k = default_shape_neighbors, int num_threads = 1) {
  const KdTree<traits::dimension_v<C>, traits::scalar_t<C>> tree(cloud);
  const auto by_tree = estimate_normals(tree, k, num_threads);
  std::vector<cloud_point_t<C>> normals(traits::size(cloud), cloud_point_t<C>::Zero());
  for (std::size_t i = 0; i < tree.size(); ++i)
    normals[tree.source_index(i)] = by_tree[i];
  return normals;
}

/// Generalized-ICP covariances of the points of a cloud, one per point in cloud order (the
/// identity for a non-finite point); builds a KdTree of the cloud. See
/// estimate_covariances(search, ...).
template <PointCloud C>
[[nodiscard]] std::vector<
    Eigen::Matrix<traits::scalar_t<C>, traits::dimension_v<C>, traits::dimension_v<C>>>
estimate_covariances(
    const C& cloud, std::size_t k = default_shape_neighbors, int num_threads = 1,
    traits::scalar_t<C> epsilon = static_cast<traits::scalar_t<C>>(default_gicp_epsilon)) {
  constexpr int D = traits::dimension_v<C>;
  using Scalar = traits::scalar_t<C>;
  const KdTree<D, Scalar> tree(cloud);
  const auto by_tree = estimate_covariances(tree, k, num_threads, epsilon);
  std::vector<Eigen::Matrix<Scalar, D, D>> covariances(traits::size(cloud),
                                                       Eigen::Matrix<Scalar, D, D>::Identity());
  for (std::size_t i = 0; i < tree.size(); ++i)
    covariances[tree.source_index(i)] = by_tree[i];
  return covariances;
}

}  // namespace rangenav
