#pragma once
// Iterative Closest Point (Besl & McKay 1992; paper 000 §3.1, paper 002 §6.3), one code path for
// SE(2) and SE(3). The stages of every iteration (libpointmatcher's taxonomy):
//   correspondence search  nearest model point of every data point under the current transform,
//                          bounded by the tightest `max_distance_sq` any rejector exposes and
//                          skipping data points a rejector does not `admit` (frustum culling);
//   rejection              each rejector of the compile-time list, in order;
//   solver                 closed-form minimiser of Eq. (1) of paper 000 over the kept pairs;
//   convergence check      change of the transform below the epsilons and every rejector settled.
// Policies are public typed members with defaults (as in small_gicp's Registration):
//   Icp<2, double, DecayingDistanceRejector<double>, UniqueModelPointRejector> icp;
//   icp.params.max_iterations = 30;
//   icp.rejector<DecayingDistanceRejector<double>>().final_distance = 0.05;
//   const auto result = icp.align(KdTree<2, double>(model_scan), data_scan, initial_guess);
// The result says why it stopped and carries a degeneracy signal: the smallest eigenvalue of the
// point-to-plane normal equations at the solution, so a featureless corridor is reported.
//
// An Icp object owns scratch buffers reused across calls: align() allocates nothing once they
// have grown. One object per thread.

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/registration/correspondence.hpp"
#include "rangenav/registration/point_to_point_solver.hpp"
#include "rangenav/registration/rejectors.hpp"
#include "rangenav/search/nearest_neighbor_search.hpp"

namespace rangenav {

/// Why an alignment stopped.
enum class IcpTermination {
  converged,       ///< the transform stopped changing and every rejector settled
  max_iterations,  ///< the iteration budget ran out first
  too_few_pairs,   ///< fewer pairs survived than the solver needs (no overlap, empty / NaN data)
  degenerate,      ///< the pairs do not determine a transform (identical / collinear points), or
                   ///< the normal equations are near-singular (e.g. a featureless corridor)
};

[[nodiscard]] constexpr std::string_view to_string(IcpTermination reason) {
  switch (reason) {
    case IcpTermination::converged:
      return "converged";
    case IcpTermination::max_iterations:
      return "max_iterations";
    case IcpTermination::too_few_pairs:
      return "too_few_pairs";
    case IcpTermination::degenerate:
      return "degenerate";
  }
  return "unknown";
}

/// ICP parameters that are not a policy's.
template <std::floating_point Scalar = double>
struct IcpParams {
  int max_iterations = 50;
  Scalar translation_epsilon = Scalar(1e-4);  ///< m: converged when the update moves less ...
  Scalar rotation_epsilon = Scalar(1e-4);     ///< rad: ... and turns less than this
  std::size_t min_pairs = 0;                  ///< at least the solver's minimum; 0 = that minimum
  /// Evaluate the normal equations at the solution (costs one k-NN query per pair, once).
  bool check_degeneracy = true;
  /// A smallest normalised eigenvalue below this reports IcpTermination::degenerate. The
  /// eigenvalues are per pair and unit-free (rotations scaled by the data's RMS radius): about
  /// 1/D for a well-constrained scene, ~0 along a corridor.
  Scalar degeneracy_threshold = Scalar(0.01);
  /// Neighbours for the model normals of the degeneracy check; 0 = 5 in 2D, 10 in 3D.
  std::size_t normal_neighbors = 0;
  /// Skip the correspondence search of a data point whose nearest model point is provably
  /// among the `reuse_candidates` nearest of its last search (see BasicIcp::match): the pairs,
  /// and so the result, are those of a search every iteration; false searches every time (the
  /// reference).
  bool reuse_neighbors = true;
  /// Model points kept per data point for reuse_neighbors (>= 2): more make a search costlier
  /// but let it serve larger moves of the estimate.
  std::size_t reuse_candidates = 2;
  /// Coarse-to-fine: while the estimate still moves (large early thresholds, steps of
  /// centimetres), iterate on a subset of about `coarse_points` data points only (every k-th,
  /// k = floor(data points / coarse_points)); once that subset meets the convergence test (the
  /// epsilons above, every rejector settled), continue on all points to convergence. The last
  /// iteration always uses all points, so matched_count, fitness and the final pairs are the
  /// full set's. 0, or data with fewer than 2 coarse_points points, = all points throughout.
  std::size_t coarse_points = 0;

  void validate() const {
    constexpr std::string_view where = "IcpParams";
    if (max_iterations < 1)
      detail::throw_invalid_argument(where, "max_iterations", max_iterations, "must be >= 1");
    detail::require_non_negative(where, "translation_epsilon", translation_epsilon);
    detail::require_non_negative(where, "rotation_epsilon", rotation_epsilon);
    detail::require_non_negative(where, "degeneracy_threshold", degeneracy_threshold);
    if (reuse_neighbors && reuse_candidates < 2)
      detail::throw_invalid_argument(where, "reuse_candidates", reuse_candidates, "must be >= 2");
  }
};

/// The outcome of one alignment. Every number is finite.
template <int D, class Scalar = double>
struct IcpResult {
  static constexpr int dof = D == 2 ? 3 : 6;

  Transform<D, Scalar> transform = Transform<D, Scalar>::Identity();  ///< data -> model frame
  bool converged = false;
  IcpTermination reason = IcpTermination::max_iterations;
  int iterations = 0;  ///< iterations run (each with a correspondence search)
  /// Of them, those on the IcpParams::coarse_points subset of the data (the first ones).
  int coarse_iterations = 0;
  std::size_t matched_count = 0;  ///< data points the last search paired (before rejectors)
  std::size_t inlier_count = 0;   ///< pairs kept by the rejectors in the last iteration
  std::size_t data_count = 0;     ///< finite data points
  /// Correspondence searches run on the model (at most iterations x data_count; fewer when
  /// IcpParams::reuse_neighbors proved a data point's nearest model point unchanged).
  std::size_t neighbor_searches = 0;
  Scalar rmse = 0;  ///< RMS distance of the kept pairs under the final transform (m)
  /// matched_count / data_count: the fraction of data points with a model point within the
  /// search bound (Open3D's fitness). With a unique-pair rejector and a sparser model,
  /// inlier_count / data_count would be bounded by the density ratio instead.
  Scalar fitness = 0;
  /// Smallest normalised eigenvalue of the point-to-plane normal equations at the solution,
  /// when it was evaluated (see IcpParams::degeneracy_threshold).
  std::optional<Scalar> smallest_eigenvalue;
  /// Largest / smallest eigenvalue (+inf when singular), when evaluated.
  std::optional<Scalar> condition_number;
  /// The least constrained motion (tx, ty[, tz], rotation...) when evaluated: along a corridor
  /// it points along the corridor's axis.
  std::optional<Eigen::Matrix<Scalar, dof, 1>> weakest_direction;
};

/// ICP with a solver policy and a compile-time list of rejectors (see the file comment).
template <int D, std::floating_point Scalar, class Solver, class... Rejectors>
class BasicIcp {
  static_assert(D == 2 || D == 3, "Icp: dimension must be 2 or 3");
  static_assert(TransformSolver<Solver, D, Scalar>, "Icp: Solver must model TransformSolver");
  static_assert((CorrespondenceRejector<Rejectors, D, Scalar> && ...),
                "Icp: every rejector must model CorrespondenceRejector");

 public:
  static constexpr int dimension = D;
  using scalar_type = Scalar;
  using point_type = Point<D, Scalar>;
  using transform_type = Transform<D, Scalar>;
  using result_type = IcpResult<D, Scalar>;
  using correspondence_type = Correspondence<D, Scalar>;

  IcpParams<Scalar> params{};
  Solver solver{};
  std::tuple<Rejectors...> rejectors{};

  BasicIcp() = default;
  explicit BasicIcp(const IcpParams<Scalar>& p, Rejectors... r)
      : params(p), rejectors(std::move(r)...) {}

  /// The rejector of type R in the list.
  template <class R>
  [[nodiscard]] R& rejector() {
    return std::get<R>(rejectors);
  }
  template <class R>
  [[nodiscard]] const R& rejector() const {
    return std::get<R>(rejectors);
  }

  /// Aligns `data` to the indexed `model`, starting from `initial_guess` (data -> model frame).
  /// Throws invalid_argument for an empty model or data cloud, a non-finite or non-rigid
  /// initial guess and invalid parameters; data without enough finite points (all-NaN scans)
  /// returns reason too_few_pairs with the initial guess.
  template <NearestNeighborSearch Model, PointCloudOf<D> Data>
  requires(Model::dimension == D && std::same_as<typename Model::scalar_type, Scalar>) result_type
      align(const Model& model, const Data& data,
            const transform_type& initial_guess = transform_type::Identity()) {
    constexpr std::string_view where = "Icp::align";
    params.validate();
    std::apply([](auto&... r) { (validate_rejector(r), ...); }, rejectors);
    if (model.size() == 0) detail::throw_invalid(where, "argument 'model' is empty (0 points)");
    if (traits::size(data) == 0)
      detail::throw_invalid(where, "argument 'data' is empty (0 points)");
    if (!initial_guess.matrix().allFinite())
      detail::throw_invalid(where, "argument 'initial_guess' is not finite");
    if (!is_rigid(initial_guess, Scalar(std::is_same_v<Scalar, float> ? 1e-3 : 1e-6)))
      detail::throw_invalid(where, "argument 'initial_guess' is not a rigid transform");

    data_.clear();
    data_index_.clear();
    const std::size_t n = traits::size(data);
    for (std::size_t i = 0; i < n; ++i) {
      const point_type p = traits::point(data, i).template cast<Scalar>();
      if (p.allFinite()) {
        data_.push_back(p);
        data_index_.push_back(static_cast<std::uint32_t>(i));
      }
    }
    return run(model, initial_guess);
  }

  /// The pairs kept in the last iteration of the last alignment.
  [[nodiscard]] std::span<const correspondence_type> correspondences() const { return pairs_; }

 private:
  template <class R>
  static void validate_rejector(const R& r) {
    if constexpr (requires { r.validate(); }) r.validate();
  }

  template <class Model>
  result_type run(const Model& model, transform_type transform) {
    result_type result;
    result.data_count = data_.size();
    const std::size_t min_pairs = std::max<std::size_t>(params.min_pairs, Solver::min_pairs);
    IcpContext<D, Scalar> ctx{0, transform, model.size(), data_.size()};
    std::apply([&](auto&... r) { (begin_rejector(r, model.size()), ...); }, rejectors);
    pairs_.reserve(data_.size());
    const std::size_t stride = params.coarse_points > 0 ? data_.size() / params.coarse_points : 1;
    bool coarse = stride > 1;

    for (int it = 0; it < params.max_iterations; ++it) {
      ctx.iteration = it;
      ctx.transform = transform;
      result.iterations = it + 1;
      // The last iteration of the budget is never a coarse one.
      const bool coarse_now = coarse && it + 1 < params.max_iterations;
      result.neighbor_searches += match(model, ctx, coarse_now ? stride : 1);
      result.matched_count = pairs_.size();
      std::apply([&](auto&... r) { (reject_with(r, ctx), ...); }, rejectors);
      if (pairs_.size() < min_pairs) {
        if (coarse_now) {  // too sparse a subset: this iteration again on all points
          coarse = false;
          --it;
          continue;
        }
        result.reason = IcpTermination::too_few_pairs;
        break;
      }
      if (coarse_now) ++result.coarse_iterations;
      // A solver that refines from the current transform (PointToPlaneSolver) gets it.
      const std::span<const correspondence_type> kept(pairs_);
      std::optional<transform_type> next;
      if constexpr (requires { solver.solve(kept, transform); })
        next = solver.solve(kept, transform);
      else
        next = solver.solve(kept);
      if (!next) {
        result.reason = IcpTermination::degenerate;
        break;
      }
      const transform_type delta = transform.inverse(Eigen::Isometry) * *next;
      transform = *next;
      const bool small = delta.translation().norm() <= params.translation_epsilon &&
                         rotation_angle(delta) <= params.rotation_epsilon;
      bool settled = true;
      std::apply([&](const auto&... r) { ((settled = settled && is_settled(r, ctx)), ...); },
                 rejectors);
      if (small && settled && coarse_now) {
        coarse = false;  // the subset converged: refine on all points
        continue;
      }
      if (small && settled) {
        result.reason = IcpTermination::converged;
        result.converged = true;
        break;
      }
    }

    result.transform = transform;
    result.inlier_count = pairs_.size();
    if (!pairs_.empty()) {
      Scalar sum_sq = 0;
      const detail::AffineApply<D, Scalar> apply(transform);
      for (const auto& c : pairs_)
        sum_sq += (c.model - apply(c.data)).squaredNorm();
      result.rmse = std::sqrt(sum_sq / static_cast<Scalar>(pairs_.size()));
    }
    result.fitness = data_.empty() ? Scalar(0)
                                   : static_cast<Scalar>(result.matched_count) /
                                         static_cast<Scalar>(data_.size());
    if (params.check_degeneracy && result.reason != IcpTermination::too_few_pairs &&
        result.reason != IcpTermination::degenerate)
      evaluate_degeneracy(model, transform, result);
    return result;
  }

  // The pairs of one iteration, of every `stride`-th data point; returns the number of model
  // searches run.
  template <class Model>
  std::size_t match(const Model& model, const IcpContext<D, Scalar>& ctx, std::size_t stride) {
    Scalar bound_sq = unbounded_sq<Scalar>;
    std::apply([&](const auto&... r) { ((bound_sq = std::min(bound_sq, bound_of(r, ctx))), ...); },
               rejectors);
    pairs_.clear();
    const detail::AffineApply<D, Scalar> t(ctx.transform);
    const bool reuse = params.reuse_neighbors && std::isfinite(bound_sq);
    const std::size_t candidates = params.reuse_candidates;
    if (reuse && ctx.iteration == 0) {
      cache_.assign(data_.size(), {});
      candidates_.resize(data_.size() * candidates);
    }
    const Scalar bound = std::sqrt(bound_sq);
    std::size_t searches = 0;
    for (std::size_t j = 0; j < data_.size(); j += stride) {
      const point_type p = t(data_[j]);
      bool admitted = true;
      std::apply([&](const auto&... r) { ((admitted = admitted && admits(r, ctx, p)), ...); },
                 rejectors);
      if (!admitted) continue;
      if (!reuse) {
        ++searches;
        if (const auto nb = model.nearest(p, bound_sq))
          pairs_.push_back(
              {data_[j], model.point(nb->index), nb->distance_sq, data_index_[j], nb->index});
        continue;
      }
      // Reuse of the last search of this data point, made at `query`, which found the
      // candidates (its k nearest model points within the bound) and proved every other model
      // point at least `others` away. The point has since moved by delta, so every other model
      // point is now at least others - delta away (triangle inequality): if the closest
      // candidate is nearer than that, it is the nearest model point; if there was none and
      // others - delta reaches the bound, there is none.
      NeighborCache& c = cache_[j];
      if (c.count != no_cache) {
        const Scalar delta = (p - c.query).norm();
        const Scalar margin = Scalar(64) * std::numeric_limits<Scalar>::epsilon() *
                              (Scalar(1) + p.template lpNorm<Eigen::Infinity>() + c.others);
        const Scalar reach = c.others - delta - margin;
        if (c.count == 0) {
          if (reach >= bound) continue;
        } else {
          std::uint32_t best = 0;
          Scalar best_sq = std::numeric_limits<Scalar>::infinity();
          for (std::uint32_t k = 0; k < c.count; ++k) {
            const std::uint32_t index = candidates_[j * candidates + k];
            const point_type& m = model.point(index);
            Scalar d_sq = 0;  // summed per axis in order, as the kd-tree's metric does
            for (int d = 0; d < D; ++d)
              d_sq += (p[d] - m[d]) * (p[d] - m[d]);
            if (d_sq < best_sq) {
              best_sq = d_sq;
              best = index;
            }
          }
          if (std::sqrt(best_sq) < reach) {
            if (best_sq < bound_sq)
              pairs_.push_back({data_[j], model.point(best), best_sq, data_index_[j], best});
            continue;
          }
        }
      }
      // The k nearest within the bound: the first pairs, the k-th bounds the others.
      ++searches;
      model.knn(p, candidates, knn_, bound_sq);
      c.query = p;
      c.count = static_cast<std::uint32_t>(knn_.size());
      c.others = knn_.size() == candidates ? std::sqrt(knn_.back().distance_sq) : bound;
      for (std::size_t k = 0; k < knn_.size(); ++k)
        candidates_[j * candidates + k] = knn_[k].index;
      if (!knn_.empty())
        pairs_.push_back({data_[j], model.point(knn_[0].index), knn_[0].distance_sq, data_index_[j],
                          knn_[0].index});
    }
    return searches;
  }

  /// The normal equations J^T J of point-to-plane ICP at the solution, rows
  /// J_i = [n_i^T, ((p_i - c) x n_i)^T / L] with model normals n_i (PCA of k neighbours), data
  /// centroid c and RMS radius L, divided by the pair count.
  template <class Model>
  void evaluate_degeneracy(const Model& model, const transform_type& transform,
                           result_type& result) {
    constexpr int dof = result_type::dof;
    if (pairs_.size() < static_cast<std::size_t>(dof)) return;
    const std::size_t k =
        params.normal_neighbors != 0 ? params.normal_neighbors : (D == 2 ? 5u : 10u);
    point_type c = point_type::Zero();
    for (const auto& pr : pairs_)
      c += transform * pr.data;
    c /= static_cast<Scalar>(pairs_.size());
    Scalar radius_sq = 0;
    for (const auto& pr : pairs_)
      radius_sq += (transform * pr.data - c).squaredNorm();
    radius_sq /= static_cast<Scalar>(pairs_.size());
    if (!(radius_sq > Scalar(0))) return;
    const Scalar inv_radius = Scalar(1) / std::sqrt(radius_sq);

    using Matrix = Eigen::Matrix<Scalar, dof, dof>;
    using Row = Eigen::Matrix<Scalar, dof, 1>;
    Matrix h = Matrix::Zero();
    std::size_t rows = 0;
    for (const auto& pr : pairs_) {
      if (model.knn(pr.model, k, knn_) < static_cast<std::size_t>(D)) continue;
      point_type mean = point_type::Zero();
      for (const auto& nb : knn_)
        mean += model.point(nb.index);
      mean /= static_cast<Scalar>(knn_.size());
      Eigen::Matrix<Scalar, D, D> cov = Eigen::Matrix<Scalar, D, D>::Zero();
      for (const auto& nb : knn_) {
        const point_type d = model.point(nb.index) - mean;
        cov.noalias() += d * d.transpose();
      }
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix<Scalar, D, D>> eig;
      eig.computeDirect(cov);
      const point_type normal = eig.eigenvectors().col(0);
      if (!normal.allFinite()) continue;
      const point_type p = (transform * pr.data - c) * inv_radius;
      Row j;
      j.template head<D>() = normal;
      if constexpr (D == 2) {
        j(2) = p.x() * normal.y() - p.y() * normal.x();
      } else {
        j.template tail<3>() = p.cross(normal);
      }
      h.noalias() += j * j.transpose();
      ++rows;
    }
    if (rows < static_cast<std::size_t>(dof)) return;
    h /= static_cast<Scalar>(rows);
    Eigen::SelfAdjointEigenSolver<Matrix> eig(h);
    const Scalar lambda_min = std::max(Scalar(0), eig.eigenvalues()(0));
    const Scalar lambda_max = eig.eigenvalues()(dof - 1);
    result.smallest_eigenvalue = lambda_min;
    result.condition_number =
        lambda_min > Scalar(0) ? lambda_max / lambda_min : std::numeric_limits<Scalar>::infinity();
    result.weakest_direction = Row(eig.eigenvectors().col(0));
    if (lambda_min < params.degeneracy_threshold) {
      result.reason = IcpTermination::degenerate;
      result.converged = false;
    }
  }

  template <class R>
  static Scalar bound_of(const R& r, const IcpContext<D, Scalar>& ctx) {
    if constexpr (detail::HasMaxDistance<R, D, Scalar>)
      return static_cast<Scalar>(r.max_distance_sq(ctx));
    else
      return unbounded_sq<Scalar>;
  }
  template <class R>
  static bool admits(const R& r, const IcpContext<D, Scalar>& ctx, const point_type& p) {
    if constexpr (detail::HasAdmits<R, D, Scalar>)
      return r.admits(ctx, p);
    else
      return true;
  }
  template <class R>
  void reject_with(R& r, const IcpContext<D, Scalar>& ctx) {
    if constexpr (detail::HasReject<R, D, Scalar>) r.reject(ctx, pairs_);
  }
  template <class R>
  static bool is_settled(const R& r, const IcpContext<D, Scalar>& ctx) {
    if constexpr (detail::HasSettled<R, D, Scalar>)
      return r.settled(ctx);
    else
      return true;
  }
  template <class R>
  void begin_rejector(R& r, std::size_t model_size) {
    if constexpr (detail::HasBegin<R>) r.begin(model_size, data_.size());
  }

  static constexpr std::uint32_t no_cache = std::numeric_limits<std::uint32_t>::max();
  /// The last correspondence search of one data point (see match()).
  struct NeighborCache {
    std::uint32_t count = no_cache;         ///< candidates found (no_cache: not searched yet)
    Scalar others = 0;                      ///< every other model point was at least this far
    point_type query = point_type::Zero();  ///< where it was searched (model frame)
  };

  std::vector<point_type> data_;
  std::vector<std::uint32_t> data_index_;
  std::vector<NeighborCache> cache_;
  std::vector<std::uint32_t> candidates_;  ///< reuse_candidates model indices per data point
  std::vector<correspondence_type> pairs_;
  std::vector<Neighbor<Scalar>> knn_;
};

/// Point-to-point ICP with the closed-form solver of the dimension and the given rejectors.
template <int D, std::floating_point Scalar = double, class... Rejectors>
using Icp = BasicIcp<D, Scalar, PointToPointSolver<D, Scalar>, Rejectors...>;

/// The paper's configuration (paper 002 §6.3): decaying distance threshold + unique model points.
template <int D, std::floating_point Scalar = double>
using PaperIcp = Icp<D, Scalar, DecayingDistanceRejector<Scalar>, UniqueModelPointRejector>;

}  // namespace rangenav
