#pragma once
// The vocabulary every ICP stage shares: a correspondence pair, the iteration context, and the
// CorrespondenceRejector concept (libpointmatcher's outlier-rejector stage, composed at compile
// time).
//
// A rejector is any type with one or more of these members (all optional, at least one):
//   void reject(const IcpContext<D, S>&, std::vector<Correspondence<D, S>>&)
//        drops pairs in place after the correspondence search (order need not be kept);
//   S max_distance_sq(const IcpContext<D, S>&) const
//        a bound the correspondence search uses to prune: pairs at or beyond it are never formed;
//   bool admits(const IcpContext<D, S>&, const Point<D, S>& data_point_in_model_frame) const
//        a test applied before the search: a data point it refuses is not searched for at all;
//   bool settled(const IcpContext<D, S>&) const
//        false while the rejector still changes between iterations (a decaying threshold): ICP
//        does not declare convergence before every rejector has settled;
//   void begin(std::size_t model_size, std::size_t data_size)
//        called once at the start of each alignment (scratch sizing, no allocation afterwards).

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "rangenav/core/types.hpp"

namespace rangenav {

/// A data point paired with its closest model point. `data` is the data point in the data frame
/// (untransformed), `model` the model point, `distance_sq` = |model - T * data|^2 for the
/// transform T of the iteration that formed the pair.
template <int D, class Scalar>
struct Correspondence {
  Point<D, Scalar> data;          ///< the data point, in the data frame
  Point<D, Scalar> model;         ///< the model point, in the model frame
  Scalar distance_sq = 0;         ///< |model - T * data|^2 (m²)
  std::uint32_t data_index = 0;   ///< the data point's index in the data cloud as given
  std::uint32_t model_index = 0;  ///< the model point's index in the model's search structure
};

/// What a stage knows about the running alignment.
template <int D, class Scalar>
struct IcpContext {
  int iteration = 0;               ///< 0-based
  Transform<D, Scalar> transform;  ///< current estimate, maps data into the model frame
  std::size_t model_size = 0;      ///< points in the model's search structure
  std::size_t data_size = 0;       ///< finite data points
  /// The first iteration whose update moved the estimate less than the ICP's epsilons while
  /// some rejector had not settled (the estimate converged under a threshold still decaying);
  /// -1 while none has. A rejector may then settle at once (DecayingDistanceRejector::
  /// skip_when_converged).
  int converged_unsettled = -1;
};

namespace detail {

/// p -> T p for an affine Transform T, evaluated as Eigen's `T * p` evaluates it (the columns
/// of the linear part scaled by p's coordinates and summed in order, then the translation: the
/// same floating-point result, checked on 10^5 random transforms in 2D and 3D with g++ and
/// clang++) without forming the homogeneous vector and the product's extra row; about half the
/// instructions in the ICP's per-point loops.
template <int D, class Scalar>
struct AffineApply {
  Eigen::Matrix<Scalar, D, D> linear;
  Point<D, Scalar> translation;

  explicit AffineApply(const Transform<D, Scalar>& t)
      : linear(t.linear()), translation(t.translation()) {}
  [[nodiscard]] Point<D, Scalar> operator()(const Point<D, Scalar>& p) const {
    Point<D, Scalar> out = linear.col(0) * p[0];
    for (int d = 1; d < D; ++d)
      out += linear.col(d) * p[d];
    return out + translation;
  }
};

template <class R, int D, class S>
concept HasReject = requires(R& r, const IcpContext<D, S>& ctx,
                             std::vector<Correspondence<D, S>>& pairs) {
  r.reject(ctx, pairs);
};
template <class R, int D, class S>
concept HasMaxDistance = requires(const R& r, const IcpContext<D, S>& ctx) {
  { r.max_distance_sq(ctx) } -> std::convertible_to<S>;
};
template <class R, int D, class S>
concept HasAdmits = requires(const R& r, const IcpContext<D, S>& ctx, const Point<D, S>& p) {
  { r.admits(ctx, p) } -> std::convertible_to<bool>;
};
template <class R, int D, class S>
concept HasSettled = requires(const R& r, const IcpContext<D, S>& ctx) {
  { r.settled(ctx) } -> std::convertible_to<bool>;
};
template <class R>
concept HasBegin = requires(R& r, std::size_t n) {
  r.begin(n, n);
};
}  // namespace detail

/// A correspondence rejector for D-dimensional alignment with scalar S (see the file comment).
template <class R, int D, class S>
concept CorrespondenceRejector =
    detail::HasReject<R, D, S> || detail::HasMaxDistance<R, D, S> || detail::HasAdmits<R, D, S>;

}  // namespace rangenav
