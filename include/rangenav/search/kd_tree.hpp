#pragma once
// kd-trees behind the NearestNeighborSearch concept, built with nanoflann.
//
// KdTree<D, Scalar>        a static index over one cloud (the ICP model of a scan-to-scan match).
// GrowingKdTree<D, Scalar> an index that points are appended to (a growing map). Appended batches
//                          form a short chain of static trees over contiguous index ranges whose
//                          sizes at least halve along the chain; a new batch merges (rebuilds)
//                          the tail of the chain while that keeps the halving rule (Bentley-Saxe
//                          logarithmic method). Each point is rebuilt O(log n) times, a query
//                          visits at most log2(n) trees largest first, and one collector runs over
//                          all of them so the first tree's answer bounds the others.
//
// Both copy the finite points of their input into one contiguous array (non-finite points, e.g.
// invalid beams of a LaserScan, are skipped; source_index(i) maps back). Queries are const and
// thread-safe; insert() is not.

#include <nanoflann.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/parallel.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/search/nearest_neighbor_search.hpp"

namespace rangenav {

/// Build parameters of the kd-trees.
struct KdTreeParams {
  /// Maximum number of points in a leaf (nanoflann's leaf_max_size): smaller leaves mean faster
  /// queries and slower builds. 10 is nanoflann's default.
  std::size_t leaf_max_size = 10;
  /// Threads that build a KdTree (see KdTree: a large cloud is cut into parts built at once).
  /// The tree, and so every query's answer, does not depend on it. Default 1.
  int num_threads = 1;
};

namespace detail {

/// nanoflann dataset adaptor over a contiguous range of Eigen points (zero-copy view).
template <int D, class Scalar>
struct PointRangeAdaptor {
  const Point<D, Scalar>* data = nullptr;
  std::size_t count = 0;

  [[nodiscard]] std::size_t kdtree_get_point_count() const { return count; }
  [[nodiscard]] Scalar kdtree_get_pt(std::uint32_t i, std::size_t dim) const {
    return data[i][static_cast<Eigen::Index>(dim)];
  }
  template <class BoundingBox>
  bool kdtree_get_bbox(BoundingBox&) const {
    return false;
  }
};

/// One static nanoflann tree over points [offset, offset + count) of an external array.
template <int D, class Scalar>
class RangeTree {
 public:
  using Adaptor = PointRangeAdaptor<D, Scalar>;
  using Index = nanoflann::KDTreeSingleIndexAdaptor<
      nanoflann::L2_Simple_Adaptor<Scalar, Adaptor, Scalar, std::uint32_t>, Adaptor, D,
      std::uint32_t>;

  RangeTree(const Point<D, Scalar>* data, std::size_t offset, std::size_t count,
            const KdTreeParams& params)
      : offset_(offset), adaptor_{data + offset, count} {
    index_ = std::make_unique<Index>(D, adaptor_,
                                     nanoflann::KDTreeSingleIndexAdaptorParams(
                                         params.leaf_max_size < 1 ? 1 : params.leaf_max_size));
  }
  RangeTree(const RangeTree&) = delete;
  RangeTree& operator=(const RangeTree&) = delete;

  /// The points moved (the owning vector reallocated): the tree's structure is unchanged.
  void rebase(const Point<D, Scalar>* data) { adaptor_.data = data + offset_; }

  [[nodiscard]] std::size_t offset() const { return offset_; }
  /// Bytes held by the tree structure (nodes and index array), not the points.
  [[nodiscard]] std::size_t memory_bytes() const {
    return static_cast<std::size_t>(index_->usedMemory(*index_));
  }
  [[nodiscard]] std::size_t size() const { return adaptor_.count; }

  /// Runs a result collector; indices it receives are local to this tree.
  template <class Collector>
  void search(Collector& collector, const Point<D, Scalar>& q) const {
    if (adaptor_.count == 0) return;
    index_->findNeighbors(collector, q.data(), nanoflann::SearchParams(32, 0.0f, false));
  }

 private:
  std::size_t offset_;
  Adaptor adaptor_;
  std::unique_ptr<Index> index_;
};

/// Collector decorator that maps a part's local indices through a permutation (KdTree's parts).
template <class Inner>
struct PermutedCollector {
  Inner& inner;
  const std::uint32_t* index;  ///< index[local] is the stored point's index
  [[nodiscard]] auto worstDist() const { return inner.worstDist(); }
  template <class Scalar>
  bool addPoint(Scalar distance_sq, std::uint32_t local) {
    return inner.addPoint(distance_sq, index[local]);
  }
  [[nodiscard]] bool full() const { return inner.full(); }
};

/// Collector decorator that shifts a tree's local indices by its offset.
template <class Inner>
struct OffsetCollector {
  Inner& inner;
  std::uint32_t offset;
  [[nodiscard]] auto worstDist() const { return inner.worstDist(); }
  template <class Scalar>
  bool addPoint(Scalar distance_sq, std::uint32_t index) {
    return inner.addPoint(distance_sq, index + offset);
  }
  [[nodiscard]] bool full() const { return inner.full(); }
};

template <int D, class Scalar, PointCloud C>
void append_finite(const C& cloud, std::vector<Point<D, Scalar>>& points,
                   std::vector<std::uint32_t>& source, bool& has_gaps, std::size_t source_base) {
  const std::size_t n = traits::size(cloud);
  points.reserve(points.size() + n);
  for (std::size_t i = 0; i < n; ++i) {
    const Point<D, Scalar> p = traits::point(cloud, i).template cast<Scalar>();
    if (!p.allFinite()) {
      if (!has_gaps) {
        has_gaps = true;
        source.resize(points.size());
        for (std::size_t j = 0; j < source.size(); ++j)
          source[j] = static_cast<std::uint32_t>(j);
      }
      continue;
    }
    if (has_gaps) source.push_back(static_cast<std::uint32_t>(source_base + i));
    points.push_back(p);
  }
}

}  // namespace detail

/// A static kd-tree over the finite points of a cloud. Models NearestNeighborSearch.
///
/// A cloud of at least 2 * part_size points is cut into 2, 4 or 8 parts by median planes (the
/// top levels of a kd-tree, along the widest extent), and each part gets its own nanoflann tree,
/// so that KdTreeParams::num_threads threads build the parts at once (nanoflann builds one tree
/// on one thread). A query descends the planes nearest side first and visits the other side only
/// when the plane is nearer than the answer so far, as inside a single tree. The parts hold a
/// reordered copy of the points; the cut depends on the point count only, never on the threads.
template <int D, class Scalar = double>
class KdTree : public SearchQueries<KdTree<D, Scalar>, D, Scalar> {
 public:
  static_assert(D == 2 || D == 3, "KdTree: dimension must be 2 or 3");
  static constexpr int dimension = D;   ///< 2 or 3
  using scalar_type = Scalar;           ///< coordinate type
  using point_type = Point<D, Scalar>;  ///< a stored point
  /// Least points of a part: a smaller cloud is one nanoflann tree.
  static constexpr std::size_t part_size = 2048;
  /// Most parts.
  static constexpr std::size_t max_parts = 8;

  KdTree() = default;

  /// Indexes the finite points of `cloud` (converted to Scalar).
  template <PointCloudOf<D> C>
  explicit KdTree(const C& cloud, KdTreeParams params = {}) : params_(params) {
    detail::append_finite<D, Scalar>(cloud, points_, source_, has_gaps_, 0);
    build();
  }

  /// Takes ownership of a point array (no copy); non-finite points are not allowed here.
  explicit KdTree(std::vector<point_type>&& points, KdTreeParams params = {})
      : points_(std::move(points)), params_(params) {
    for (std::size_t i = 0; i < points_.size(); ++i)
      if (!points_[i].allFinite())
        detail::throw_invalid_argument("KdTree", "points[" + std::to_string(i) + "]",
                                       "(non-finite)", "must be finite");
    build();
  }

  /// Moves the tree (points and structure; no rebuild).
  KdTree(KdTree&&) noexcept = default;
  /// Move assignment (no rebuild).
  KdTree& operator=(KdTree&&) noexcept = default;

  /// Number of stored (finite) points.
  [[nodiscard]] std::size_t size() const { return points_.size(); }
  /// True when no point is stored.
  [[nodiscard]] bool empty() const { return points_.empty(); }
  /// Stored point i, i < size().
  [[nodiscard]] const point_type& point(std::size_t i) const { return points_[i]; }
  /// The stored points, indexed as the query results are.
  [[nodiscard]] const std::vector<point_type>& points() const { return points_; }
  /// The index in the input cloud of stored point i.
  [[nodiscard]] std::size_t source_index(std::size_t i) const { return has_gaps_ ? source_[i] : i; }

  // nearest() / knn() / radius(): SearchQueries.

 private:
  friend class SearchQueries<KdTree, D, Scalar>;
  /// A median plane of the top levels: points with x[axis] < value lie on the first side,
  /// > value on the second, = value on either.
  struct Cut {
    int axis = 0;
    Scalar value = 0;
  };

  void build() {
    detail::require_threads("KdTree", params_.num_threads);
    const std::size_t n = points_.size();
    if (n == 0) return;
    std::size_t parts = 1;
    while (parts < max_parts && n >= 2 * parts * part_size)
      parts *= 2;
    if (parts == 1) {
      tree_ = std::make_unique<detail::RangeTree<D, Scalar>>(points_.data(), 0, n, params_);
      return;
    }
    // The cuts in heap order (node c has children 2c + 1, 2c + 2; the parts are the leaves
    // parts - 1 ...): each halves its node's points at the median of the widest axis.
    order_.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      order_[i] = static_cast<std::uint32_t>(i);
    cuts_.assign(parts - 1, Cut{});
    std::vector<std::size_t> first(2 * parts - 1), last(2 * parts - 1);
    first[0] = 0;
    last[0] = n;
    for (std::size_t c = 0; c + 1 < parts; ++c) {
      const auto begin = order_.begin() + static_cast<std::ptrdiff_t>(first[c]);
      const auto end = order_.begin() + static_cast<std::ptrdiff_t>(last[c]);
      point_type lo = points_[*begin], hi = lo;
      for (auto it = begin; it != end; ++it) {
        lo = lo.cwiseMin(points_[*it]);
        hi = hi.cwiseMax(points_[*it]);
      }
      int axis = 0;
      (hi - lo).maxCoeff(&axis);
      const auto mid = begin + (end - begin) / 2;
      std::nth_element(begin, mid, end, [&](std::uint32_t a, std::uint32_t b) {
        return points_[a][axis] < points_[b][axis];
      });
      cuts_[c] = {axis, points_[*mid][axis]};
      const std::size_t m = static_cast<std::size_t>(mid - order_.begin());
      first[2 * c + 1] = first[c];
      last[2 * c + 1] = m;
      first[2 * c + 2] = m;
      last[2 * c + 2] = last[c];
    }
    part_points_.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      part_points_[i] = points_[order_[i]];
    parts_.resize(parts);
    detail::for_each_block(
        parts, 1, params_.num_threads, [&](std::size_t p, std::size_t, std::size_t, int) {
          const std::size_t leaf = parts - 1 + p;
          parts_[p] = std::make_unique<detail::RangeTree<D, Scalar>>(
              part_points_.data(), first[leaf], last[leaf] - first[leaf], params_);
        });
  }

  template <class Collector>
  void collect(Collector& c, const point_type& q, Scalar) const {
    if (tree_)
      tree_->search(c, q);
    else if (!parts_.empty())
      search_node(c, q, 0);
  }

  /// The parts under heap node `node`, nearest side first.
  template <class Collector>
  void search_node(Collector& c, const point_type& q, std::size_t node) const {
    if (node >= cuts_.size()) {
      const auto& part = *parts_[node - cuts_.size()];
      detail::PermutedCollector<Collector> mapped{c, order_.data() + part.offset()};
      part.search(mapped, q);
      return;
    }
    const Cut& cut = cuts_[node];
    const Scalar diff = q[cut.axis] - cut.value;
    const std::size_t near = diff < Scalar(0) ? 2 * node + 1 : 2 * node + 2;
    search_node(c, q, near);
    // Every point beyond the plane is at least |diff| away.
    if (diff * diff < c.worstDist()) search_node(c, q, near == 2 * node + 1 ? near + 1 : near - 1);
  }

  std::vector<point_type> points_;
  std::vector<std::uint32_t> source_;
  bool has_gaps_ = false;
  KdTreeParams params_{};
  std::unique_ptr<detail::RangeTree<D, Scalar>> tree_;  ///< a cloud of one part
  // A cloud of several parts:
  std::vector<Cut> cuts_;                ///< the top levels, in heap order
  std::vector<std::uint32_t> order_;     ///< part_points_[i] is points_[order_[i]]
  std::vector<point_type> part_points_;  ///< the points, each part contiguous
  std::vector<std::unique_ptr<detail::RangeTree<D, Scalar>>> parts_;  ///< by leaf
};

/// A kd-tree that points are appended to, with amortised O(log n) rebuilds per point (see the
/// file comment). Models NearestNeighborSearch; indices are stable (insertion order).
template <int D, class Scalar = double>
class GrowingKdTree : public SearchQueries<GrowingKdTree<D, Scalar>, D, Scalar> {
 public:
  static_assert(D == 2 || D == 3, "GrowingKdTree: dimension must be 2 or 3");
  static constexpr int dimension = D;   ///< 2 or 3
  using scalar_type = Scalar;           ///< coordinate type
  using point_type = Point<D, Scalar>;  ///< a stored point

  /// An empty index whose trees will be built with `params`.
  explicit GrowingKdTree(KdTreeParams params = {}) : params_(params) {}
  /// Moves the index (points and trees; no rebuild).
  GrowingKdTree(GrowingKdTree&&) noexcept = default;
  /// Move assignment (no rebuild).
  GrowingKdTree& operator=(GrowingKdTree&&) noexcept = default;

  /// Appends the finite points of a cloud (one batch); returns how many were appended.
  template <PointCloudOf<D> C>
  std::size_t insert(const C& cloud) {
    const std::size_t before = points_.size();
    const std::size_t n = traits::size(cloud);
    points_.reserve(before + n);
    for (std::size_t i = 0; i < n; ++i) {
      const point_type p = traits::point(cloud, i).template cast<Scalar>();
      if (p.allFinite()) points_.push_back(p);
    }
    commit(before);
    return points_.size() - before;
  }

  /// Appends one point (non-finite points are ignored). Prefer batches: each call is a batch.
  bool insert_point(const point_type& p) {
    if (!p.allFinite()) return false;
    const std::size_t before = points_.size();
    points_.push_back(p);
    commit(before);
    return true;
  }

  /// Reserves room for n points in all (as std::vector::reserve).
  void reserve(std::size_t n) { points_.reserve(n); }
  /// Removes every point and tree; the parameters stay.
  void clear() {
    trees_.clear();
    points_.clear();
  }

  /// Number of stored points.
  [[nodiscard]] std::size_t size() const { return points_.size(); }
  /// True when no point is stored.
  [[nodiscard]] bool empty() const { return points_.empty(); }
  /// Stored point i (the i-th finite point inserted), i < size().
  [[nodiscard]] const point_type& point(std::size_t i) const { return points_[i]; }
  /// The stored points in insertion order, indexed as the query results are.
  [[nodiscard]] const std::vector<point_type>& points() const { return points_; }
  /// Bytes held: the point array plus every tree's nodes and index array.
  [[nodiscard]] std::size_t memory_bytes() const {
    std::size_t bytes = points_.capacity() * sizeof(point_type);
    for (const auto& tree : trees_)
      bytes += tree->memory_bytes();
    return bytes;
  }
  /// Number of static trees in the chain (at most log2(size) + 1).
  [[nodiscard]] std::size_t tree_count() const { return trees_.size(); }

  // nearest() / knn() / radius(): SearchQueries.

 private:
  friend class SearchQueries<GrowingKdTree, D, Scalar>;
  template <class Collector>
  void collect(Collector& c, const point_type& q, Scalar) const {
    for (const auto& tree : trees_) {
      detail::OffsetCollector<Collector> shifted{c, static_cast<std::uint32_t>(tree->offset())};
      tree->search(shifted, q);
    }
  }

  void commit(std::size_t before) {
    if (points_.size() == before) return;
    // Merge the chain's tail with the new batch while the halving rule would break.
    std::size_t start = before;
    while (!trees_.empty() && trees_.back()->size() < 2 * (points_.size() - start)) {
      start = trees_.back()->offset();
      trees_.pop_back();
    }
    for (auto& tree : trees_)
      tree->rebase(points_.data());
    trees_.push_back(std::make_unique<detail::RangeTree<D, Scalar>>(
        points_.data(), start, points_.size() - start, params_));
  }

  std::vector<point_type> points_;
  KdTreeParams params_{};
  std::vector<std::unique_ptr<detail::RangeTree<D, Scalar>>> trees_;
};

}  // namespace rangenav
