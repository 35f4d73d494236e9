#pragma once
// Iterative Closest Point (Besl & McKay 1992; paper 000 §3.1, paper 002 §6.3), one code path for
// SE(2) and SE(3). The stages of every iteration (libpointmatcher's taxonomy):
//   correspondence search  nearest model point of every data point under the current transform,
//                          bounded by the tightest `max_distance_sq` any rejector exposes and
//                          skipping data points a rejector does not `admit` (frustum culling);
//   rejection              each rejector of the compile-time list, in order;
//   solver                 the TransformSolver policy (transform_solver.hpp): closed-form
//                          point-to-point, point-to-plane or Generalized-ICP, with an optional
//                          robust kernel and an optional Gaussian prior on the transform;
//   convergence check      change of the transform below the epsilons and every rejector settled;
//                          a limit cycle ends the loop early with the budget's result
//                          (IcpParams::skip_cycles).
// Policies are public typed members with defaults (as in small_gicp's Registration):
//   Icp<2, double, DecayingDistanceRejector<double>, UniqueModelPointRejector> icp;
//   icp.params.max_iterations = 30;
//   icp.rejector<DecayingDistanceRejector<double>>().final_distance = 0.05;
//   const auto result = icp.align(KdTree<2, double>(model_scan), data_scan, initial_guess);
// The result says why it stopped, carries the information matrix of the solver's objective at the
// solution (its inverse estimates the covariance of the transform, in the tangent space of
// transform_solver.hpp) and a degeneracy signal: the smallest eigenvalue of the point-to-plane
// normal equations at the solution, so a featureless corridor is reported.
//
// Threads: IcpParams::num_threads (default 1) runs the correspondence search, the solver's
// reduction and the degeneracy check on that many threads (OpenMP); the reductions are blocked
// independently of the thread count, so 1 and N threads give the same transform bit for bit.
// Rejectors' const members (max_distance_sq, admits) and the search's queries are then called
// from several threads at once.
//
// An Icp object owns scratch buffers reused across calls: align() allocates nothing once they
// have grown. One object per thread.

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
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
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/parallel.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/pca.hpp"
#include "rangenav/registration/correspondence.hpp"
#include "rangenav/registration/gauss_newton.hpp"
#include "rangenav/registration/point_to_plane_solver.hpp"
#include "rangenav/registration/point_to_point_solver.hpp"
#include "rangenav/registration/rejectors.hpp"
#include "rangenav/registration/transform_solver.hpp"
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

/// The reason's name as spelled in the enum.
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
  int max_iterations = 50;  ///< iterations at most (each with a correspondence search)
  /// m: converged when the update moves the data frame's origin less than this ... (the
  /// data's centroid instead when the origin lies farther from the data's bounding box than
  /// the box's diagonal, as for a cloud in UTM coordinates: see detail::convergence_probe)
  Scalar translation_epsilon = Scalar(1e-4);
  Scalar rotation_epsilon = Scalar(1e-4);  ///< rad: ... and turns less than this
  std::size_t min_pairs = 0;               ///< at least the solver's minimum; 0 = that minimum
  /// Evaluate the normal equations at the solution (costs one k-NN query per pair, once).
  bool check_degeneracy = true;
  /// A smallest normalised eigenvalue below this reports IcpTermination::degenerate. The
  /// eigenvalues are per pair and unit-free (rotations scaled by the data's RMS lever arm): about
  /// 1/D for a well-constrained scene, ~0 along a corridor.
  Scalar degeneracy_threshold = Scalar(0.01);
  /// Neighbours for the model normals of the degeneracy check; 0 = 5 in 2D, 10 in 3D. Unused
  /// where the solver gives the normals (model normals, or model covariances as in GICP).
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
  /// Stop iterating once the estimate has entered a limit cycle: the pairs flip between a few
  /// sets and the transform between as many states, too far apart for the epsilons (tenths of
  /// a millimetre on a laser log). Once every rejector has settled, an iteration's outcome is a
  /// function of the transform alone (the solver is const, the pairs are those of a search),
  /// so a transform equal bit for bit to one of the last 8 repeats the same states to the end
  /// of the budget: ICP jumps to the state the budget would end on and runs the last iteration
  /// only. The result is that of iterating to max_iterations (reason max_iterations,
  /// IcpResult::cycle_period > 0); false iterates (the reference).
  bool skip_cycles = true;
  /// Threads for the correspondence search and the reductions (see the file comment).
  int num_threads = 1;
  /// Evaluate the information matrix of the solver's objective at the solution (one more pass
  /// of the solver's linearisation over the final pairs).
  bool compute_information = true;
  /// Directions the information matrix constrains less than this fraction of its strongest
  /// (rotations scaled by the data's RMS lever arm) are reported with zero information: the
  /// solvers treat them as unobserved too (transform_solver.hpp, default_degeneracy_ratio).
  Scalar degeneracy_ratio = static_cast<Scalar>(default_degeneracy_ratio);

  /// Throws invalid_argument for a value out of range.
  void validate() const {
    constexpr std::string_view where = "IcpParams";
    if (max_iterations < 1)
      detail::throw_invalid_argument(where, "max_iterations", max_iterations, "must be >= 1");
    detail::require_non_negative(where, "translation_epsilon", translation_epsilon);
    detail::require_non_negative(where, "rotation_epsilon", rotation_epsilon);
    detail::require_non_negative(where, "degeneracy_threshold", degeneracy_threshold);
    if (!(degeneracy_ratio >= Scalar(0) && degeneracy_ratio < Scalar(1)))
      detail::throw_invalid_argument(where, "degeneracy_ratio", degeneracy_ratio,
                                     "must be in [0, 1)");
    if (reuse_neighbors && reuse_candidates < 2)
      detail::throw_invalid_argument(where, "reuse_candidates", reuse_candidates, "must be >= 2");
    detail::require_threads(where, num_threads);
  }
};

/// The outcome of one alignment. Every number is finite.
template <int D, class Scalar = double>
struct IcpResult {
  static constexpr int dof = pose_dof<D>;  ///< degrees of freedom of the transform

  Transform<D, Scalar> transform = Transform<D, Scalar>::Identity();  ///< data -> model frame
  bool converged = false;                                  ///< reason == IcpTermination::converged
  IcpTermination reason = IcpTermination::max_iterations;  ///< why it stopped
  /// Iterations run (each with a correspondence search); after a limit cycle (cycle_period >
  /// 0), the budget's, as if they had run.
  int iterations = 0;
  /// Of them, those on the IcpParams::coarse_points subset of the data (the first ones).
  int coarse_iterations = 0;
  /// The period of the limit cycle the estimate entered (IcpParams::skip_cycles), 0 when none:
  /// the transform is the state of that cycle the iteration budget ends on.
  int cycle_period = 0;
  std::size_t matched_count = 0;  ///< data points the last search paired (before rejectors)
  std::size_t inlier_count = 0;   ///< pairs kept by the rejectors in the last iteration
  std::size_t data_count = 0;     ///< finite data points
  /// Correspondence searches run on the model (at most iterations x data_count; fewer when
  /// IcpParams::reuse_neighbors or BasicIcp::model_neighbors proved a data point's nearest model
  /// point without one).
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
  /// The information matrix of the scan match at the solution (IcpParams::compute_information):
  /// the Hessian of the solver's objective over the final pairs divided by the residual
  /// variance, in the tangent space of transform_solver.hpp (T_true = transform [+] d, d =
  /// (translation, rotation) in the data frame: g2o's edge convention). Its inverse estimates
  /// the covariance of the transform from the noise of the points (Censi 2007: not the errors
  /// of wrong pairs nor of a wrong local minimum). A pose prior given to align() is not
  /// included, so a pose graph may hold both as separate edges. Along a direction the geometry
  /// leaves free (a corridor's axis) it is ~0.
  std::optional<PoseMatrix<D, Scalar>> information;
  /// The residual variance that scaled it (m^2 per scalar residual).
  std::optional<Scalar> residual_variance;
};

namespace detail {

/// The data-frame point whose move ICP's translation test measures, when it is not the frame's
/// origin. The origin is a scan's sensor, and measuring there is what small_gicp does and what
/// translation_epsilon means for data around a sensor. Data farther from the origin than their
/// own extent (a cloud in UTM or other world coordinates) would turn every tiny rotation of an
/// update into a long move there (1e-9 rad at 5e6 m: 5 mm), so the test would wait for
/// rotations far below anything the data resolve: for those the data's centroid, which makes
/// the number of iterations independent of where the cloud lies. "Farther" = the origin's
/// distance to the data's bounding box exceeds the box's diagonal.
template <int D, class Scalar>
[[nodiscard]] std::optional<Point<D, Scalar>> convergence_probe(
    std::span<const Point<D, Scalar>> data) {
  if (data.empty()) return std::nullopt;
  Eigen::AlignedBox<Scalar, D> box;
  Point<D, Scalar> sum = Point<D, Scalar>::Zero();
  for (const Point<D, Scalar>& p : data) {
    box.extend(p);
    sum += p;
  }
  if (box.exteriorDistance(Point<D, Scalar>::Zero()) <= box.diagonal().norm()) return std::nullopt;
  return (sum / static_cast<Scalar>(data.size())).eval();
}

/// The normal of a point's covariance: the unit eigenvector of its smallest eigenvalue; zero when
/// `index` is out of range or the covariance has no direction of least spread (a multiple of the
/// identity, the shape estimate of a point without enough neighbours).
template <int D, class Scalar>
[[nodiscard]] Point<D, Scalar> covariance_normal(
    std::span<const Eigen::Matrix<Scalar, D, D>> covariances, std::size_t index) {
  if (index >= covariances.size()) return Point<D, Scalar>::Zero();
  const PcaFit<D, Scalar> fit =
      pca_of_covariance<D, Scalar>(Point<D, Scalar>::Zero(), covariances[index], 0);
  const Scalar tolerance = std::sqrt(std::numeric_limits<Scalar>::epsilon());
  if (!(fit.eigenvalues(0) < fit.eigenvalues(D - 1) * (Scalar(1) - tolerance)))
    return Point<D, Scalar>::Zero();
  const Point<D, Scalar> n = fit.normal();
  return n.allFinite() ? n : Point<D, Scalar>::Zero();
}

}  // namespace detail

/// ICP with a solver policy and a compile-time list of rejectors (see the file comment).
template <int D, std::floating_point Scalar, class Solver, class... Rejectors>
class BasicIcp {
  static_assert(D == 2 || D == 3, "Icp: dimension must be 2 or 3");
  static_assert(TransformSolver<Solver, D, Scalar>, "Icp: Solver must model TransformSolver");
  static_assert((CorrespondenceRejector<Rejectors, D, Scalar> && ...),
                "Icp: every rejector must model CorrespondenceRejector");

 public:
  static constexpr int dimension = D;                     ///< 2 or 3
  using scalar_type = Scalar;                             ///< float or double
  using point_type = Point<D, Scalar>;                    ///< a point of either cloud
  using transform_type = Transform<D, Scalar>;            ///< data -> model frame
  using result_type = IcpResult<D, Scalar>;               ///< what align() returns
  using correspondence_type = Correspondence<D, Scalar>;  ///< a data-model pair
  using solver_type = Solver;                             ///< the TransformSolver policy

  IcpParams<Scalar> params{};            ///< iterations, convergence, threads, degeneracy check
  Solver solver{};                       ///< public typed policy: configure it directly
  std::tuple<Rejectors...> rejectors{};  ///< applied in order every iteration
  /// The neighbour lists of the model's points (neighbor_lists() of the model given to align()),
  /// when the caller has them (the model's normals or covariances came from them): a data point's
  /// nearest model point is then first looked for among the neighbours of its last one, which
  /// proves it without a search in most iterations after the first (see match()). Must outlive
  /// align(); null = search.
  const NeighborLists<Scalar>* model_neighbors = nullptr;

  /// Default parameters, solver and rejectors.
  BasicIcp() = default;
  /// These parameters and rejectors, a default solver.
  explicit BasicIcp(const IcpParams<Scalar>& p, Rejectors... r)
      : params(p), rejectors(std::move(r)...) {}

  /// The rejector of type R in the list.
  template <class R>
  [[nodiscard]] R& rejector() {
    return std::get<R>(rejectors);
  }
  /// The rejector of type R in the list (const).
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
    return align_impl(model, data, initial_guess, nullptr);
  }

  /// As above, with a Gaussian prior on the transform that the solver adds to its normal
  /// equations every iteration (transform_solver.hpp): where the geometry leaves a direction
  /// free (a corridor's axis), the result follows the prior instead of sliding. Throws
  /// invalid_argument for an invalid prior as well.
  template <NearestNeighborSearch Model, PointCloudOf<D> Data>
  requires(Model::dimension == D && std::same_as<typename Model::scalar_type, Scalar>) result_type
      align(const Model& model, const Data& data, const transform_type& initial_guess,
            const PosePrior<D, Scalar>& prior) {
    prior.validate("Icp::align");
    return align_impl(model, data, initial_guess, &prior);
  }

  /// The pairs kept in the last iteration of the last alignment.
  [[nodiscard]] std::span<const correspondence_type> correspondences() const { return pairs_; }

 private:
  template <class Model, class Data>
  result_type align_impl(const Model& model, const Data& data, const transform_type& initial_guess,
                         const PosePrior<D, Scalar>* prior) {
    constexpr std::string_view where = "Icp::align";
    params.validate();
    std::apply([](auto&... r) { (validate_rejector(r), ...); }, rejectors);
    if (model.size() == 0) detail::throw_invalid(where, "argument 'model' is empty (0 points)");
    if (model_neighbors != nullptr && model_neighbors->size() != model.size())
      detail::throw_invalid_argument(where, "model_neighbors->size()", model_neighbors->size(),
                                     "must equal the model's size");
    if (traits::size(data) == 0)
      detail::throw_invalid(where, "argument 'data' is empty (0 points)");
    if (!initial_guess.matrix().allFinite())
      detail::throw_invalid(where, "argument 'initial_guess' is not finite");
    if (!is_rigid(initial_guess, rigid_tolerance<Scalar>))
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
    return run(model, initial_guess, prior);
  }

  template <class R>
  static void validate_rejector(const R& r) {
    if constexpr (requires { r.validate(); }) r.validate();
  }

  template <class Model>
  result_type run(const Model& model, transform_type transform, const PosePrior<D, Scalar>* prior) {
    result_type result;
    result.data_count = data_.size();
    const std::size_t min_pairs = std::max<std::size_t>(params.min_pairs, Solver::min_pairs);
    IcpContext<D, Scalar> ctx{0, transform, model.size(), data_.size()};
    std::apply([&](auto&... r) { (begin_rejector(r, model.size()), ...); }, rejectors);
    pairs_.reserve(data_.size());
    if (model_neighbors != nullptr) last_model_.assign(data_.size(), no_cache);
    const std::size_t stride = params.coarse_points > 0 ? data_.size() / params.coarse_points : 1;
    bool coarse = stride > 1;
    // The transforms x_k (x_k before iteration k) since the first full iteration with every
    // rejector settled, x_k in recent[k % size]: the states a limit cycle repeats.
    std::array<transform_type, max_cycle_period + 1> recent;
    int recorded_from = -1;  // the first k recorded; -1 = none
    const std::optional<point_type> probe = detail::convergence_probe<D, Scalar>(data_);

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
      const std::optional<transform_type> next =
          solver.solve(std::span<const correspondence_type>(pairs_),
                       SolveContext<D, Scalar>{transform, prior, params.num_threads});
      if (!next) {
        result.reason = IcpTermination::degenerate;
        break;
      }
      const transform_type previous = transform;
      const transform_type delta = transform.inverse(Eigen::Isometry) * *next;
      transform = *next;
      // The update moves a data-frame point x by |δ x - x| (x_{k+1} x - x_k x = R_k (δ x - x)).
      const point_type moved = probe ? (delta * *probe - *probe).eval() : delta.translation();
      const bool small = moved.norm() <= params.translation_epsilon &&
                         rotation_angle(delta) <= params.rotation_epsilon;
      bool settled = true;
      std::apply([&](const auto&... r) { ((settled = settled && is_settled(r, ctx)), ...); },
                 rejectors);
      if (small && settled && coarse_now) {
        coarse = false;  // the subset converged: refine on all points
        continue;
      }
      if (small && !settled && ctx.converged_unsettled < 0) ctx.converged_unsettled = it;
      if (small && settled) {
        result.reason = IcpTermination::converged;
        result.converged = true;
        break;
      }
      if (params.skip_cycles && settled && !coarse_now) {
        constexpr int size = max_cycle_period + 1;
        if (recorded_from < 0) {
          recorded_from = it;
          recent[static_cast<std::size_t>(it % size)] = previous;
        }
        const int k = it + 1;  // transform is x_k
        const int last = params.max_iterations - 1;
        int period = 0;
        for (int p = 1; p <= max_cycle_period && k - p >= recorded_from && period == 0; ++p)
          if (recent[static_cast<std::size_t>((k - p) % size)].matrix() == transform.matrix())
            period = p;
        recent[static_cast<std::size_t>(k % size)] = transform;
        if (period > 0 && k < last) {
          // x_last = x_j with j = k - period + ((last - (k - period)) mod period): run iteration
          // `last` from it, as the budget would have.
          const int j = k - period + (last - k + period) % period;
          transform = recent[static_cast<std::size_t>(j % size)];
          result.cycle_period = period;
          it = last - 1;
        }
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
    const bool solved = result.reason != IcpTermination::too_few_pairs &&
                        result.reason != IcpTermination::degenerate;
    if (params.compute_information && solved) evaluate_information(transform, result);
    if (params.check_degeneracy && solved) evaluate_degeneracy(model, transform, result);
    return result;
  }

  // The pairs of one iteration, of every `stride`-th data point, in data order; returns the
  // number of model searches run. Blocks of data points run on up to num_threads threads, each
  // writing the pair of data point j into slot j; the pairs are then gathered in order.
  template <class Model>
  std::size_t match(const Model& model, const IcpContext<D, Scalar>& ctx, std::size_t stride) {
    Scalar bound_sq = unbounded_sq<Scalar>;
    std::apply([&](const auto&... r) { ((bound_sq = std::min(bound_sq, bound_of(r, ctx))), ...); },
               rejectors);
    const detail::AffineApply<D, Scalar> t(ctx.transform);
    const bool reuse = params.reuse_neighbors && std::isfinite(bound_sq);
    const std::size_t candidates = params.reuse_candidates;
    if (reuse && ctx.iteration == 0) {
      cache_.assign(data_.size(), {});
      candidates_.resize(data_.size() * candidates);
    }
    const Scalar bound = std::sqrt(bound_sq);
    const std::size_t count = (data_.size() + stride - 1) / stride;
    if (slots_.size() < count) slots_.resize(count);
    const std::size_t blocks = detail::block_count(count, match_block);
    searches_.assign(blocks, 0);
    block_pairs_.assign(blocks, 0);
    knn_.resize(static_cast<std::size_t>(params.num_threads));
    // The model point nearest to p among `indices`, by the kd-tree's metric (squared distance
    // summed per axis in order, so a proven pair carries the distance a search reports).
    const auto closest_of = [&](const point_type& p, std::span<const std::uint32_t> indices) {
      Neighbor<Scalar> best{0, std::numeric_limits<Scalar>::infinity()};
      for (const std::uint32_t index : indices) {
        const point_type& m = model.point(index);
        Scalar d_sq = 0;
        for (int d = 0; d < D; ++d)
          d_sq += (p[d] - m[d]) * (p[d] - m[d]);
        if (d_sq < best.distance_sq) best = {index, d_sq};
      }
      return best;
    };
    // Data point j pairs with model point nb: the pair goes to the next free slot of its block
    // (a block's pairs are packed at its start, in data order).
    const auto pair_with = [&](std::size_t& slot, std::size_t j, const Neighbor<Scalar>& nb) {
      slots_[slot++] = {data_[j], model.point(nb.index), nb.distance_sq, data_index_[j], nb.index};
      if (model_neighbors != nullptr) last_model_[j] = nb.index;
    };
    // Rounding of the distances compared in a proof below.
    const auto margin = [](const point_type& p, Scalar reach) {
      return Scalar(64) * std::numeric_limits<Scalar>::epsilon() *
             (Scalar(1) + p.template lpNorm<Eigen::Infinity>() + reach);
    };
    detail::for_each_block(
        count, match_block, params.num_threads,
        [&](std::size_t b, std::size_t begin, std::size_t end, int thread) {
          std::vector<Neighbor<Scalar>>& knn = knn_[static_cast<std::size_t>(thread)];
          std::size_t searches = 0;
          std::size_t slot = begin;
          for (std::size_t k = begin; k < end; ++k) {
            const std::size_t j = k * stride;
            const point_type p = t(data_[j]);
            bool admitted = true;
            std::apply([&](const auto&... r) { ((admitted = admitted && admits(r, ctx, p)), ...); },
                       rejectors);
            if (!admitted) continue;
            // The nearest model point among the neighbours of a model point m (its list holds m
            // itself): every other model point is at least reach(m) from m, so at least
            // reach(m) - |p - m| from p (triangle inequality); a neighbour nearer than that is the
            // nearest model point, inside the bound or not. m is the last nearest model point,
            // then, while that proves nothing, the nearest of its neighbours (a walk towards p).
            if (model_neighbors != nullptr && last_model_[j] != no_cache) {
              std::uint32_t m = last_model_[j];
              bool proven = false;
              for (int hop = 0; hop < max_hops && !proven; ++hop) {
                const Neighbor<Scalar> best = closest_of(p, model_neighbors->of(m));
                const Scalar others = model_neighbors->reach[m];
                const Scalar lever = (p - model.point(m)).norm();
                proven = std::isinf(others) ||
                         std::sqrt(best.distance_sq) < others - lever - margin(p, others);
                if (proven && best.distance_sq < bound_sq) pair_with(slot, j, best);
                if (best.index == m) break;  // no nearer neighbour to walk to
                m = best.index;
                last_model_[j] = m;
              }
              if (proven) continue;
            }
            if (!reuse) {
              ++searches;
              if (const auto nb = model.nearest(p, bound_sq)) pair_with(slot, j, *nb);
              continue;
            }
            // Reuse of the last search of this data point, made at `query`, which found the
            // candidates (its k nearest model points within the bound) and proved every other
            // model point at least `others` away. The point has since moved by delta, so every
            // other model point is now at least others - delta away (triangle inequality): if the
            // closest candidate is nearer than that, it is the nearest model point; if there was
            // none and others - delta reaches the bound, there is none.
            NeighborCache& c = cache_[j];
            if (c.count != no_cache) {
              const Scalar reach = c.others - (p - c.query).norm() - margin(p, c.others);
              if (c.count == 0) {
                if (reach >= bound) continue;
              } else {
                const Neighbor<Scalar> best = closest_of(
                    p,
                    std::span<const std::uint32_t>(candidates_).subspan(j * candidates, c.count));
                if (std::sqrt(best.distance_sq) < reach) {
                  if (best.distance_sq < bound_sq) pair_with(slot, j, best);
                  continue;
                }
              }
            }
            // The k nearest within the bound: the first pairs, the k-th bounds the others.
            ++searches;
            model.knn(p, candidates, knn, bound_sq);
            c.query = p;
            c.count = static_cast<std::uint32_t>(knn.size());
            c.others = knn.size() == candidates ? std::sqrt(knn.back().distance_sq) : bound;
            for (std::size_t q = 0; q < knn.size(); ++q)
              candidates_[j * candidates + q] = knn[q].index;
            if (!knn.empty()) pair_with(slot, j, knn[0]);
          }
          searches_[b] = searches;
          block_pairs_[b] = slot - begin;
        });
    // The blocks' pairs, in block order: each block copies its own to its offset.
    std::size_t total = 0;
    for (std::size_t& n : block_pairs_)
      total += std::exchange(n, total);
    pairs_.resize(total);
    detail::for_each_block(
        count, match_block, params.num_threads,
        [&](std::size_t b, std::size_t begin, std::size_t, int) {
          const std::size_t first = block_pairs_[b];
          const std::size_t last = b + 1 < blocks ? block_pairs_[b + 1] : total;
          std::copy(slots_.begin() + static_cast<std::ptrdiff_t>(begin),
                    slots_.begin() + static_cast<std::ptrdiff_t>(begin + (last - first)),
                    pairs_.begin() + static_cast<std::ptrdiff_t>(first));
        });
    std::size_t searches = 0;
    for (const std::size_t s : searches_)
      searches += s;
    return searches;
  }

  /// The information of the match (IcpResult::information): the solver's normal equations at
  /// the solution over the final pairs, their observed part (degeneracy_ratio), divided by the
  /// residual variance.
  void evaluate_information(const transform_type& transform, result_type& result) {
    const NormalEquations<D, Scalar> eq = solver.linearize(
        std::span<const correspondence_type>(pairs_), transform, params.num_threads);
    const Scalar variance = eq.residual_variance();
    result.residual_variance = variance;
    PoseMatrix<D, Scalar> information = PoseMatrix<D, Scalar>::Zero();
    if (variance > Scalar(0))
      if (const auto observed = detail::observed_part<D, Scalar>(
              eq.hessian, std::span<const correspondence_type>(pairs_), params.degeneracy_ratio))
        information = *observed / variance;
    result.information = information;
  }

  /// The point-to-plane normal equations at the solution, with the model normals of a
  /// ModelNormalSolver, the normals of a CovarianceSolver's model covariances, or else the PCA
  /// normals of k model neighbours of each paired model point,
  /// in the centred coordinates of the solvers' step (rotations about the data centroid scaled by
  /// the points' RMS lever arm about each axis: gauss_newton.hpp, PointMoments), divided by the
  /// pair count: eigenvalues in (metres of point motion)^-2 per pair, unit-free.
  template <class Model>
  void evaluate_degeneracy(const Model& model, const transform_type& transform,
                           result_type& result) {
    constexpr int dof = result_type::dof;
    if (pairs_.size() < static_cast<std::size_t>(dof)) return;
    std::span<const point_type> given;
    if constexpr (ModelNormalSolver<Solver, D, Scalar>) given = solver.model_normals;
    const std::size_t k =
        params.normal_neighbors != 0 ? params.normal_neighbors : (D == 2 ? 5u : 10u);
    bool from_covariances = false;
    if constexpr (CovarianceSolver<Solver, D, Scalar>) {
      // The model covariances already hold each model point's shape (GICP's are the regularised
      // PCA covariances of its nearest neighbours): its normal is their direction of least
      // spread, found without another neighbour search.
      if (given.empty() && !solver.model_covariances.empty()) {
        from_covariances = true;
        normals_.resize(pairs_.size());
        detail::for_each_block(pairs_.size(), match_block, params.num_threads,
                               [&](std::size_t, std::size_t begin, std::size_t end, int) {
                                 for (std::size_t i = begin; i < end; ++i)
                                   normals_[i] = detail::covariance_normal<D, Scalar>(
                                       solver.model_covariances, pairs_[i].model_index);
                               });
      }
    }
    if (given.empty() && !from_covariances) {
      normals_.resize(pairs_.size());
      knn_.resize(static_cast<std::size_t>(params.num_threads));
      detail::for_each_block(
          pairs_.size(), match_block, params.num_threads,
          [&](std::size_t, std::size_t begin, std::size_t end, int thread) {
            auto& knn = knn_[static_cast<std::size_t>(thread)];
            for (std::size_t i = begin; i < end; ++i) {
              normals_[i] = point_type::Zero();
              if (model.knn(pairs_[i].model, k, knn) < static_cast<std::size_t>(D)) continue;
              const PcaFit<D, Scalar> fit = fit_pca<D, Scalar>(
                  knn.size(),
                  [&](std::size_t m) -> decltype(auto) { return model.point(knn[m].index); });
              const point_type n = fit.normal();
              if (n.allFinite()) normals_[i] = n;
            }
          });
    }
    const detail::AffineApply<D, Scalar> apply(transform);
    const Eigen::Matrix<Scalar, D, D> rt = transform.linear().transpose();
    const RobustKernel<Scalar> plain{};
    const correspondence_type* first = pairs_.data();
    const detail::Linearization<D, Scalar> lin = detail::linearize_pairs<D, Scalar>(
        std::span<const correspondence_type>(pairs_), params.num_threads, degeneracy_scratch_,
        [&](const correspondence_type& pr, NormalEquations<D, Scalar>& eq) {
          const point_type n = given.empty() ? normals_[static_cast<std::size_t>(&pr - first)]
                               : pr.model_index < given.size() ? given[pr.model_index]
                                                               : point_type::Zero();
          if (n.isZero(0)) return false;
          detail::add_point_to_plane<D, Scalar>(eq, plain, n, pr, apply, rt);
          return true;
        });
    const std::size_t rows = lin.equations.pairs;
    const auto scale = lin.points.rotation_scale();
    if (rows < static_cast<std::size_t>(dof) || !scale) return;
    using Matrix = PoseMatrix<D, Scalar>;
    using Row = PoseTangent<D, Scalar>;
    const Matrix m = detail::centred_coordinates<D, Scalar>(lin.points.centroid(), *scale);
    const Matrix h = m.transpose() * lin.equations.hessian * m / static_cast<Scalar>(rows);
    const Eigen::SelfAdjointEigenSolver<Matrix> eig(h);
    const Scalar lambda_min = std::max(Scalar(0), eig.eigenvalues()(0));
    const Scalar lambda_max = eig.eigenvalues()(dof - 1);
    result.smallest_eigenvalue = lambda_min;
    result.condition_number =
        lambda_min > Scalar(0) ? lambda_max / lambda_min : std::numeric_limits<Scalar>::infinity();
    // In the model frame: the translation (and in 3D the rotation axis) turned by R.
    Row weakest = eig.eigenvectors().col(0);
    weakest.template head<D>() = transform.linear() * weakest.template head<D>();
    if constexpr (D == 3)
      weakest.template tail<3>() = transform.linear() * weakest.template tail<3>();
    result.weakest_direction = weakest;
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

  /// Steps of the walk through model_neighbors before match() falls back to a search: each costs
  /// one list's distances (k), a search about ten times as much.
  static constexpr int max_hops = 4;

  /// Longest limit cycle IcpParams::skip_cycles looks for (the map registrations of a laser log
  /// show periods 2 to 8, most of them 2); a longer one runs out the budget as before.
  static constexpr int max_cycle_period = 8;

  /// Data points per block of the parallel search (a constant: see the file comment).
  static constexpr std::size_t match_block = 128;

  std::vector<point_type> data_;
  std::vector<std::uint32_t> data_index_;
  std::vector<NeighborCache> cache_;
  std::vector<std::uint32_t> candidates_;  ///< reuse_candidates model indices per data point
  std::vector<std::uint32_t> last_model_;  ///< model_neighbors: each data point's last nearest
  std::vector<correspondence_type> pairs_;
  std::vector<correspondence_type> slots_;  ///< the pair of each searched data point
  std::vector<std::size_t> block_pairs_;    ///< pairs per block, then each block's first pair
  std::vector<std::size_t> searches_;       ///< searches per block
  std::vector<std::vector<Neighbor<Scalar>>> knn_;  ///< one k-NN buffer per thread
  std::vector<point_type> normals_;                 ///< degeneracy check: normal per pair
  std::vector<detail::Linearization<D, Scalar>> degeneracy_scratch_;
};

/// Point-to-point ICP with the closed-form solver of the dimension and the given rejectors.
template <int D, std::floating_point Scalar = double, class... Rejectors>
using Icp = BasicIcp<D, Scalar, PointToPointSolver<D, Scalar>, Rejectors...>;

/// The paper's configuration (paper 002 §6.3): decaying distance threshold + unique model points.
template <int D, std::floating_point Scalar = double>
using PaperIcp = Icp<D, Scalar, DecayingDistanceRejector<Scalar>, UniqueModelPointRejector>;

}  // namespace rangenav
