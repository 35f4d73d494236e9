#pragma once
// Correspondence rejectors (see correspondence.hpp for the protocol). The frustum rejector lives
// in frustum.hpp.

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/registration/correspondence.hpp"

namespace rangenav {

/// Rejects pairs farther apart than a threshold that decays exponentially per iteration from
/// `initial_distance` to `final_distance` (paper 000 §3.1, paper 002 §6.3):
///   d_k = max(final_distance, initial_distance * decay^k).
/// Large early distances give fast convergence of E(R, t) (Eq. (1) of paper 000), small late
/// ones fine-tune. The threshold also bounds the correspondence search.
template <std::floating_point Scalar = double>
struct DecayingDistanceRejector {
  Scalar initial_distance = Scalar(1.0);  ///< m, threshold of iteration 0
  Scalar final_distance = Scalar(0.1);    ///< m, the threshold never decays below this
  Scalar decay = Scalar(0.8);             ///< factor per iteration, in (0, 1]
  /// Once the estimate has converged under a threshold that has not yet decayed to
  /// final_distance (IcpContext::converged_unsettled), go straight to final_distance. The wide
  /// thresholds are there for the "fast convergence" of paper 000 §3.1; when the estimate has
  /// stopped moving under one of them, what is left is the fine-tuning under the final one, and
  /// the iterations of the schedule in between are skipped. Default false: the papers' schedule,
  /// one threshold per iteration.
  bool skip_when_converged = false;

  /// Throws invalid_argument unless 0 < final <= initial and 0 < decay <= 1.
  void validate() const {
    constexpr std::string_view where = "DecayingDistanceRejector";
    detail::require_positive(where, "final_distance", final_distance);
    detail::require_positive(where, "initial_distance", initial_distance);
    if (initial_distance < final_distance)
      detail::throw_invalid_argument(where, "initial_distance", initial_distance,
                                     "must be >= final_distance");
    if (!(decay > Scalar(0) && decay <= Scalar(1)))
      detail::throw_invalid_argument(where, "decay", decay, "must be in (0, 1]");
  }

  /// The threshold d_k of iteration k, in metres (the schedule, without skip_when_converged).
  [[nodiscard]] Scalar distance(int iteration) const {
    return std::max(final_distance,
                    initial_distance * std::pow(decay, static_cast<Scalar>(iteration)));
  }
  /// The threshold of the context's iteration (m): distance(ctx.iteration), or final_distance
  /// after a convergence with skip_when_converged.
  template <int D>
  [[nodiscard]] Scalar distance(const IcpContext<D, Scalar>& ctx) const {
    const bool skipped = skip_when_converged && ctx.converged_unsettled >= 0 &&
                         ctx.iteration > ctx.converged_unsettled;
    return skipped ? final_distance : distance(ctx.iteration);
  }
  /// The search bound of the context's iteration: d_k² (m²).
  template <int D>
  [[nodiscard]] Scalar max_distance_sq(const IcpContext<D, Scalar>& ctx) const {
    const Scalar d = distance(ctx);
    return d * d;
  }
  /// True once the threshold is final_distance (ICP may then declare convergence).
  template <int D>
  [[nodiscard]] bool settled(const IcpContext<D, Scalar>& ctx) const {
    return distance(ctx) <= final_distance;
  }
};

/// Keeps, for every model point that several data points paired with, only the closest pair
/// (Zinßer et al. 2003; paper 002 §6.3): one model point cannot be the image of two data points.
struct UniqueModelPointRejector {
  /// Drops, per model point, every pair but the one with the smallest distance_sq; the kept
  /// pairs end up sorted by model_index.
  template <int D, class Scalar>
  void reject(const IcpContext<D, Scalar>&, std::vector<Correspondence<D, Scalar>>& pairs) const {
    std::sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) {
      return a.model_index < b.model_index ||
             (a.model_index == b.model_index && a.distance_sq < b.distance_sq);
    });
    const auto last = std::unique(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) {
      return a.model_index == b.model_index;
    });
    pairs.erase(last, pairs.end());
  }
};

/// Keeps the `overlap` fraction of pairs with the smallest distances (trimmed ICP,
/// Chetverikov et al. 2002): the expected overlap of data and model.
template <std::floating_point Scalar = double>
struct TrimmedRejector {
  Scalar overlap = Scalar(0.9);  ///< fraction of pairs kept, in (0, 1]

  /// Throws invalid_argument unless 0 < overlap <= 1.
  void validate() const {
    if (!(overlap > Scalar(0) && overlap <= Scalar(1)))
      detail::throw_invalid_argument("TrimmedRejector", "overlap", overlap, "must be in (0, 1]");
  }

  /// Keeps the ceil(overlap · n) of the n pairs with the smallest distance_sq, in no particular
  /// order.
  template <int D>
  void reject(const IcpContext<D, Scalar>&, std::vector<Correspondence<D, Scalar>>& pairs) const {
    const auto keep = static_cast<std::size_t>(
        std::ceil(overlap * static_cast<Scalar>(pairs.size()) - Scalar(1e-9)));
    if (keep >= pairs.size()) return;
    std::nth_element(pairs.begin(), pairs.begin() + static_cast<std::ptrdiff_t>(keep), pairs.end(),
                     [](const auto& a, const auto& b) { return a.distance_sq < b.distance_sq; });
    pairs.resize(keep);
  }
};

/// A fixed maximum pair distance (the common `max_correspondence_distance` of PCL / Open3D).
template <std::floating_point Scalar = double>
struct MaxDistanceRejector {
  Scalar max_distance = Scalar(1.0);  ///< m
  /// The search bound: max_distance² (m²), the same at every iteration.
  template <int D>
  [[nodiscard]] Scalar max_distance_sq(const IcpContext<D, Scalar>&) const {
    return max_distance * max_distance;
  }
};

}  // namespace rangenav
