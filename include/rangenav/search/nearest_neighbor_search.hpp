#pragma once
// The NearestNeighborSearch concept, its result type, and a brute-force reference model.
//
// A search structure indexes a set of D-dimensional points and answers three queries; every
// distance it reports or takes is SQUARED (named `*_sq`) and every bound is strict:
//   nearest(q, max_distance_sq)   the closest point with distance_sq < max_distance_sq, if any.
//                                 The bound prunes the search (ICP passes its rejection radius).
//   knn(q, k, out, max_distance_sq = inf)   the k closest points, ascending; returns the count.
//   radius(q, radius_sq, out)     all points with distance_sq < radius_sq, ascending.
// `out` is a caller-owned buffer that is cleared and refilled, so a loop of queries allocates
// nothing once the buffer has grown. Indices refer to the structure's own point list: point(i).
// Queries are const and may run concurrently from several threads; mutation (insert) may not.

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/parallel.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// One query answer: the index of a stored point and its squared distance to the query.
template <class Scalar>
struct Neighbor {
  std::uint32_t index = 0;  ///< the stored point's index: point(index) of the structure queried
  Scalar distance_sq = 0;   ///< squared Euclidean distance to the query (m²)
  friend bool operator==(const Neighbor&, const Neighbor&) = default;
};

/// +infinity, the "no bound" value of every `max_distance_sq` argument.
template <class Scalar>
inline constexpr Scalar unbounded_sq = std::numeric_limits<Scalar>::infinity();

// clang-format off
/// A nearest-neighbour index over points of dimension S::dimension and scalar S::scalar_type.
template <class S>
concept NearestNeighborSearch =
    requires { { S::dimension } -> std::convertible_to<int>; typename S::scalar_type; } &&
    requires(const S& s, const Point<S::dimension, typename S::scalar_type>& q, std::size_t k,
             typename S::scalar_type bound_sq,
             std::vector<Neighbor<typename S::scalar_type>>& out) {
      { s.size() } -> std::convertible_to<std::size_t>;
      { s.point(std::size_t{}) } -> std::convertible_to<Point<S::dimension, typename S::scalar_type>>;
      { s.nearest(q, bound_sq) } -> std::same_as<std::optional<Neighbor<typename S::scalar_type>>>;
      { s.knn(q, k, out) } -> std::convertible_to<std::size_t>;
      { s.knn(q, k, out, bound_sq) } -> std::convertible_to<std::size_t>;
      { s.radius(q, bound_sq, out) } -> std::convertible_to<std::size_t>;
    };
// clang-format on

namespace detail {

/// Keeps the k best (index, distance_sq) pairs in ascending order inside a caller's buffer; also
/// the result-set protocol of nanoflann (worstDist / addPoint / full), so one collector can run
/// over several trees and the bound shrinks across them.
template <class Scalar>
class KnnCollector {
 public:
  KnnCollector(Neighbor<Scalar>* data, std::size_t capacity, Scalar bound_sq)
      : data_(data), capacity_(capacity), worst_(bound_sq) {}

  /// The bound a new point must beat: the k-th distance once k points are held, else the bound
  /// given (kept in a member: the tree asks at every node).
  [[nodiscard]] Scalar worstDist() const { return worst_; }
  bool addPoint(Scalar distance_sq, std::uint32_t index) {
    if (!(distance_sq < worst_)) return true;
    std::size_t i = count_ < capacity_ ? count_++ : capacity_ - 1;
    for (; i > 0 && data_[i - 1].distance_sq > distance_sq; --i)
      data_[i] = data_[i - 1];
    data_[i] = {index, distance_sq};
    if (count_ == capacity_) worst_ = data_[capacity_ - 1].distance_sq;
    return true;
  }
  [[nodiscard]] bool full() const { return count_ == capacity_; }
  [[nodiscard]] std::size_t size() const { return count_; }

 private:
  Neighbor<Scalar>* data_;
  std::size_t capacity_;
  std::size_t count_ = 0;
  Scalar worst_;
};

/// The single closest point under a strict bound (nanoflann result-set protocol).
template <class Scalar>
class NearestCollector {
 public:
  explicit NearestCollector(Scalar bound_sq) : best_{0, bound_sq} {}
  [[nodiscard]] Scalar worstDist() const { return best_.distance_sq; }
  bool addPoint(Scalar distance_sq, std::uint32_t index) {
    if (distance_sq < best_.distance_sq) {
      best_ = {index, distance_sq};
      found_ = true;
    }
    return true;
  }
  [[nodiscard]] bool full() const { return true; }
  [[nodiscard]] std::optional<Neighbor<Scalar>> result() const {
    return found_ ? std::optional<Neighbor<Scalar>>(best_) : std::nullopt;
  }

 private:
  Neighbor<Scalar> best_;
  bool found_ = false;
};

/// Every point under a strict bound (nanoflann result-set protocol); sort afterwards.
template <class Scalar>
class RadiusCollector {
 public:
  RadiusCollector(std::vector<Neighbor<Scalar>>& out, Scalar radius_sq)
      : out_(out), radius_sq_(radius_sq) {}
  [[nodiscard]] Scalar worstDist() const { return radius_sq_; }
  bool addPoint(Scalar distance_sq, std::uint32_t index) {
    if (distance_sq < radius_sq_) out_.push_back({index, distance_sq});
    return true;
  }
  [[nodiscard]] bool full() const { return true; }

 private:
  std::vector<Neighbor<Scalar>>& out_;
  Scalar radius_sq_;
};

template <class Scalar>
void sort_by_distance(std::vector<Neighbor<Scalar>>& out) {
  std::sort(out.begin(), out.end(), [](const Neighbor<Scalar>& a, const Neighbor<Scalar>& b) {
    return a.distance_sq < b.distance_sq || (a.distance_sq == b.distance_sq && a.index < b.index);
  });
}

}  // namespace detail

/// The queries of NearestNeighborSearch (nearest, knn, radius), written once for every search
/// structure of the library over the structure's own collect(c, q, bound_sq), which offers a
/// result collector (nanoflann's result-set protocol) every stored point that may lie within
/// bound_sq of q, pruning by the collector's shrinking bound. A structure of one's own gets the
/// queries the same way (CRTP): `class S : public SearchQueries<S, D, Scalar>`, with this base
/// a friend of S when collect() is private.
template <class Derived, int D, class Scalar>
class SearchQueries {
 public:
  /// The closest stored point with distance_sq < max_distance_sq, or nothing when no point is
  /// that close.
  [[nodiscard]] std::optional<Neighbor<Scalar>> nearest(
      const Point<D, Scalar>& q, Scalar max_distance_sq = unbounded_sq<Scalar>) const {
    detail::NearestCollector<Scalar> c(max_distance_sq);
    self().collect(c, q, max_distance_sq);
    return c.result();
  }

  /// Replaces `out` by the (at most) k closest points with distance_sq < max_distance_sq,
  /// ascending by distance; returns their count.
  std::size_t knn(const Point<D, Scalar>& q, std::size_t k, std::vector<Neighbor<Scalar>>& out,
                  Scalar max_distance_sq = unbounded_sq<Scalar>) const {
    if (out.size() != k) out.resize(k);  // (a call GCC does not inline: skipped when sized)
    if (k == 0) return 0;
    detail::KnnCollector<Scalar> c(out.data(), k, max_distance_sq);
    self().collect(c, q, max_distance_sq);
    if (c.size() != k) out.resize(c.size());
    return out.size();
  }

  /// Replaces `out` by every point with distance_sq < radius_sq, ascending by distance (ties by
  /// index); with `sorted` false in no particular order (cheaper when the order does not
  /// matter, e.g. for clustering). Returns their count.
  std::size_t radius(const Point<D, Scalar>& q, Scalar radius_sq,
                     std::vector<Neighbor<Scalar>>& out, bool sorted = true) const {
    out.clear();
    detail::RadiusCollector<Scalar> c(out, radius_sq);
    self().collect(c, q, radius_sq);
    if (sorted) detail::sort_by_distance(out);
    return out.size();
  }

 private:
  [[nodiscard]] const Derived& self() const { return static_cast<const Derived&>(*this); }
};

/// The k nearest stored points of every stored point of a search structure (itself included),
/// ascending by distance, with each list's reach: every stored point not in list i is at least
/// reach[i] away from point i (the k-th distance; +infinity when the list holds every point).
/// The normal / covariance PCA reads its neighbourhoods from them, and ICP finds a data point's
/// nearest model point among the neighbours of its last one without a search (icp.hpp).
template <class Scalar>
struct NeighborLists {
  std::size_t k = 0;                   ///< slots per point
  std::vector<std::uint32_t> count;    ///< neighbours found for point i (<= k)
  std::vector<std::uint32_t> indices;  ///< k slots per point: point i's are [i k, i k + count[i])
  std::vector<Scalar> reach;           ///< see the struct comment (a distance, not squared)

  /// Number of points with a list (the search structure's size).
  [[nodiscard]] std::size_t size() const { return count.size(); }
  /// The neighbours of point i, nearest first.
  [[nodiscard]] std::span<const std::uint32_t> of(std::size_t i) const {
    return {indices.data() + i * k, count[i]};
  }
};

/// The neighbour lists of every point of `search` (k >= 1 neighbours, itself included), queried
/// on up to num_threads threads; each list is one k-NN query, so the thread count does not
/// change them. Throws invalid_argument unless k >= 1 and num_threads >= 1.
template <NearestNeighborSearch S>
[[nodiscard]] NeighborLists<typename S::scalar_type> neighbor_lists(const S& search, std::size_t k,
                                                                    int num_threads = 1) {
  using Scalar = typename S::scalar_type;
  constexpr std::string_view where = "neighbor_lists";
  if (k < 1) detail::throw_invalid_argument(where, "k", k, "must be >= 1");
  detail::require_threads(where, num_threads);
  NeighborLists<Scalar> lists;
  const std::size_t n = search.size();
  lists.k = k;
  lists.count.resize(n);
  lists.indices.resize(n * k);
  lists.reach.resize(n);
  detail::for_each_block(n, 256, num_threads,
                         [&](std::size_t, std::size_t begin, std::size_t end, int) {
                           std::vector<Neighbor<Scalar>> knn;
                           knn.reserve(k);
                           for (std::size_t i = begin; i < end; ++i) {
                             const std::size_t found = search.knn(search.point(i), k, knn);
                             lists.count[i] = static_cast<std::uint32_t>(found);
                             for (std::size_t m = 0; m < found; ++m)
                               lists.indices[i * k + m] = knn[m].index;
                             lists.reach[i] = found == k ? std::sqrt(knn[k - 1].distance_sq)
                                                         : std::numeric_limits<Scalar>::infinity();
                           }
                         });
  return lists;
}

/// Exhaustive search: the reference the kd-trees are tested against, and the fastest choice for
/// a few dozen points. Non-finite points of the input are skipped (source_index maps back).
template <int D, class Scalar = double>
class BruteForceSearch : public SearchQueries<BruteForceSearch<D, Scalar>, D, Scalar> {
 public:
  static constexpr int dimension = D;   ///< 2 or 3
  using scalar_type = Scalar;           ///< coordinate type
  using point_type = Point<D, Scalar>;  ///< a stored point

  BruteForceSearch() = default;
  /// Stores the finite points of `cloud` (converted to Scalar), in input order.
  template <PointCloudOf<D> C>
  explicit BruteForceSearch(const C& cloud) {
    const std::size_t n = traits::size(cloud);
    for (std::size_t i = 0; i < n; ++i) {
      const point_type p = traits::point(cloud, i).template cast<Scalar>();
      if (!p.allFinite()) continue;
      points_.push_back(p);
      source_.push_back(static_cast<std::uint32_t>(i));
    }
  }

  /// Number of stored (finite) points.
  [[nodiscard]] std::size_t size() const { return points_.size(); }
  /// Stored point i, i < size().
  [[nodiscard]] const point_type& point(std::size_t i) const { return points_[i]; }
  /// The index in the input cloud of stored point i, i < size().
  [[nodiscard]] std::size_t source_index(std::size_t i) const { return source_[i]; }

  // nearest() / knn() / radius(): SearchQueries (points in index order: ties go to the first).

 private:
  friend class SearchQueries<BruteForceSearch, D, Scalar>;
  template <class Collector>
  void collect(Collector& c, const point_type& q, Scalar) const {
    for (std::size_t i = 0; i < points_.size(); ++i)
      c.addPoint((points_[i] - q).squaredNorm(), static_cast<std::uint32_t>(i));
  }

  std::vector<point_type> points_;
  std::vector<std::uint32_t> source_;
};

}  // namespace rangenav
