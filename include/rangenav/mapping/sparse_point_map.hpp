#pragma once
// Sparse point maps (paper 000 §3.3, Eq. (5); paper 002 §6.3, Eq. (12)): a registered point is
// added to the map only when no stored point lies within eps_D of it,
//   M_i = M_{i-1} ∪ { d | d ∈ D_i, ∄ m ∈ M_{i-1} : |d - m| < eps_D },
// which bounds the point density of the map. The test runs on the same index the ICP searches
// (a GridIndex2 in 2D, a GrowingKdTree in 3D, or the `Index` given), so the map is directly an
// ICP model.
//
// Eq. (5) only compares with the map before the scan; by default the new points are also
// thinned among themselves (deduplicate_within_scan), so that one dense scan does not store
// several points per eps_D ball. Set it to false for the literal Eq. (5).
//
// With `normals` set, the map also keeps a unit normal per stored point (PCA of its
// `normal_neighbors` nearest map points within `normal_radius`; zero when they do not form a line
// / plane: smallest / largest eigenvalue above `max_flatness`), refreshed for every point whose
// neighbourhood an insertion changed. PointToLineSolver uses them (an option beyond the papers).
// Each point keeps the indices of its k nearest, so a refreshed point's new k nearest are
// merged from them and the new points that came within its k-th neighbour's distance, without
// a k-NN query (the same neighbours as the query's, found without searching the map).
//
// Memory: one stored point costs sizeof(Point<D, Scalar>) (16 B in 2D, 24 B in 3D for double)
// plus the kd-tree's index (4 B) and nodes (about 2 nodes of ~40-60 B per 10-point leaf), i.e.
// about 30 B per point in 2D; memory_bytes() reports that exact figure. With normals, a point
// also holds its normal and 4 (normal_neighbors + 2) B of neighbour bookkeeping (not counted).

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <string_view>
#include <type_traits>
#include <unordered_map>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/pca.hpp"
#include "rangenav/search/grid_index.hpp"
#include "rangenav/search/kd_tree.hpp"

namespace rangenav {

/// Settings of a SparsePointMap: the density bound eps_D, the index, and the optional normals.
template <std::floating_point Scalar = double>
struct SparsePointMapParams {
  Scalar epsilon_d = Scalar(0.15);  ///< m, eps_D of Eq. (5); paper 000 Fig. 3 uses 15 cm
  /// Also thin a scan's new points among themselves, so one dense scan stores one point per
  /// eps_D ball; false gives the literal Eq. (5), which only compares with the map before it.
  bool deduplicate_within_scan = true;
  KdTreeParams tree{};                 ///< of a GrowingKdTree index
  GridIndexParams<Scalar> grid{};      ///< of a GridIndex2 index
  bool normals = false;                ///< keep a normal per stored point (see above)
  std::size_t normal_neighbors = 5;    ///< k of the normals' PCA
  Scalar normal_radius = Scalar(0.5);  ///< m, neighbours farther away are not used
  Scalar max_flatness = Scalar(0.1);   ///< eigenvalue ratio above which the normal is zero

  /// Throws invalid_argument naming the first bad field: epsilon_d not > 0, a bad grid, or (with
  /// normals) normal_neighbors < 2, normal_radius not > 0 or max_flatness < 0.
  void validate() const {
    constexpr std::string_view where = "SparsePointMap";
    detail::require_positive(where, "epsilon_d", epsilon_d);
    grid.validate();
    if (normals) {
      if (normal_neighbors < static_cast<std::size_t>(2))
        detail::throw_invalid_argument(where, "normal_neighbors", normal_neighbors, "must be >= 2");
      detail::require_positive(where, "normal_radius", normal_radius);
      detail::require_non_negative(where, "max_flatness", max_flatness);
    }
  }
};

/// What one insertion did.
struct SparseInsertStats {
  std::size_t offered = 0;  ///< finite points offered
  std::size_t stored = 0;   ///< points added to the map
};

/// The default map index: the 2D grid in 2D (faster on laser maps, see grid_index.hpp), the
/// growing kd-tree in 3D.
template <int D, class Scalar>
using DefaultMapIndex = std::conditional_t<D == 2, GridIndex2<Scalar>, GrowingKdTree<D, Scalar>>;

/// A point map of bounded density (Eq. (5), see the file comment) that is directly an ICP model:
/// search() is the index the insertions test against. D is 2 or 3; `Index` is any index with
/// incremental insertion (GridIndex2, GrowingKdTree, or one of the same interface).
template <int D, std::floating_point Scalar = double, class Index = DefaultMapIndex<D, Scalar>>
class SparsePointMap {
 public:
  static constexpr int dimension = D;           ///< 2 or 3
  using scalar_type = Scalar;                   ///< coordinate type
  using index_type = Index;                     ///< the search structure search() returns
  using point_type = Point<D, Scalar>;          ///< a stored point (map frame, m)
  using transform_type = Transform<D, Scalar>;  ///< a scan's pose, scan frame -> map frame

  /// Throws invalid_argument for bad params (see SparsePointMapParams::validate()).
  explicit SparsePointMap(SparsePointMapParams<Scalar> params = {})
      : params_((params.validate(), params)), tree_(make_index(params)) {}

  /// Transforms the points of `cloud` by `pose` (cloud frame -> map frame) and stores those with
  /// no map point within eps_D (Eq. (5)). Throws invalid_argument for a non-rigid pose.
  template <PointCloudOf<D> C>
  SparseInsertStats insert(const C& cloud,
                           const transform_type& pose = transform_type::Identity()) {
    return insert(cloud, pose, {});
  }

  /// No hint for a point (see the three-argument insert()).
  static constexpr std::uint32_t no_hint = std::numeric_limits<std::uint32_t>::max();

  /// insert(cloud, pose) with a hint per cloud point: the index of a stored point that may lie
  /// within eps_D of it (e.g. its last ICP correspondence), or no_hint; an empty span gives no
  /// hints. A hinted point within eps_D proves Eq. (5)'s test without a search; the stored
  /// points are those of insert(cloud, pose).
  template <PointCloudOf<D> C>
  SparseInsertStats insert(const C& cloud, const transform_type& pose,
                           std::span<const std::uint32_t> near_hint) {
    if (!is_rigid(pose, rigid_tolerance<Scalar>))
      detail::throw_invalid("SparsePointMap::insert",
                            "argument 'pose' is not a finite rigid transform");
    const Scalar eps_sq = params_.epsilon_d * params_.epsilon_d;
    SparseInsertStats stats;
    candidates_.clear();
    const std::size_t n = traits::size(cloud);
    for (std::size_t i = 0; i < n; ++i) {
      const point_type p = pose * traits::point(cloud, i).template cast<Scalar>();
      if (!p.allFinite()) continue;
      ++stats.offered;
      if (i < near_hint.size() && near_hint[i] < tree_.size() &&
          (tree_.point(near_hint[i]) - p).squaredNorm() < eps_sq)
        continue;
      if (!tree_.nearest(p, eps_sq)) candidates_.push_back(p);
    }
    if (params_.deduplicate_within_scan) thin_candidates(eps_sq);
    stats.stored = candidates_.size();
    if (!candidates_.empty()) {
      const std::size_t before = tree_.size();
      tree_.insert(candidates_);
      if (params_.normals) update_normals(before);
    }
    offered_ += stats.offered;
    return stats;
  }

  /// The map as a search structure (an ICP model).
  [[nodiscard]] const Index& search() const { return tree_; }
  /// The stored points (map frame), in insertion order; indices match the index's.
  [[nodiscard]] const std::vector<point_type>& points() const { return tree_.points(); }
  /// Unit normals of the stored points (zero where there is no line / plane), indexed like
  /// points(); empty unless SparsePointMapParams::normals.
  [[nodiscard]] const std::vector<point_type>& normals() const { return normals_; }
  /// Number of stored points.
  [[nodiscard]] std::size_t size() const { return tree_.size(); }
  /// True before the first point is stored.
  [[nodiscard]] bool empty() const { return tree_.empty(); }
  /// Finite points offered to insert() so far.
  [[nodiscard]] std::size_t points_offered() const { return offered_; }
  /// Bytes held by the stored points and the search structure.
  [[nodiscard]] std::size_t memory_bytes() const { return tree_.memory_bytes(); }
  /// The settings the map was built with.
  [[nodiscard]] const SparsePointMapParams<Scalar>& params() const { return params_; }

 private:
  static Index make_index(const SparsePointMapParams<Scalar>& p) {
    if constexpr (std::is_constructible_v<Index, GridIndexParams<Scalar>>)
      return Index(p.grid);
    else if constexpr (std::is_constructible_v<Index, KdTreeParams>)
      return Index(p.tree);
    else
      return Index();
  }

  // Normals of the new points [first, size) and of every stored point whose k nearest
  // neighbours changed. A stored point's k-NN (within normal_radius) changes exactly when a
  // new point comes closer than its `reach` (its k-th neighbour's distance, or normal_radius
  // while it has fewer than k), so only those are recomputed. They are found by a radius query
  // of normal_radius / 2 around each new point, plus, for the few stored points whose reach
  // exceeds that ("wide" points, kept in their own index), a normal_radius query of that
  // index; each such pair (stored point, new point closer than its reach) is recorded. A
  // stored point's new k-NN are then the k nearest of its previous k-NN (kept per point) and
  // its recorded new points, without a search. The k-NN of a new point are the k nearest of
  // its half-radius neighbourhood when it holds k points, else a k-NN query's.
  void update_normals(std::size_t first) {
    const Scalar radius_sq = params_.normal_radius * params_.normal_radius;
    const Scalar near_sq = radius_sq / 4;
    const std::size_t size = tree_.size();
    const std::size_t k = params_.normal_neighbors;
    normals_.resize(size, point_type::Zero());
    reach_sq_.resize(size, radius_sq);
    neighbor_count_.resize(size, 0);
    neighbor_index_.resize(size * k);
    touched_head_.assign(first, no_touch);
    touched_.clear();
    const auto closer = [](const Neighbor<Scalar>& a, const Neighbor<Scalar>& b) {
      return a.distance_sq < b.distance_sq || (a.distance_sq == b.distance_sq && a.index < b.index);
    };
    // Stored point j may now have new point i among its k-NN.
    const auto mark = [&](std::uint32_t j, std::size_t i, Scalar distance_sq) {
      if (j < first && distance_sq < reach_sq_[j]) {
        touched_.push_back({static_cast<std::uint32_t>(i), distance_sq, touched_head_[j]});
        touched_head_[j] = static_cast<std::uint32_t>(touched_.size() - 1);
      }
    };
    for (std::size_t i = first; i < size; ++i) {
      const point_type& q = tree_.point(i);
      if (!wide_.empty()) {
        wide_.radius(q, radius_sq, neighbors_, false);
        for (const auto& nb : neighbors_)
          mark(wide_index_[nb.index], i, nb.distance_sq);
      }
      // Only which points are near matters here, not their order.
      if constexpr (requires { tree_.radius(q, near_sq, neighbors_, false); })
        tree_.radius(q, near_sq, neighbors_, false);
      else
        tree_.radius(q, near_sq, neighbors_);
      for (const auto& nb : neighbors_)
        mark(nb.index, i, nb.distance_sq);
      if (neighbors_.size() >= k) {
        // A total order (ties by index): the k first are those of a partial sort; a full sort
        // of the dozen or so near points is cheaper.
        std::sort(neighbors_.begin(), neighbors_.end(), closer);
        neighbors_.resize(k);
      } else {
        tree_.knn(q, k, neighbors_, radius_sq);
      }
      normals_[i] = normal_of_neighbors(i, radius_sq);
    }
    for (std::size_t j = 0; j < first; ++j) {
      if (touched_head_[j] == no_touch) continue;
      // Its k-NN: the nearest of its previous k-NN (distances summed per axis in order, as the
      // kd-tree's metric does) and the new points recorded for it (a wide point near a new one
      // is recorded twice, hence the unique).
      const point_type& p = tree_.point(j);
      neighbors_.clear();
      for (std::size_t m = 0; m < neighbor_count_[j]; ++m) {
        const std::uint32_t index = neighbor_index_[j * k + m];
        const point_type& o = tree_.point(index);
        Scalar d_sq = 0;
        for (int d = 0; d < D; ++d)
          d_sq += (p[d] - o[d]) * (p[d] - o[d]);
        neighbors_.push_back({index, d_sq});
      }
      for (std::uint32_t t = touched_head_[j]; t != no_touch; t = touched_[t].next)
        neighbors_.push_back({touched_[t].index, touched_[t].distance_sq});
      std::sort(neighbors_.begin(), neighbors_.end(), closer);
      neighbors_.erase(std::unique(neighbors_.begin(), neighbors_.end()), neighbors_.end());
      if (neighbors_.size() > k) neighbors_.resize(k);
      normals_[j] = normal_of_neighbors(j, radius_sq);
    }
    // A reach only shrinks as points are added: the wide points are among the new ones.
    wide_batch_.clear();
    for (std::size_t i = first; i < size; ++i)
      if (reach_sq_[i] >= near_sq) {
        wide_batch_.push_back(tree_.point(i));
        wide_index_.push_back(static_cast<std::uint32_t>(i));
      }
    if (!wide_batch_.empty()) wide_.insert(wide_batch_);
  }

  // The PCA normal of point i from its k nearest neighbours in neighbors_ (ascending); records
  // its reach (see update_normals).
  point_type normal_of_neighbors(std::size_t i, Scalar radius_sq) {
    const std::size_t k = neighbors_.size();
    reach_sq_[i] = k == params_.normal_neighbors ? neighbors_.back().distance_sq : radius_sq;
    neighbor_count_[i] = static_cast<std::uint32_t>(k);
    for (std::size_t m = 0; m < k; ++m)
      neighbor_index_[i * params_.normal_neighbors + m] = neighbors_[m].index;
    if (k < static_cast<std::size_t>(D)) return point_type::Zero();
    const PcaFit<D, Scalar> fit = fit_pca<D, Scalar>(
        k, [&](std::size_t m) -> const point_type& { return tree_.point(neighbors_[m].index); });
    const auto& values = fit.eigenvalues;
    if (!(values(D - 1) > Scalar(0)) || values(0) > params_.max_flatness * values(D - 1))
      return point_type::Zero();
    const point_type n = fit.normal().normalized();
    return n.allFinite() ? n : point_type::Zero();
  }

  // Greedy thinning of the candidates among themselves on a hashed grid of cell eps_D: a
  // candidate is kept when no kept candidate in the 3^D surrounding cells is within eps_D.
  void thin_candidates(Scalar eps_sq) {
    if (candidates_.size() < 2) return;
    grid_.clear();
    kept_.clear();
    next_.clear();
    const Scalar inv = Scalar(1) / params_.epsilon_d;
    const auto cell_of = [&](const point_type& p) {
      Eigen::Matrix<std::int64_t, D, 1> c;
      for (int d = 0; d < D; ++d)
        c[d] = static_cast<std::int64_t>(std::floor(p[d] * inv));
      return c;
    };
    const auto key_of = [](const Eigen::Matrix<std::int64_t, D, 1>& c) {
      std::uint64_t key = 0;
      for (int d = 0; d < D; ++d)
        key = key * 0x9E3779B97F4A7C15ull + static_cast<std::uint64_t>(c[d]);
      return key;
    };
    for (const point_type& p : candidates_) {
      const auto c = cell_of(p);
      bool near = false;
      for (int offset = 0; offset < (D == 2 ? 9 : 27) && !near; ++offset) {
        Eigen::Matrix<std::int64_t, D, 1> nc = c;
        int o = offset;
        for (int d = 0; d < D; ++d, o /= 3)
          nc[d] += o % 3 - 1;
        const auto it = grid_.find(key_of(nc));
        for (std::uint32_t k = it == grid_.end() ? UINT32_MAX : it->second; k != UINT32_MAX;
             k = next_[k])
          if ((kept_[k] - p).squaredNorm() < eps_sq) {
            near = true;
            break;
          }
      }
      if (near) continue;
      const auto key = key_of(c);
      const auto [it, fresh] = grid_.try_emplace(key, static_cast<std::uint32_t>(kept_.size()));
      next_.push_back(fresh ? UINT32_MAX : it->second);
      if (!fresh) it->second = static_cast<std::uint32_t>(kept_.size());
      kept_.push_back(p);
    }
    candidates_.swap(kept_);
  }

  SparsePointMapParams<Scalar> params_;
  Index tree_;
  std::size_t offered_ = 0;
  std::vector<point_type> candidates_, kept_;
  std::unordered_map<std::uint64_t, std::uint32_t> grid_;
  std::vector<std::uint32_t> next_;
  std::vector<point_type> normals_;
  std::vector<Scalar> reach_sq_;   ///< per point: squared distance of its k-th normal neighbour
  GrowingKdTree<D, Scalar> wide_;  ///< points whose reach exceeds normal_radius / 2
  std::vector<std::uint32_t> wide_index_;  ///< their indices in the map
  std::vector<point_type> wide_batch_;
  std::vector<Neighbor<Scalar>> neighbors_;
  /// Per stored point: the count and the indices (normal_neighbors slots) of its k-NN.
  std::vector<std::uint32_t> neighbor_count_, neighbor_index_;
  /// A new point closer to a stored point than its reach (see update_normals); the records of
  /// one stored point are chained from touched_head_.
  struct Touch {
    std::uint32_t index;
    Scalar distance_sq;
    std::uint32_t next;
  };
  static constexpr std::uint32_t no_touch = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> touched_head_;
  std::vector<Touch> touched_;
};

}  // namespace rangenav
