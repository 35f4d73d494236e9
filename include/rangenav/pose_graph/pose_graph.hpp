#pragma once
// PoseGraph: maximum-likelihood poses from relative-pose measurements, over SE(2) and SE(3) with
// one code path (the dimension D is a template parameter).
//
// Nodes are poses X_i (Transform<D>: x forward, y left, z up; metres, radians). An edge (a, b)
// measures the pose Z of node b in node a's frame with an information matrix Ω (the inverse
// covariance) in g2o's error coordinates: 2D (x, y, θ), 3D (x, y, z, qx, qy, qz), where q is the
// vector part of the error's unit quaternion, ≈ half the rotation vector. So an information over
// (x, y, z, rotation vector) is not an edge information in 3D: information_from_covariance()
// converts a covariance over (translation, rotation vector) into one (relative_pose_error.hpp has
// the error definition). The optimiser minimises
//
//   F(X) = Σ_edges ρ_e(e_eᵀ Ω_e e_e),   e = e(Z⁻¹·Xa⁻¹·Xb)   (g2o's error, relative_pose_error.hpp)
//
// by Levenberg-Marquardt (Marquardt's diagonal scaling, Nielsen's damping update: Madsen, Nielsen,
// Tingleff, "Methods for Non-Linear Least Squares Problems", 2004, §3.2, Eq. 3.14-3.16) over
// the normal equations Σ w JᵀΩJ δ = −Σ w JᵀΩe with analytic Jacobians and the IRLS weight
// w = ρ'(χ²) (core/robust_kernel.hpp), solved by a sparse LDLT factorisation in a fill-reducing
// (AMD) order whose symbolic analysis is reused while the graph does not change.
//
// Each edge has a loss ρ: plain least squares, a robust kernel (Huber, Cauchy, Geman-McClure),
// or dynamic covariance scaling (DCS, Agarwal et al., "Robust Map Optimization using Dynamic
// Covariance Scaling", ICRA 2013), the defence against false loop closures: an edge whose χ²
// exceeds Φ has its information scaled by s² with s = 2Φ/(Φ + χ²) (Eq. 11 there).
//
// Fixed nodes keep their poses. The problem's gauge (a global rigid motion leaves F unchanged)
// is fixed by holding, in every connected part of the graph that has no fixed node, its
// lowest-numbered node where it is. Poses are updated on the right, X ← X·[[Exp(φ), ρ], [0, 1]].
//
// Incremental use: add nodes and edges, then call optimize() again; it starts from the current
// poses (warm). Starting values far from the optimum (odometry that drifted around a large loop)
// can trap any local method in a wrong minimum: initialize() first computes the rotations from
// the edges alone by the chordal relaxation and then the translations given the rotations, two
// linear least-squares problems with no starting values (see initialize()).
//
// Not thread-safe: one graph, one thread at a time. No I/O, no global state.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <numeric>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/lie.hpp"
#include "rangenav/core/robust_kernel.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/pose_graph/detail/block_system.hpp"
#include "rangenav/pose_graph/relative_pose_error.hpp"

namespace rangenav {

/// Dynamic covariance scaling (Agarwal et al., ICRA 2013), a loss that rejects false loop
/// closures: an edge whose χ² = eᵀΩe exceeds Φ has its information scaled by s² with
/// s = 2Φ/(Φ + χ²) (their Eq. 11). As a robust kernel (the IRLS weight ρ' = s²):
///   ρ(χ²) = χ²                         (χ² ≤ Φ)
///         = Φ·(3χ² − Φ)/(χ² + Φ)       (χ² > Φ, bounded by 3Φ)
/// Agarwal et al. find Φ = 1 right over a wide range of data sets, χ² being measured in units of
/// the edge's own covariance.
template <std::floating_point Scalar = double>
struct DynamicCovarianceScaling {
  Scalar phi = Scalar(1);  ///< Φ, the χ² above which the edge is scaled down.

  /// Throws invalid_argument unless Φ is finite and > 0.
  void validate(std::string_view where = "DynamicCovarianceScaling") const {
    detail::require_positive(where, "phi", phi);
  }
  /// ρ(χ²) for χ² ≥ 0.
  [[nodiscard]] Scalar rho(Scalar s) const {
    return s <= phi ? s : phi * (Scalar(3) * s - phi) / (s + phi);
  }
  /// The IRLS weight ρ'(χ²) = min(1, 2Φ/(Φ + χ²))².
  [[nodiscard]] Scalar weight(Scalar s) const {
    if (s <= phi) return Scalar(1);
    const Scalar scale = Scalar(2) * phi / (phi + s);
    return scale * scale;
  }
};

/// The loss of an edge: a robust kernel (type none = plain least squares) or DCS.
template <std::floating_point Scalar = double>
using PoseGraphLoss = std::variant<RobustKernel<Scalar>, DynamicCovarianceScaling<Scalar>>;

/// Why PoseGraph::optimize() stopped.
enum class PoseGraphTermination {
  converged_cost,       ///< the relative decrease of the cost fell below function_tolerance
  converged_step,       ///< the step fell below step_tolerance
  max_iterations,       ///< max_iterations steps were tried
  no_progress,          ///< no step decreased the cost, however strongly damped
  nothing_to_optimize,  ///< no edge, or no node free to move
  numerical_failure     ///< a non-finite cost (non-finite poses or measurements)
};

/// A short name of a termination reason ("converged_cost", ...).
[[nodiscard]] constexpr std::string_view to_string(PoseGraphTermination t) {
  switch (t) {
    case PoseGraphTermination::converged_cost:
      return "converged_cost";
    case PoseGraphTermination::converged_step:
      return "converged_step";
    case PoseGraphTermination::max_iterations:
      return "max_iterations";
    case PoseGraphTermination::no_progress:
      return "no_progress";
    case PoseGraphTermination::nothing_to_optimize:
      return "nothing_to_optimize";
    case PoseGraphTermination::numerical_failure:
      return "numerical_failure";
  }
  return "unknown";
}

/// Settings of PoseGraph::optimize() and PoseGraph::initialize(). The defaults suit graphs of any
/// size and origin.
template <std::floating_point Scalar = double>
struct PoseGraphOptions {
  /// Maximum number of Levenberg-Marquardt steps tried (accepted or not).
  int max_iterations = 100;
  /// Stop when a step lowers the cost F by less than this fraction of F, or when the
  /// Gauss-Newton decrement −gᵀH⁻¹g (what one more step can gain, estimated with the last
  /// factorisation near the minimum) is below this fraction of F.
  Scalar function_tolerance = Scalar(1e-8);
  /// Stop when the largest entry of an accepted step is below this (metres / radians).
  Scalar step_tolerance = Scalar(1e-12);
  /// Initial damping λ, relative to the diagonal of the normal equations. Small, because pose
  /// graphs are badly conditioned (the bending modes of long loops have eigenvalues many orders
  /// below the diagonal, and Marquardt's damping λ·diag(H) smothers them unless λ is below
  /// 1/condition): from a good start (initialize(), or a warm re-optimisation) the Gauss-Newton
  /// step is then taken at once; from a poor one, rejected steps raise λ by Nielsen's rule (×2,
  /// ×4, ×8, ...), to 10⁻⁴ after six.
  Scalar initial_lambda = Scalar(1e-10);
  /// The sparse Cholesky factorisation. automatic: CHOLMOD's supernodal Cholesky where rangenav
  /// was built with it (RANGENAV_HAVE_CHOLMOD) and the graph's fill makes it pay (large 3D
  /// graphs), Eigen's SimplicialLDLT otherwise. The results agree to rounding.
  SparseBackend backend = SparseBackend::automatic;

  /// Throws invalid_argument for a setting out of range.
  void validate() const {
    constexpr std::string_view where = "PoseGraphOptions";
    if (max_iterations < 0)
      detail::throw_invalid_argument(where, "max_iterations", max_iterations, "must be >= 0");
    detail::require_non_negative(where, "function_tolerance", function_tolerance);
    detail::require_non_negative(where, "step_tolerance", step_tolerance);
    detail::require_positive(where, "initial_lambda", initial_lambda);
    if (backend == SparseBackend::cholmod && !(have_cholmod && std::is_same_v<Scalar, double>))
      detail::throw_invalid(where,
                            "backend = cholmod, but rangenav was built without CHOLMOD "
                            "(RANGENAV_HAVE_CHOLMOD) or Scalar is not double");
  }
};

/// What PoseGraph::optimize() did.
template <std::floating_point Scalar = double>
struct PoseGraphResult {
  Scalar chi2_initial{0};  ///< Σ eᵀΩe before (g2o's χ², without the losses)
  Scalar chi2_final{0};    ///< Σ eᵀΩe after
  Scalar cost_initial{0};  ///< F = Σ ρ(eᵀΩe) before (the minimised cost)
  Scalar cost_final{0};    ///< F after
  int iterations{0};       ///< steps tried
  int accepted_steps{0};   ///< steps that lowered the cost
  int factorizations{0};   ///< numeric factorisations of the normal equations
  bool cholmod{false};     ///< true when CHOLMOD factored the normal equations (see backend)
  /// Why the optimiser stopped (see PoseGraphTermination).
  PoseGraphTermination termination{PoseGraphTermination::nothing_to_optimize};

  /// True when the optimiser stopped at a minimum (cost or step tolerance reached, or nothing to
  /// optimise).
  [[nodiscard]] bool converged() const {
    return termination == PoseGraphTermination::converged_cost ||
           termination == PoseGraphTermination::converged_step ||
           termination == PoseGraphTermination::nothing_to_optimize;
  }
};

/// A pose graph over SE(D), D ∈ {2, 3} (see the file comment for the model and conventions).
template <int D, std::floating_point Scalar = double>
class PoseGraph {
  static_assert(D == 2 || D == 3, "PoseGraph: D must be 2 or 3");

 public:
  /// Degrees of freedom of a pose: 3 in 2D, 6 in 3D.
  static constexpr int dof = lie::pose_dof<D>;
  /// A node's pose: maps points from the node's frame into the world frame.
  using Pose = Transform<D, Scalar>;
  /// An edge's information matrix in g2o's error coordinates (2D: x, y, θ; 3D: x, y, z, qx, qy,
  /// qz).
  using Information = lie::PoseMatrix<D, Scalar>;
  /// An error vector in g2o's error coordinates.
  using Error = lie::PoseTangent<D, Scalar>;
  /// A node's index, as returned by add_node (0, 1, 2, ...).
  using NodeId = std::size_t;
  /// An edge's index, as returned by add_edge (0, 1, 2, ...).
  using EdgeId = std::size_t;
  /// An edge's loss.
  using Loss = PoseGraphLoss<Scalar>;
  /// The optimiser's settings (see PoseGraphOptions for their defaults).
  using Options = PoseGraphOptions<Scalar>;
  /// What optimize() returns.
  using Result = PoseGraphResult<Scalar>;

  /// A relative-pose measurement: the pose of node `to` in the frame of node `from`.
  struct Edge {
    NodeId from{0};                                    ///< node a
    NodeId to{0};                                      ///< node b
    Pose measurement{Pose::Identity()};                ///< Z, the pose of b in a's frame
    Information information{Information::Identity()};  ///< Ω, symmetric positive semidefinite
    Loss loss{};                                       ///< ρ
  };

  /// Adds a node at `pose` (finite, rigid); a fixed node never moves. Returns its index.
  NodeId add_node(const Pose& pose, bool fixed = false) {
    require_pose("add_node", "pose", pose);
    poses_.push_back(pose);
    fixed_.push_back(fixed);
    structure_changed_ = true;
    return poses_.size() - 1;
  }

  /// Adds an edge measuring the pose of node `to` in the frame of node `from`, with information
  /// Ω (symmetric positive semidefinite, in g2o's error coordinates) and a loss (default: plain
  /// least squares). Returns its index. Throws invalid_argument for unknown or equal nodes, a
  /// measurement that is not a finite rigid transform, or an information that is not finite,
  /// symmetric and positive semidefinite.
  EdgeId add_edge(NodeId from, NodeId to, const Pose& measurement, const Information& information,
                  const Loss& loss = Loss{}) {
    constexpr std::string_view where = "PoseGraph::add_edge";
    require_node(where, "from", from);
    require_node(where, "to", to);
    if (from == to) detail::throw_invalid_argument(where, "to", to, "must differ from 'from'");
    require_pose(where, "measurement", measurement);
    require_information(where, information);
    require_loss(where, loss);
    Edge edge{from, to, measurement, Scalar(0.5) * (information + information.transpose()), loss};
    edges_.push_back(std::move(edge));
    inverse_measurements_.push_back(measurement.inverse());
    structure_changed_ = true;
    return edges_.size() - 1;
  }

  /// Number of nodes.
  [[nodiscard]] std::size_t node_count() const { return poses_.size(); }
  /// Number of edges.
  [[nodiscard]] std::size_t edge_count() const { return edges_.size(); }

  /// The current pose of a node. Throws invalid_argument for an unknown node.
  [[nodiscard]] const Pose& pose(NodeId node) const {
    require_node("PoseGraph::pose", "node", node);
    return poses_[node];
  }
  /// All poses, indexed by NodeId.
  [[nodiscard]] const std::vector<Pose>& poses() const { return poses_; }
  /// Sets a node's pose (finite, rigid), e.g. a better initial guess.
  void set_pose(NodeId node, const Pose& pose) {
    require_node("PoseGraph::set_pose", "node", node);
    require_pose("PoseGraph::set_pose", "pose", pose);
    poses_[node] = pose;
  }

  /// True when the node is fixed.
  [[nodiscard]] bool is_fixed(NodeId node) const {
    require_node("PoseGraph::is_fixed", "node", node);
    return fixed_[node];
  }
  /// Fixes a node (it keeps its pose) or frees it.
  void set_fixed(NodeId node, bool fixed = true) {
    require_node("PoseGraph::set_fixed", "node", node);
    if (fixed_[node] != fixed) structure_changed_ = true;
    fixed_[node] = fixed;
  }

  /// An edge. Throws invalid_argument for an unknown edge.
  [[nodiscard]] const Edge& edge(EdgeId e) const {
    require_edge("PoseGraph::edge", e);
    return edges_[e];
  }
  /// Replaces an edge's loss.
  void set_loss(EdgeId e, const Loss& loss) {
    require_edge("PoseGraph::set_loss", e);
    require_loss("PoseGraph::set_loss", loss);
    edges_[e].loss = loss;
  }

  /// An edge's error e(Z⁻¹·Xa⁻¹·Xb) at the current poses.
  [[nodiscard]] Error edge_error(EdgeId e) const {
    require_edge("PoseGraph::edge_error", e);
    return error_of(e, poses_);
  }
  /// An edge's χ² = eᵀΩe at the current poses.
  [[nodiscard]] Scalar edge_chi2(EdgeId e) const {
    const Error r = edge_error(e);
    return r.dot(edges_[e].information * r);
  }
  /// An edge's IRLS weight ρ'(χ²) ∈ (0, 1] at the current poses: 1 for an edge its loss trusts
  /// fully; near 0 for one its robust loss has rejected (a false loop closure under DCS).
  [[nodiscard]] Scalar edge_weight(EdgeId e) const {
    const Scalar s = edge_chi2(e);
    return std::visit([s](const auto& loss) { return loss.weight(s); }, edges_[e].loss);
  }
  /// g2o's χ² of the graph: Σ eᵀΩe over all edges, without the losses.
  [[nodiscard]] Scalar chi2() const { return evaluate(poses_).chi2; }
  /// The minimised cost F = Σ ρ(eᵀΩe).
  [[nodiscard]] Scalar cost() const { return evaluate(poses_).cost; }

  /// Levenberg-Marquardt from the current poses; the poses hold the result. Throws
  /// invalid_argument for invalid options; numerical trouble is reported in the result.
  Result optimize(const Options& options = Options{}) {
    options.validate();
    prepare(options.backend);
    Result result;
    result.cholmod = system_.uses_cholmod();
    Evaluation current = evaluate(poses_);
    result.chi2_initial = result.chi2_final = current.chi2;
    result.cost_initial = result.cost_final = current.cost;
    if (free_count_ == 0 || edges_.empty()) {
      result.termination = PoseGraphTermination::nothing_to_optimize;
      return result;
    }
    if (!std::isfinite(current.cost)) {
      result.termination = PoseGraphTermination::numerical_failure;
      return result;
    }
    result.termination = PoseGraphTermination::max_iterations;
    Scalar lambda = options.initial_lambda;
    Scalar nu = Scalar(2);
    bool linearized = false;
    // True while the last factorisation is of a nearly undamped H whose quadratic model predicted
    // its step well: near the minimum it then also serves the next linearisation (below).
    bool factor_current = false;
    while (result.iterations < options.max_iterations) {
      if (current.cost == Scalar(0)) {
        result.termination = PoseGraphTermination::converged_cost;
        break;
      }
      if (!linearized) {
        linearize();
        linearized = true;
        if (factor_current) {
          // The Gauss-Newton decrement −gᵀδ with δ = −H⁻¹g from the previous factor of H, one
          // back-substitution: what one more step can still gain. Below the tolerance the
          // optimiser stops after taking that step (if it lowers the cost) instead of paying a
          // factorisation to learn that the next decrease is negligible.
          system_.solve(step_);
          if (system_.rhs_dot(step_) <= options.function_tolerance * current.cost) {
            ++result.iterations;
            apply_step(candidate_);
            const Evaluation next = evaluate(candidate_);
            if (std::isfinite(next.cost) && next.cost < current.cost) {
              poses_.swap(candidate_);
              current = next;
              ++result.accepted_steps;
            }
            result.termination = PoseGraphTermination::converged_cost;
            break;
          }
        }
      }
      ++result.iterations;
      ++result.factorizations;
      factor_current = false;
      system_.damp(lambda, Scalar(1e-6));
      if (!system_.factorize()) {
        lambda *= nu;
        nu *= Scalar(2);
        if (!(lambda < Scalar(1e32))) {
          result.termination = PoseGraphTermination::no_progress;
          break;
        }
        continue;
      }
      system_.solve(step_);
      // Model decrease −gᵀδ + λδᵀDδ of F (with g = −rhs and (H + λD)δ = −g).
      const Scalar predicted = predicted_decrease(lambda);
      apply_step(candidate_);
      const Evaluation next = evaluate(candidate_);
      const Scalar actual = current.cost - next.cost;
      const Scalar gain = predicted > Scalar(0) ? actual / predicted : Scalar(-1);
      if (std::isfinite(next.cost) && actual > Scalar(0) && gain > Scalar(0)) {
        poses_.swap(candidate_);
        ++result.accepted_steps;
        linearized = false;
        factor_current = gain > Scalar(0.75) && lambda <= Scalar(1e-6);
        const Scalar previous_cost = current.cost;
        current = next;
        const Scalar g = Scalar(2) * gain - Scalar(1);
        lambda *= std::max(Scalar(1) / Scalar(3), Scalar(1) - g * g * g);
        nu = Scalar(2);
        if (actual <= options.function_tolerance * previous_cost) {
          result.termination = PoseGraphTermination::converged_cost;
          break;
        }
        if (step_.cwiseAbs().maxCoeff() <= options.step_tolerance) {
          result.termination = PoseGraphTermination::converged_step;
          break;
        }
      } else {
        // A rejected nearly undamped step whose predicted gain is below the tolerance: at the
        // minimum, where rounding decides the sign of so small a change.
        if (std::isfinite(next.cost) && lambda <= Scalar(1e-6) &&
            predicted <= options.function_tolerance * current.cost) {
          result.termination = PoseGraphTermination::converged_cost;
          break;
        }
        // A rejected step so small that the cost cannot tell it apart: at the minimum.
        if (std::isfinite(next.cost) && step_.cwiseAbs().maxCoeff() <= options.step_tolerance) {
          result.termination = PoseGraphTermination::converged_step;
          break;
        }
        lambda *= nu;
        nu *= Scalar(2);
        if (!(lambda < Scalar(1e32))) {
          result.termination = PoseGraphTermination::no_progress;
          break;
        }
      }
    }
    result.chi2_final = current.chi2;
    result.cost_final = current.cost;
    return result;
  }

  /// Replaces the poses of the free nodes by a starting point computed from the edges alone, for
  /// starting values far from the optimum (e.g. odometry that drifted around large loops):
  ///  1. rotations by the chordal relaxation (Martinec & Pajdla, "Robust Rotation and Translation
  ///     Estimation in Multiview Reconstruction", CVPR 2007; Carlone et al., "Initialization
  ///     Techniques for 3D SLAM", ICRA 2015, Eq. 9): minimise Σ κ‖R_b − R_a·R_Z‖²_F over
  ///     unconstrained D×D matrices, a linear problem (rows decouple: one factorisation, D
  ///     right-hand sides), then project each onto SO(D); κ is the mean eigenvalue of the edge's
  ///     rotation information with the translation marginalised out;
  ///  2. translations given those rotations: Σ (t_b − t_a − R_a·t_Z)ᵀ W (…) with W the
  ///     translation information rotated into the world frame, again linear.
  /// In 2D this is the rotation-first idea of LAGO (Carlone et al., "A fast and accurate
  /// approximation for planar pose graph optimization", IJRR 2014), without its angle
  /// unwrapping, which the chordal form does not need. Edges with a robust loss are re-weighted
  /// by it (IRLS on each linear problem with that sub-problem's χ²), so a false loop closure
  /// does not bend the starting point. Fixed nodes and gauge anchors keep their poses. Returns
  /// false, leaving the poses unchanged, when a linear system is singular (a free node whose
  /// edges carry no rotation or no translation information). Of `options`, only `backend` is
  /// used.
  bool initialize(const Options& options = Options{}) {
    using Rotation = Eigen::Matrix<Scalar, D, D>;
    using Dense = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
    constexpr int rdof = lie::rotation_dof<D>;
    options.validate();
    prepare(options.backend);
    if (free_count_ == 0) return true;
    auto& system = initialization_system_;
    if (!initialization_ready_) {
      system.build(free_count_, pairs_, ordering_, options.backend);
      initialization_ready_ = true;
    }
    const std::size_t m = edges_.size();
    bool robust = false;
    for (const Edge& edge : edges_)
      robust = robust || std::visit([](const auto& loss) { return !is_plain(loss); }, edge.loss);
    const int rounds = robust ? 5 : 1;
    // Rotation information with the translation marginalised out: Ω_rr − Ω_rt·Ω_tt⁻¹·Ω_tr.
    std::vector<Eigen::Matrix<Scalar, rdof, rdof>> rotation_information(m);
    for (std::size_t e = 0; e < m; ++e) {
      const Information& o = edges_[e].information;
      const Eigen::LLT<Rotation> tt(o.template topLeftCorner<D, D>());
      rotation_information[e] = o.template bottomRightCorner<rdof, rdof>();
      if (tt.info() == Eigen::Success)
        rotation_information[e] -=
            o.template bottomLeftCorner<rdof, D>() * tt.solve(o.template topRightCorner<D, rdof>());
    }
    std::vector<Scalar> weight(m, Scalar(1));
    std::vector<Rotation> rotation(poses_.size());
    for (std::size_t i = 0; i < poses_.size(); ++i)
      rotation[i] = poses_[i].linear();
    Dense rhs(static_cast<Eigen::Index>(free_count_ * D), D), x;
    const auto rhs_block = [&rhs](std::size_t f) {
      return rhs.template middleRows<D>(static_cast<Eigen::Index>(f * D));
    };
    for (int round = 0; round < rounds; ++round) {
      system.set_zero();
      rhs.setZero();
      for (std::size_t e = 0; e < m; ++e) {
        const Edge& edge = edges_[e];
        const Scalar kappa =
            weight[e] * std::max(Scalar(0), rotation_information[e].trace() / Scalar(rdof));
        const std::size_t fa = free_index_[edge.from], fb = free_index_[edge.to];
        if (kappa == Scalar(0) || (fa == none && fb == none)) continue;
        const Rotation rz = edge.measurement.linear();
        // Row k of R_b − R_a·R_Z is ρ_bk − R_Zᵀ·ρ_ak for the rows ρ of R_a and R_b.
        if (fa != none) system.add_diagonal(fa, kappa * Rotation::Identity());
        if (fb != none) system.add_diagonal(fb, kappa * Rotation::Identity());
        if (edge_pair_[e] != none) system.add_off_diagonal(edge_pair_[e], -kappa * rz);
        if (fa == none) rhs_block(fb) += kappa * rz.transpose() * rotation[edge.from].transpose();
        if (fb == none) rhs_block(fa) += kappa * rz * rotation[edge.to].transpose();
      }
      if (!system.factorize()) return false;
      system.solve(rhs, x);
      for (std::size_t i = 0; i < poses_.size(); ++i)
        if (free_index_[i] != none)
          rotation[i] = lie::nearest_rotation<D, Scalar>(Rotation(
              x.template middleRows<D>(static_cast<Eigen::Index>(free_index_[i] * D)).transpose()));
      if (!robust) break;
      for (std::size_t e = 0; e < m; ++e) {
        const Edge& edge = edges_[e];
        Pose residual = Pose::Identity();
        residual.linear() = edge.measurement.linear().transpose() *
                            rotation[edge.from].transpose() * rotation[edge.to];
        const auto r = relative_pose_error<D, Scalar>(residual).template tail<rdof>().eval();
        const Scalar s = r.dot(rotation_information[e] * r);
        weight[e] = std::visit([s](const auto& loss) { return loss.weight(s); }, edge.loss);
      }
    }

    // Translations given the rotations.
    std::vector<Point<D, Scalar>> translation(poses_.size());
    for (std::size_t i = 0; i < poses_.size(); ++i)
      translation[i] = poses_[i].translation();
    std::fill(weight.begin(), weight.end(), Scalar(1));
    rhs.resize(static_cast<Eigen::Index>(free_count_ * D), 1);
    for (int round = 0; round < rounds; ++round) {
      system.set_zero();
      rhs.setZero();
      for (std::size_t e = 0; e < m; ++e) {
        const Edge& edge = edges_[e];
        const std::size_t fa = free_index_[edge.from], fb = free_index_[edge.to];
        if (weight[e] == Scalar(0) || (fa == none && fb == none)) continue;
        // e_t = R_Zᵀ·(R_aᵀ·(t_b − t_a) − t_Z), so eᵀΩ_tt·e = (t_b − t_a − R_a·t_Z)ᵀ·W·(…).
        const Rotation world = rotation[edge.from] * edge.measurement.linear();
        const Rotation w =
            weight[e] * world * edge.information.template topLeftCorner<D, D>() * world.transpose();
        const Point<D, Scalar> offset = rotation[edge.from] * edge.measurement.translation();
        if (fa != none) system.add_diagonal(fa, w);
        if (fb != none) system.add_diagonal(fb, w);
        if (edge_pair_[e] != none) system.add_off_diagonal(edge_pair_[e], -w);
        if (fa == none)
          rhs_block(fb) += w * (translation[edge.from] + offset);
        else if (fb == none)
          rhs_block(fa) += w * (translation[edge.to] - offset);
        else {
          rhs_block(fb) += w * offset;
          rhs_block(fa) -= w * offset;
        }
      }
      if (!system.factorize()) return false;
      system.solve(rhs, x);
      for (std::size_t i = 0; i < poses_.size(); ++i)
        if (free_index_[i] != none)
          translation[i] = x.template middleRows<D>(static_cast<Eigen::Index>(free_index_[i] * D));
      if (!robust) break;
      for (std::size_t e = 0; e < m; ++e) {
        const Edge& edge = edges_[e];
        const Point<D, Scalar> r =
            edge.measurement.linear().transpose() *
            (rotation[edge.from].transpose() * (translation[edge.to] - translation[edge.from]) -
             edge.measurement.translation());
        const Scalar s = r.dot(edge.information.template topLeftCorner<D, D>() * r);
        weight[e] = std::visit([s](const auto& loss) { return loss.weight(s); }, edge.loss);
      }
    }
    for (std::size_t i = 0; i < poses_.size(); ++i) {
      if (free_index_[i] == none) continue;
      poses_[i].linear() = rotation[i];
      poses_[i].translation() = translation[i];
    }
    return true;
  }

 private:
  struct Evaluation {
    Scalar chi2{0};
    Scalar cost{0};
  };

  static void require_pose(std::string_view where, std::string_view name, const Pose& pose) {
    if (!is_rigid<D, Scalar>(pose, Scalar(1e-6)))
      detail::throw_invalid(where, std::string(name) + " is not a finite rigid transform");
  }
  void require_node(std::string_view where, std::string_view name, NodeId node) const {
    if (node >= poses_.size())
      detail::throw_invalid_argument(
          where, name, node,
          "is not a node (node_count() = " + std::to_string(poses_.size()) + ")");
  }
  void require_edge(std::string_view where, EdgeId e) const {
    if (e >= edges_.size())
      detail::throw_invalid_argument(
          where, "edge", e,
          "is not an edge (edge_count() = " + std::to_string(edges_.size()) + ")");
  }
  static void require_information(std::string_view where, const Information& information) {
    if (!information.allFinite())
      detail::throw_invalid(where, "information has a non-finite entry");
    const Scalar scale = information.cwiseAbs().maxCoeff();
    if (!((information - information.transpose()).cwiseAbs().maxCoeff() <= Scalar(1e-9) * scale))
      detail::throw_invalid(where, "information is not symmetric");
    const Eigen::LDLT<Information> ldlt(information);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive())
      detail::throw_invalid(where, "information is not positive semidefinite");
  }
  static bool is_plain(const RobustKernel<Scalar>& kernel) {
    return kernel.type == RobustKernelType::none;
  }
  static bool is_plain(const DynamicCovarianceScaling<Scalar>&) { return false; }

  static void require_loss(std::string_view where, const Loss& loss) {
    std::visit([where](const auto& l) { l.validate(where); }, loss);
  }

  Error error_of(EdgeId e, const std::vector<Pose>& poses) const {
    const Edge& edge = edges_[e];
    return relative_pose_error<D, Scalar>(inverse_measurements_[e] *
                                          (poses[edge.from].inverse() * poses[edge.to]));
  }

  Evaluation evaluate(const std::vector<Pose>& poses) const {
    Evaluation sum;
    for (std::size_t e = 0; e < edges_.size(); ++e) {
      const Error r = error_of(e, poses);
      const Scalar s = r.dot(edges_[e].information * r);
      sum.chi2 += s;
      sum.cost += std::visit([s](const auto& loss) { return loss.rho(s); }, edges_[e].loss);
    }
    return sum;
  }

  // Chooses the free nodes (not fixed, not a gauge anchor) and builds the normal equations'
  // pattern; runs only after the graph's structure changed.
  void prepare(SparseBackend backend) {
    if (!structure_changed_ && backend == backend_) return;
    backend_ = backend;
    const std::size_t n = poses_.size();
    // Connected parts (union-find with path halving); each part without a fixed node gets its
    // lowest-numbered node as the anchor of the gauge.
    std::vector<std::size_t> parent(n);
    std::iota(parent.begin(), parent.end(), std::size_t{0});
    const auto find = [&parent](std::size_t i) {
      while (parent[i] != i)
        i = parent[i] = parent[parent[i]];
      return i;
    };
    for (const Edge& edge : edges_) {
      const std::size_t a = find(edge.from), b = find(edge.to);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);  // the root is the lowest node
    }
    std::vector<bool> part_fixed(n, false);
    for (std::size_t i = 0; i < n; ++i)
      if (fixed_[i]) part_fixed[find(i)] = true;
    anchored_.assign(n, false);
    for (std::size_t i = 0; i < n; ++i)
      anchored_[i] = fixed_[i] || (!part_fixed[find(i)] && find(i) == i);

    free_index_.assign(n, none);
    free_count_ = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (!anchored_[i]) free_index_[i] = free_count_++;
    std::vector<std::pair<std::size_t, std::size_t>> pairs;
    edge_pair_.assign(edges_.size(), none);
    for (std::size_t e = 0; e < edges_.size(); ++e) {
      const std::size_t a = free_index_[edges_[e].from], b = free_index_[edges_[e].to];
      if (a == none || b == none) continue;
      edge_pair_[e] = pairs.size();
      pairs.emplace_back(a, b);
    }
    ordering_ = detail::block_ordering(free_count_, pairs);
    system_.build(free_count_, pairs, ordering_, backend);
    pairs_ = std::move(pairs);
    initialization_ready_ = false;
    candidate_ = poses_;
    structure_changed_ = false;
  }

  // Assembles H = Σ w JᵀΩJ and the right-hand side −g = −Σ w JᵀΩe at the current poses.
  void linearize() {
    system_.set_zero();
    Error r;
    Information jr;
    for (std::size_t e = 0; e < edges_.size(); ++e) {
      const Edge& edge = edges_[e];
      const std::size_t fa = free_index_[edge.from], fb = free_index_[edge.to];
      if (fa == none && fb == none) continue;
      const Pose a_to_b = poses_[edge.from].inverse() * poses_[edge.to];
      relative_pose_error<D, Scalar>(inverse_measurements_[e] * a_to_b, r, jr);
      const Scalar s = r.dot(edge.information * r);
      const Scalar w = std::visit([s](const auto& loss) { return loss.weight(s); }, edge.loss);
      const Information weighted = w * edge.information;
      // ∂e/∂δb = J_E, ∂e/∂δa = −J_E·Ad(A⁻¹) (relative_pose_error.hpp).
      const Information jb = jr;
      const Information ja = -jr * lie::se_adjoint<D, Scalar>(a_to_b.inverse());
      // Products evaluated into fixed-size matrices once (the assembly reads them entry-wise).
      const Information wjb = weighted * jb;
      const Error wr = weighted * r;
      if (fb != none) {
        const Information hbb = jb.transpose() * wjb;
        system_.add_diagonal(fb, hbb);
        system_.rhs(fb) -= jb.transpose() * wr;
      }
      if (fa != none) {
        const Information wja = weighted * ja;
        const Information haa = ja.transpose() * wja;
        system_.add_diagonal(fa, haa);
        system_.rhs(fa) -= ja.transpose() * wr;
      }
      if (edge_pair_[e] != none) {
        const Information hab = ja.transpose() * wjb;
        system_.add_off_diagonal(edge_pair_[e], hab);
      }
    }
    system_.save_diagonal();
  }

  Scalar predicted_decrease(Scalar lambda) const {
    // −gᵀδ + λ·δᵀDδ, with −g the right-hand side and D the clamped diagonal, both in node order.
    return system_.rhs_dot(step_) + lambda * system_.damping_norm(step_);
  }

  void apply_step(std::vector<Pose>& out) const {
    out = poses_;
    for (std::size_t i = 0; i < poses_.size(); ++i) {
      const std::size_t f = free_index_[i];
      if (f == none) continue;
      const Error delta = step_.template segment<dof>(static_cast<Eigen::Index>(f * dof));
      out[i] = lie::retract_right<D>(poses_[i], delta);
    }
  }

  static constexpr std::size_t none = std::numeric_limits<std::size_t>::max();

  std::vector<Pose> poses_;
  std::vector<bool> fixed_;
  std::vector<Edge> edges_;
  std::vector<Pose> inverse_measurements_;
  bool structure_changed_{true};
  SparseBackend backend_{SparseBackend::automatic};
  // Derived from the structure by prepare().
  std::vector<bool> anchored_;
  std::vector<std::size_t> free_index_;
  std::vector<std::size_t> edge_pair_;
  std::size_t free_count_{0};
  std::vector<std::pair<std::size_t, std::size_t>> pairs_;
  std::vector<std::size_t>
      ordering_;  // the free nodes' fill-reducing order, shared by both systems
  detail::BlockSystem<Scalar, dof> system_;
  detail::BlockSystem<Scalar, D> initialization_system_;
  bool initialization_ready_{false};
  // Scratch reused across iterations and calls.
  std::vector<Pose> candidate_;
  Eigen::Matrix<Scalar, Eigen::Dynamic, 1> step_;
};

/// Builds a pose graph from vertex and edge records such as io::G2oGraph<D> (without depending
/// on them): `records.vertices[i]` with members `pose` (a Transform<D>) and `fixed` (bool)
/// becomes node i; `records.edges[k]` with members `from` and `to` (indices into vertices),
/// `measurement` (a Transform<D>) and `information` (in g2o's error coordinates) becomes edge k,
/// with `loss`. Throws invalid_argument as add_node and add_edge do.
template <int D, std::floating_point Scalar = double, class Records>
[[nodiscard]] PoseGraph<D, Scalar> make_pose_graph(const Records& records,
                                                   const PoseGraphLoss<Scalar>& loss = {}) {
  PoseGraph<D, Scalar> graph;
  for (const auto& vertex : records.vertices)
    graph.add_node(vertex.pose.template cast<Scalar>(), vertex.fixed);
  for (const auto& edge : records.edges)
    graph.add_edge(edge.from, edge.to, edge.measurement.template cast<Scalar>(),
                   edge.information.template cast<Scalar>(), loss);
  return graph;
}

/// A pose graph in the plane.
using PoseGraph2d = PoseGraph<2, double>;
/// A pose graph in space.
using PoseGraph3d = PoseGraph<3, double>;

}  // namespace rangenav
