#pragma once
// One call that registers two clouds, 2D or 3D:
//   const auto result = rangenav::align(target, source, guess, settings);
// aligns `source` to `target`: result.transform maps source points into the target frame. It
// runs the whole pipeline a user would compose from the parts:
//   1. voxel filter of both clouds (settings.voxel_size > 0; geometry/voxel_grid.hpp);
//   2. a kd-tree of the target (search/kd_tree.hpp);
//   3. what the method needs: the target's normals (point-to-plane) or both clouds' covariances
//      (GICP), from the PCA of settings.neighbors nearest neighbours (normals.hpp);
//   4. ICP with the method's solver, pairs farther apart than max_correspondence_distance
//      rejected, an optional robust kernel and an optional pose prior (icp.hpp).
// The result says why it stopped and carries iterations, fitness, RMSE and the information
// matrix of the match (IcpResult). Every stage runs on settings.num_threads threads with the
// same result for any thread count.
//
// Methods (Segal et al. 2009 compare the three on the same data):
//   point_to_point   closed-form (Arun / Umeyama) per iteration; the fastest per iteration, but a
//                    sparse or planar scene pulls the data towards the model's sample positions.
//   point_to_plane   Gauss-Newton on the distances to the target's tangent planes (Low 2004):
//                    slides along surfaces, converges in fewer iterations.
//   gicp             plane-to-plane (Generalized-ICP): both clouds' local surfaces; the most
//                    accurate on lidar and depth data, the default.

#include <cstddef>
#include <optional>
#include <string_view>
#include <type_traits>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/parallel.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/robust_kernel.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/voxel_grid.hpp"
#include "rangenav/registration/gicp_solver.hpp"
#include "rangenav/registration/icp.hpp"
#include "rangenav/registration/normals.hpp"
#include "rangenav/registration/point_to_plane_solver.hpp"
#include "rangenav/registration/point_to_point_solver.hpp"
#include "rangenav/registration/rejectors.hpp"
#include "rangenav/registration/transform_solver.hpp"
#include "rangenav/search/kd_tree.hpp"

namespace rangenav {

/// The residual align() minimises.
enum class RegistrationMethod {
  point_to_point,  ///< |T s - t|^2 (closed form per iteration)
  point_to_plane,  ///< (n_t . (T s - t))^2 against the target's normals
  gicp             ///< Generalized-ICP, plane-to-plane (Segal et al. 2009)
};

/// The method's name as spelled in the enum.
[[nodiscard]] constexpr std::string_view to_string(RegistrationMethod method) {
  switch (method) {
    case RegistrationMethod::point_to_point:
      return "point_to_point";
    case RegistrationMethod::point_to_plane:
      return "point_to_plane";
    case RegistrationMethod::gicp:
      return "gicp";
  }
  return "unknown";
}

/// Settings of align(). The defaults suit a lidar or depth cloud in metres; scale the distances
/// with your sensor.
template <std::floating_point Scalar = double>
struct AlignSettings {
  RegistrationMethod method = RegistrationMethod::gicp;  ///< the residual (see the file comment)
  /// Voxel edge of the filter applied to both clouds first (m); 0 = use the clouds as given.
  Scalar voxel_size = 0;
  /// Pairs farther apart are not formed (m). It must exceed the error of the initial guess
  /// (what a point may have to travel) and stay below the distance between surfaces that must
  /// not be confused: 1 m fits a vehicle lidar at 0.25 m voxels and a guess from odometry.
  Scalar max_correspondence_distance = Scalar(1);
  /// Neighbours of the normal / covariance PCA (normals.hpp: why 10).
  std::size_t neighbors = default_shape_neighbors;
  /// GICP's normal-direction variance of the regularised covariances (Segal et al. 2009).
  Scalar gicp_epsilon = static_cast<Scalar>(default_gicp_epsilon);
  /// Robust kernel on the residual (its delta is a distance in metres for every method).
  RobustKernel<Scalar> kernel{};
  int max_iterations = 50;  ///< ICP iterations at most (each with a correspondence search)
  Scalar translation_epsilon = Scalar(1e-4);  ///< m: converged when an iteration moves less ...
  Scalar rotation_epsilon = Scalar(1e-4);     ///< rad: ... and turns less than this
  /// Run ICP's degeneracy check (IcpResult::smallest_eigenvalue; costs a k-NN query per pair for
  /// the point-to-point method; point-to-plane and GICP take the normals they already have).
  /// The information matrix is computed either way.
  bool check_degeneracy = false;
  /// Threads for every stage (core/parallel.hpp); the result does not depend on it.
  int num_threads = 1;

  /// Throws invalid_argument for a value out of range.
  void validate() const {
    constexpr std::string_view where = "AlignSettings";
    detail::require_non_negative(where, "voxel_size", voxel_size);
    detail::require_positive(where, "max_correspondence_distance", max_correspondence_distance);
    if (!(gicp_epsilon > Scalar(0) && gicp_epsilon <= Scalar(1)))
      detail::throw_invalid_argument(where, "gicp_epsilon", gicp_epsilon, "must be in (0, 1]");
    if (max_iterations < 1)
      detail::throw_invalid_argument(where, "max_iterations", max_iterations, "must be >= 1");
    detail::require_non_negative(where, "translation_epsilon", translation_epsilon);
    detail::require_non_negative(where, "rotation_epsilon", rotation_epsilon);
    detail::require_threads(where, num_threads);
    kernel.validate(where);
  }
};

namespace detail {

template <int D, class Scalar, class Solver, class Source>
IcpResult<D, Scalar> run_align(const KdTree<D, Scalar>& tree, const Source& source,
                               const Transform<D, Scalar>& guess,
                               const AlignSettings<Scalar>& settings, Solver solver,
                               const PosePrior<D, Scalar>* prior,
                               const NeighborLists<Scalar>* model_neighbors = nullptr) {
  BasicIcp<D, Scalar, Solver, MaxDistanceRejector<Scalar>> icp;
  icp.solver = std::move(solver);
  icp.model_neighbors = model_neighbors;
  icp.params.max_iterations = settings.max_iterations;
  icp.params.translation_epsilon = settings.translation_epsilon;
  icp.params.rotation_epsilon = settings.rotation_epsilon;
  icp.params.check_degeneracy = settings.check_degeneracy;
  icp.params.num_threads = settings.num_threads;
  // Reusing a search pays over the many small steps of point-to-point ICP; the Gauss-Newton
  // methods converge in a few large ones, where it only costs.
  icp.params.reuse_neighbors = std::is_same_v<Solver, PointToPointSolver<D, Scalar>>;
  icp.template rejector<MaxDistanceRejector<Scalar>>().max_distance =
      settings.max_correspondence_distance;
  return prior != nullptr ? icp.align(tree, source, guess, *prior) : icp.align(tree, source, guess);
}

template <class Target, class Source>
IcpResult<traits::dimension_v<Target>, traits::scalar_t<Target>> align_impl(
    const Target& target, const Source& source,
    const Transform<traits::dimension_v<Target>, traits::scalar_t<Target>>& guess,
    const AlignSettings<traits::scalar_t<Target>>& settings,
    const PosePrior<traits::dimension_v<Target>, traits::scalar_t<Target>>* prior) {
  constexpr int D = traits::dimension_v<Target>;
  using Scalar = traits::scalar_t<Target>;
  settings.validate();
  constexpr std::string_view where = "align";
  if (traits::size(target) == 0) throw_invalid(where, "argument 'target' is empty (0 points)");
  if (traits::size(source) == 0) throw_invalid(where, "argument 'source' is empty (0 points)");
  const int threads = settings.num_threads;
  std::vector<Point<D, Scalar>> target_points, source_points;
  if (settings.voxel_size > Scalar(0)) {
    target_points = voxel_downsample(target, settings.voxel_size, threads);
    source_points = voxel_downsample(source, settings.voxel_size, threads);
  } else {
    target_points = finite_points(target);
    source_points = finite_points(source);
  }
  if (target_points.empty() || source_points.empty()) {
    // Only non-finite points (an all-invalid scan): nothing to pair, as ICP reports it.
    if (!is_rigid(guess, rigid_tolerance<Scalar>))
      throw_invalid(where, "argument 'guess' is not a rigid transform");
    IcpResult<D, Scalar> none;
    none.transform = guess;
    none.reason = IcpTermination::too_few_pairs;
    return none;
  }
  // The target's tree (correspondences, normals, covariances) and, for GICP, the source's
  // (its covariances): both at once on two threads.
  const bool gicp = settings.method == RegistrationMethod::gicp;
  // (A tree alone builds its parts on the threads; nested in the two-tree loop it runs serially.)
  std::optional<KdTree<D, Scalar>> trees[2];
  KdTreeParams tree_params;
  tree_params.num_threads = threads;
  for_each_block(gicp ? 2 : 1, 1, threads, [&](std::size_t b, std::size_t, std::size_t, int) {
    if (b == 0)
      trees[0].emplace(std::move(target_points), tree_params);
    else
      trees[1].emplace(source_points, tree_params);
  });
  const KdTree<D, Scalar>& tree = *trees[0];
  switch (settings.method) {
    case RegistrationMethod::point_to_point: {
      PointToPointSolver<D, Scalar> solver;
      solver.kernel = settings.kernel;
      return run_align<D, Scalar>(tree, source_points, guess, settings, solver, prior);
    }
    case RegistrationMethod::point_to_plane:
    case RegistrationMethod::gicp:
      break;
  }
  // The target's neighbour lists serve its normals / covariances and ICP's correspondence
  // search (BasicIcp::model_neighbors).
  const NeighborLists<Scalar> target_lists = neighbor_lists(tree, settings.neighbors, threads);
  if (settings.method == RegistrationMethod::point_to_plane) {
    const auto normals = estimate_normals(tree, target_lists, threads);
    PointToPlaneSolver<D, Scalar> solver;
    solver.model_normals = normals;
    solver.kernel = settings.kernel;
    solver.gauss_newton_steps = 1;
    return run_align<D, Scalar>(tree, source_points, guess, settings, solver, prior, &target_lists);
  }
  const auto target_covariances =
      estimate_covariances(tree, target_lists, threads, settings.gicp_epsilon);
  const KdTree<D, Scalar>& source_tree = *trees[1];
  const auto source_covariances =
      estimate_covariances(source_tree, settings.neighbors, threads, settings.gicp_epsilon);
  GicpSolver<D, Scalar> solver;
  solver.model_covariances = target_covariances;
  solver.data_covariances = source_covariances;
  solver.epsilon = settings.gicp_epsilon;
  solver.kernel = settings.kernel;
  return run_align<D, Scalar>(tree, source_tree.points(), guess, settings, solver, prior,
                              &target_lists);
}

}  // namespace detail

/// Aligns `source` to `target` (see the file comment): result.transform maps source points into
/// the target frame, starting from `guess`. Non-finite points are skipped. Throws
/// invalid_argument for empty clouds, a non-rigid guess or invalid settings.
template <PointCloud Target, PointCloudOf<traits::dimension_v<Target>> Source>
requires std::same_as<traits::scalar_t<Target>, traits::scalar_t<Source>>
[[nodiscard]] IcpResult<traits::dimension_v<Target>, traits::scalar_t<Target>> align(
    const Target& target, const Source& source,
    const Transform<traits::dimension_v<Target>, traits::scalar_t<Target>>& guess =
        Transform<traits::dimension_v<Target>, traits::scalar_t<Target>>::Identity(),
    const AlignSettings<traits::scalar_t<Target>>& settings = {}) {
  return detail::align_impl(target, source, guess, settings, nullptr);
}

/// As above, with a Gaussian prior on the transform (e.g. odometry and its noise): where the
/// geometry leaves a direction free, the result follows the prior (icp.hpp).
template <PointCloud Target, PointCloudOf<traits::dimension_v<Target>> Source>
requires std::same_as<traits::scalar_t<Target>, traits::scalar_t<Source>>
[[nodiscard]] IcpResult<traits::dimension_v<Target>, traits::scalar_t<Target>> align(
    const Target& target, const Source& source,
    const Transform<traits::dimension_v<Target>, traits::scalar_t<Target>>& guess,
    const AlignSettings<traits::scalar_t<Target>>& settings,
    const PosePrior<traits::dimension_v<Target>, traits::scalar_t<Target>>& prior) {
  prior.validate("align");
  return detail::align_impl(target, source, guess, settings, &prior);
}

}  // namespace rangenav
