#pragma once
// Door detection during mapping (paper 001 §III, Nieuwenhuisen et al.): doors are found where
// line segments in the dynamic readings of successive scans rotate about a common hinge.
//
//   1. The dynamic points of a scan (OccupancyGrid::integrate(): readings in transient cells, and
//      the mean points of seen-occupied cells that turned free, each set on its own) are
//      clustered by proximity, Eq. (1): C_i = {p | exists q in C_i : ||p - q|| < epsilon}.
//   2. In each cluster all point pairs farther apart than delta are candidate lines, Eq. (2). If
//      the largest angle between two of them exceeds `max_line_angle` the cluster is no line;
//      otherwise its mean line segment (mean direction through the cluster's centroid, as long as
//      the longest candidate) is a line object.
//   3. Line objects of length in [lambda_min, lambda_max] join a persistent set of potential door
//      leaves (a leaf seen again, with both end points close, is merged).
//   4. Two leaves with an end point in common, of similar length and at clearly different angles
//   (>= `min_opening_difference`) make a door; more leaves on the
//      same hinge widen its observed opening range; a door whose leaves span more than 180 deg is
//      rejected (office doors do not swing through). The common end point is taken where the two
//      leaves' lines cross, within `hinge_tolerance` of an end of both: the cells beside a hinge
//      are never transient (§III's neighbourhood test), so observed leaves stop short of it.
//      Given the grid (add(c, grid)), the hinge must also be held by it: an occupied cell within
//      `hinge_support_radius` (the door's frame), which rejects opposite leaves meeting tip to
//      tip in the free corridor.
// A door is its hinge position, leaf length, reference angle (global direction of the leaf at
// the smallest observed opening) and observed opening range [0, opening_max]. remove_doors()
// clears the cells the leaves sweep from the static grid, keeping the hinge cell occupied as the
// paper does.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <span>
#include <string_view>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/euclidean_clustering.hpp"
#include "rangenav/mapping/occupancy_grid.hpp"
#include "rangenav/search/kd_tree.hpp"

namespace rangenav {

/// Parameters of door detection (paper 001 §III.B).
struct DoorDetectionParams {
  double epsilon{0.1};                      ///< Eq. (1) clustering distance (m)
  double delta{0.3};                        ///< Eq. (2) minimal line length (m)
  double max_line_angle{deg_to_rad(10.0)};  ///< larger spread of candidate lines: no line
  double lambda_min{0.6};                   ///< door leaf length range (m)
  double lambda_max{1.2};                   ///< upper end of the door leaf length range (m)
  std::size_t min_points{5};                ///< clusters with fewer points are ignored
  double merge_tolerance{0.1};              ///< leaves with both end points this close are one (m)
  double hinge_tolerance{0.3};   ///< leaves crossing this close to an end share a hinge (m)
  double length_tolerance{0.2};  ///< leaves of one door differ at most this much (m)
  double min_opening_difference{deg_to_rad(20.0)};  ///< "clearly different" opening angles
  double max_opening{std::numbers::pi};             ///< doors rotating farther are rejected
  /// With a grid (add(c, grid), detect(&grid)): a hinge needs an occupied cell of the static
  /// grid this close (m); the door's frame holds it (§IV: "we represent the doors' hinge joints
  /// both as occupied cells in the grid map"). Two leaves meeting tip to tip in free space
  /// (opposite doors swung towards each other) are no door.
  double hinge_support_radius{0.15};

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where) const {
    detail::require_positive(where, "epsilon", epsilon);
    detail::require_positive(where, "delta", delta);
    detail::require_positive(where, "max_line_angle", max_line_angle);
    detail::require_positive(where, "lambda_min", lambda_min);
    if (!(lambda_max >= lambda_min))
      detail::throw_invalid_argument(where, "lambda_max", lambda_max,
                                     "must be >= lambda_min = " + detail::format_value(lambda_min));
    detail::require_positive(where, "merge_tolerance", merge_tolerance);
    detail::require_positive(where, "hinge_tolerance", hinge_tolerance);
    detail::require_positive(where, "length_tolerance", length_tolerance);
    detail::require_positive(where, "min_opening_difference", min_opening_difference);
    detail::require_positive(where, "max_opening", max_opening);
    detail::require_positive(where, "hinge_support_radius", hinge_support_radius);
  }
};

/// A line object: the mean line segment of a cluster of dynamic points.
struct LineObject {
  Point2d a{0, 0};              ///< one end of the mean segment (map frame)
  Point2d b{0, 0};              ///< the other end
  std::size_t points{0};        ///< cluster size
  std::size_t observations{1};  ///< times seen (merged)
  /// |b - a| (m).
  [[nodiscard]] double length() const { return (b - a).norm(); }
};

/// A detected door (paper 001 §III).
struct DoorModel {
  Point2d hinge{0, 0};        ///< the hinge (map frame)
  double leaf_length{0};      ///< the longest reach of a supporting leaf from the hinge
  double reference_angle{0};  ///< global direction of the leaf at opening 0
  double opening_min{0};      ///< observed opening range relative to the reference, rad
  double opening_max{0};      ///< upper end of the observed opening range, rad
  std::size_t leaves{0};      ///< leaves supporting the door

  /// The free end of the leaf at `opening` (relative to the reference angle).
  [[nodiscard]] Point2d leaf_end(double opening) const {
    const double a = reference_angle + opening;
    return hinge + leaf_length * Point2d(std::cos(a), std::sin(a));
  }
};

/// Eq. (1): clusters of points linked by chains of neighbours closer than epsilon (the radius
/// queries of a KdTree, followed by euclidean_clusters). Returns one cluster index per point;
/// clusters are numbered from 0 in order of their first point.
[[nodiscard]] inline std::vector<std::size_t> proximity_clusters(std::span<const Point2d> points,
                                                                 double epsilon) {
  detail::require_positive("proximity_clusters", "epsilon", epsilon);
  std::vector<std::size_t> label(points.size(), 0);
  if (points.empty()) return label;
  const KdTree<2> tree(std::vector<Point2d>(points.begin(), points.end()));
  EuclideanClusteringParams params;
  params.tolerance = epsilon;  // chains of distances < epsilon, Eq. (1)
  auto clusters = euclidean_clusters(tree, params);
  // Each cluster starts at its smallest index (its breadth-first seed): order by it.
  std::sort(clusters.begin(), clusters.end(),
            [](const auto& a, const auto& b) { return a.front() < b.front(); });
  for (std::size_t c = 0; c < clusters.size(); ++c)
    for (const std::uint32_t i : clusters[c])
      label[i] = c;
  return label;
}

/// Eq. (2) and the angle-consistency test on one cluster: the mean line segment, or nothing when
/// no pair is longer than delta or the candidate lines disagree by more than max_line_angle.
[[nodiscard]] inline bool mean_line_segment(std::span<const Point2d> cluster, double delta,
                                            double max_line_angle, LineObject& out) {
  const double delta_sq = delta * delta;
  // The longest pair sets the reference direction; every other candidate's direction is taken
  // relative to it (undirected lines: modulo pi).
  double longest_sq = 0;
  std::size_t ia = 0, ib = 0;
  for (std::size_t i = 0; i < cluster.size(); ++i)
    for (std::size_t j = i + 1; j < cluster.size(); ++j) {
      const double d_sq = (cluster[j] - cluster[i]).squaredNorm();
      if (d_sq > longest_sq) {
        longest_sq = d_sq;
        ia = i;
        ib = j;
      }
    }
  if (!(longest_sq > delta_sq)) return false;
  const Point2d ref = cluster[ib] - cluster[ia];
  const double ref_angle = std::atan2(ref.y(), ref.x());
  double lo = 0, hi = 0, sum = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < cluster.size(); ++i)
    for (std::size_t j = i + 1; j < cluster.size(); ++j) {
      const Point2d d = cluster[j] - cluster[i];
      if (!(d.squaredNorm() > delta_sq)) continue;
      double a = normalize_angle(std::atan2(d.y(), d.x()) - ref_angle);
      if (a > std::numbers::pi / 2) a -= std::numbers::pi;
      if (a < -std::numbers::pi / 2) a += std::numbers::pi;
      lo = std::min(lo, a);
      hi = std::max(hi, a);
      sum += a;
      ++n;
    }
  if (hi - lo > max_line_angle) return false;
  const double angle = ref_angle + sum / static_cast<double>(n);
  const Point2d u(std::cos(angle), std::sin(angle));
  Point2d centroid = Point2d::Zero();
  for (const auto& p : cluster)
    centroid += p;
  centroid /= static_cast<double>(cluster.size());
  const double half = std::sqrt(longest_sq) / 2;
  // Centred where the longest pair's projection is, as long as the longest pair.
  const double mid = ((cluster[ia] + cluster[ib]) / 2 - centroid).dot(u);
  out.a = centroid + (mid - half) * u;
  out.b = centroid + (mid + half) * u;
  out.points = cluster.size();
  out.observations = 1;
  return true;
}

/// Clears the cells each door's leaf sweeps over its observed opening range from the static grid
/// (they are not static), keeping the hinge cell.
inline void remove_doors(OccupancyGrid& grid, std::span<const DoorModel> doors) {
  const double r = grid.resolution();
  for (const auto& d : doors) {
    const double span = d.opening_max - d.opening_min;
    const int steps = std::max(1, static_cast<int>(std::ceil(span * d.leaf_length / (r / 2))));
    for (int k = 0; k <= steps; ++k) {
      const double opening = d.opening_min + span * k / steps;
      const Point2d end = d.leaf_end(opening);
      // Half a cell beyond the leaf's end and to either side of it.
      const Point2d u = (end - d.hinge).normalized(), n(-u.y(), u.x());
      for (const double side : {-0.5, 0.0, 0.5})
        grid.trace(d.hinge + n * (side * r), end + u * (r / 2) + n * (side * r),
                   [&](const OccupancyGrid::Index& c) {
                     if (grid.contains(c) && (grid.cell_center(c) - d.hinge).norm() > r)
                       grid.set_log_odds(c, log_odds(grid.params().min_probability));
                   });
    }
  }
}

/// Finds doors in the dynamic points of classified scans: line objects of door length that
/// turn about a common hinge (paper 001 §III.B).
class DoorDetector {
 public:
  /// A detector with these parameters; throws invalid_argument for invalid ones.
  explicit DoorDetector(const DoorDetectionParams& params = {}) : params_(params) {
    params_.validate("DoorDetector");
  }
  /// The parameters.
  [[nodiscard]] const DoorDetectionParams& params() const { return params_; }
  /// The line objects of door length found so far (potential door leaves).
  [[nodiscard]] const std::vector<LineObject>& potential_leaves() const { return leaves_; }
  /// The doors detected so far.
  [[nodiscard]] const std::vector<DoorModel>& doors() const { return doors_; }

  /// Extracts the line objects of one set of dynamic points (steps 1-2) into `lines`.
  void extract_lines(std::span<const Point2d> points, std::vector<LineObject>& lines) {
    lines.clear();
    if (points.empty()) return;
    const auto label = proximity_clusters(points, params_.epsilon);
    const std::size_t clusters = *std::max_element(label.begin(), label.end()) + 1;
    for (std::size_t c = 0; c < clusters; ++c) {
      cluster_.clear();
      for (std::size_t i = 0; i < points.size(); ++i)
        if (label[i] == c) cluster_.push_back(points[i]);
      if (cluster_.size() < params_.min_points) continue;
      LineObject line;
      if (mean_line_segment(cluster_, params_.delta, params_.max_line_angle, line))
        lines.push_back(line);
    }
  }

  /// Adds one scan's classification: lines from both sets of dynamic points, leaves of door
  /// length to the persistent set, then re-detects the doors (step 4). Returns the number of
  /// line objects found in this scan.
  std::size_t add(const ScanClassification& c) {
    const std::size_t found = add_leaves(c);
    detect();
    return found;
  }
  /// add() whose door detection also requires every hinge to be held by the static `grid`
  /// (DoorDetectionParams::hinge_support_radius); pass the grid the classification came from.
  std::size_t add(const ScanClassification& c, const OccupancyGrid& grid) {
    const std::size_t found = add_leaves(c);
    detect(&grid);
    return found;
  }

  /// Step 3 for a line object: keeps it if its length is within [lambda_min, lambda_max].
  void add_leaf(const LineObject& line) {
    const double len = line.length();
    if (len < params_.lambda_min || len > params_.lambda_max) return;
    const double tol_sq = params_.merge_tolerance * params_.merge_tolerance;
    for (auto& leaf : leaves_) {
      const bool same =
          ((leaf.a - line.a).squaredNorm() < tol_sq && (leaf.b - line.b).squaredNorm() < tol_sq) ||
          ((leaf.a - line.b).squaredNorm() < tol_sq && (leaf.b - line.a).squaredNorm() < tol_sq);
      if (!same) continue;
      // Running mean of the end points (orientation of the stored leaf kept).
      const bool flipped = (leaf.a - line.a).squaredNorm() > (leaf.a - line.b).squaredNorm();
      const double w = 1.0 / static_cast<double>(++leaf.observations);
      leaf.a += w * ((flipped ? line.b : line.a) - leaf.a);
      leaf.b += w * ((flipped ? line.a : line.b) - leaf.b);
      return;
    }
    leaves_.push_back(line);
  }

  /// Step 4 over the whole set of potential leaves; with a `grid`, hinges must be held by it.
  void detect(const OccupancyGrid* grid = nullptr) {
    doors_.clear();
    const double hinge_sq = params_.hinge_tolerance * params_.hinge_tolerance;
    used_.assign(leaves_.size(), 0);
    // Two leaves of one door lie on lines through the hinge: their intersection is the hinge
    // candidate, and it must be close to an end of both (the cells next to the hinge and the
    // jamb are never transient, so leaves seen in dynamic points stop short of the hinge).
    const auto pair_makes_door = [&](std::size_t i, std::size_t j) {
      const LineObject& li = leaves_[i];
      const LineObject& lj = leaves_[j];
      const Point2d di = li.b - li.a, dj = lj.b - lj.a;
      const double cross = di.x() * dj.y() - di.y() * dj.x();
      if (std::abs(cross) < 1e-9 * di.norm() * dj.norm()) return false;  // parallel
      const Point2d w = lj.a - li.a;
      const Point2d hinge = li.a + di * ((w.x() * dj.y() - w.y() * dj.x()) / cross);
      const auto near_end_sq = [&](const LineObject& l) {
        return std::min((l.a - hinge).squaredNorm(), (l.b - hinge).squaredNorm());
      };
      if (near_end_sq(li) >= hinge_sq || near_end_sq(lj) >= hinge_sq) return false;
      if (grid != nullptr && !held_by(*grid, hinge)) return false;
      return try_door(hinge, i, j);
    };
    for (std::size_t i = 0; i < leaves_.size(); ++i)
      for (std::size_t j = i + 1; j < leaves_.size() && !used_[i]; ++j)
        if (!used_[j]) pair_makes_door(i, j);
  }

  /// Clears the cells swept by the detected doors from the static grid (remove_doors()).
  void remove_doors(OccupancyGrid& grid) const { rangenav::remove_doors(grid, doors_); }

 private:
  /// Steps 1-3 for one scan: lines from both sets of dynamic points, leaves of door length kept.
  std::size_t add_leaves(const ScanClassification& c) {
    std::size_t found = 0;
    for (const auto* set : {&c.dynamic_points, &c.vanished_points}) {
      extract_lines(*set, lines_);
      found += lines_.size();
      for (const auto& line : lines_)
        add_leaf(line);
    }
    return found;
  }

  /// An occupied cell of `grid` within hinge_support_radius of `hinge`.
  [[nodiscard]] bool held_by(const OccupancyGrid& grid, const Point2d& hinge) const {
    const double r = params_.hinge_support_radius;
    const OccupancyGrid::Index lo = grid.cell_of(hinge - Point2d::Constant(r));
    const OccupancyGrid::Index hi = grid.cell_of(hinge + Point2d::Constant(r));
    for (int y = lo.y(); y <= hi.y(); ++y)
      for (int x = lo.x(); x <= hi.x(); ++x) {
        const OccupancyGrid::Index c(x, y);
        if (grid.contains(c) && grid.is_occupied(c) &&
            (grid.cell_center(c) - hinge).squaredNorm() <= r * r)
          return true;
      }
    return false;
  }

  /// Leaves i and j share `hinge`: a door if their lengths agree and their angles differ
  /// clearly; then every other leaf on that hinge widens the opening range.
  bool try_door(const Point2d& hinge, std::size_t i, std::size_t j) {
    const auto direction = [&](const LineObject& l) {
      const Point2d far = (l.a - hinge).squaredNorm() > (l.b - hinge).squaredNorm() ? l.a : l.b;
      return std::atan2(far.y() - hinge.y(), far.x() - hinge.x());
    };
    const auto reach = [&](const LineObject& l) {
      return std::sqrt(std::max((l.a - hinge).squaredNorm(), (l.b - hinge).squaredNorm()));
    };
    if (std::abs(reach(leaves_[i]) - reach(leaves_[j])) > params_.length_tolerance) return false;
    if (std::abs(angle_difference(direction(leaves_[i]), direction(leaves_[j]))) <
        params_.min_opening_difference)
      return false;
    // Collect all leaves on this hinge.
    const double hinge_sq = params_.hinge_tolerance * params_.hinge_tolerance;
    members_.clear();
    for (std::size_t k = 0; k < leaves_.size(); ++k) {
      const auto& l = leaves_[k];
      const double near_sq = std::min((l.a - hinge).squaredNorm(), (l.b - hinge).squaredNorm());
      if (near_sq < hinge_sq && std::abs(reach(l) - reach(leaves_[i])) <= params_.length_tolerance)
        members_.push_back(k);
    }
    // Opening angles relative to leaf i, unwrapped into (-pi, pi]; the reference is the
    // smallest.
    const double base = direction(leaves_[i]);
    double lo = 0, hi = 0, length = 0;
    for (const std::size_t k : members_) {
      const double a = angle_difference(direction(leaves_[k]), base);
      lo = std::min(lo, a);
      hi = std::max(hi, a);
      length = std::max(length, reach(leaves_[k]));
    }
    if (hi - lo > params_.max_opening) return false;
    DoorModel d;
    d.hinge = hinge;
    d.leaf_length = length;
    d.reference_angle = normalize_angle(base + lo);
    d.opening_min = 0;
    d.opening_max = hi - lo;
    d.leaves = members_.size();
    doors_.push_back(d);
    for (const std::size_t k : members_)
      used_[k] = 1;
    return true;
  }

  DoorDetectionParams params_;
  std::vector<LineObject> leaves_;
  std::vector<DoorModel> doors_;
  std::vector<LineObject> lines_;  ///< scratch
  std::vector<Point2d> cluster_;   ///< scratch
  std::vector<std::size_t> members_;
  std::vector<std::uint8_t> used_;
};

}  // namespace rangenav
