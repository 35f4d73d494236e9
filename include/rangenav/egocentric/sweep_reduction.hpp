#pragma once
// The processing steps that paper 002 §6.1 (Fig. 9) applies to every 2D scan of the pitching
// scanner's nodding movement, after Surmann et al. (2003), to turn one sweep into a compact
// description of its structures:
//   1. the point density of each scan is reduced by replacing clusters of consecutive points whose
//      distance to each other falls below a threshold by their centroid
//      (reduce_to_cluster_centroids);
//   2. line segments are detected in the residual points of each scan (detect_line_segments):
//      a line grows from its first point as long as consecutive points stay within max_gap and
//      the ratio of the direct distance to the length of the polyline through its points,
//      ||a_i a_j|| / sum_k ||a_k a_k+1||, stays above min_ratio (Surmann et al.); each grown run
//      is then split at its farthest point from the chord while that lies more than
//      max_distance away (iterative end-point fit, so a corner ends a line even when one leg is
//      short), and every piece with enough points and length gets a total-least-squares line;
//   3. line segments of consecutive scans are merged into planes (region growing over the
//      sweep: a line joins the plane whose last line lies next to it and whose fitted plane it
//      lies in, else it starts a new one; planes are refitted by least squares);
//   4. points are classified whether or not they belong to the floor, with the neighbourhood
//      classification of §4.2 (egocentric/floor.hpp) on the sweep's organised cloud; a centroid
//      is floor when most of its cluster is.
// SweepReducer runs all four on a Sweep (egocentric/pitching_stream.hpp) and keeps its buffers,
// so reducing one sweep after the other allocates nothing once the buffers have grown.
// Paper 002 only names the four steps and refers to Surmann et al. for the details; choices of
// ours: exact pairwise cluster distances, the split-and-merge refinement after the ratio growth,
// the region-growing criteria of step 3 (endpoint distance to the fitted plane, proximity to and
// direction of the plane's last line, planes reported from min_scans scans on), centroids and
// lines labelled floor by majority, and every default value.

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <numbers>
#include <span>
#include <string_view>
#include <utility>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/egocentric/floor.hpp"
#include "rangenav/egocentric/pitching_stream.hpp"
#include "rangenav/geometry/pca.hpp"

namespace rangenav {

// ---- step 1: cluster centroids ---------------------------------------------------------------

/// §6.1 step 1: walks the points in scan order and replaces every cluster of consecutive points
/// whose distances to each other all stay below `max_distance` by its centroid; non-finite points
/// end a cluster and are dropped. Appends the centroids to `out` and, when `sizes` is given, the
/// number of points behind each; returns the number of centroids.
template <int D, std::floating_point Scalar>
std::size_t reduce_to_cluster_centroids(std::span<const Point<D, Scalar>> points,
                                        Scalar max_distance, std::vector<Point<D, Scalar>>& out,
                                        std::vector<std::size_t>* sizes = nullptr) {
  detail::require_positive("reduce_to_cluster_centroids", "max_distance", max_distance);
  const Scalar limit_sq = max_distance * max_distance;
  const std::size_t before = out.size();
  std::size_t first = 0, n = 0;
  const auto flush = [&]() {
    if (n == 0) return;
    Point<D, Scalar> sum = Point<D, Scalar>::Zero();
    for (std::size_t k = first; k < first + n; ++k)
      sum += points[k];
    out.push_back(sum / static_cast<Scalar>(n));
    if (sizes != nullptr) sizes->push_back(n);
    n = 0;
  };
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Point<D, Scalar>& p = points[i];
    if (!p.allFinite()) {
      flush();
      continue;
    }
    bool joins = n > 0;
    for (std::size_t k = first; joins && k < first + n; ++k)
      joins = (p - points[k]).squaredNorm() < limit_sq;
    if (!joins) {
      flush();
      first = i;
    }
    ++n;
  }
  flush();
  return out.size() - before;
}

// ---- step 2: line segments -------------------------------------------------------------------

/// A line segment found in one scan: the total-least-squares line through its points, from the
/// projection of its first point (a) to that of its last point (b).
template <int D, std::floating_point Scalar = double>
struct LineSegment {
  Point<D, Scalar> a{
      Point<D, Scalar>::Zero()};  ///< the projection of the first point onto the line
  Point<D, Scalar> b{Point<D, Scalar>::Zero()};  ///< the projection of the last point onto the line
  Point<D, Scalar> centroid{Point<D, Scalar>::Zero()};   ///< the mean of its points
  Point<D, Scalar> direction{Point<D, Scalar>::Zero()};  ///< unit, from a to b
  Scalar rms{0};  ///< root-mean-square orthogonal distance of its points (m)
  /// Its points are first, ..., first + count - 1 of the input (SweepReducer: the first beam
  /// of its scan and the number of readings behind it).
  std::size_t first{0};
  std::size_t count{0};     ///< number of points
  std::size_t row{0};       ///< the scan it came from (SweepReducer)
  std::size_t plane{npos};  ///< the plane it was merged into (SweepReducer), or npos
  bool floor{false};        ///< most of its points are floor (SweepReducer)

  /// "No plane".
  static constexpr std::size_t npos = static_cast<std::size_t>(-1);
  /// |b - a| (m).
  [[nodiscard]] Scalar length() const { return (b - a).norm(); }
};

/// Parameters of the line-segment detection (Surmann et al. 2003, paper 002 §6.1 step 2).
template <std::floating_point Scalar = double>
struct LineDetectionParams {
  /// m; consecutive points farther apart end a line.
  Scalar max_gap{Scalar(0.2)};
  /// The ratio of the direct distance from a line's first point to the length of the polyline
  /// through its points must stay at or above this (Surmann et al.: close to 1).
  Scalar min_ratio{Scalar(0.9)};
  /// m; a run is split at its farthest point from the chord while that is farther than this.
  Scalar max_distance{Scalar(0.015)};
  /// Shorter pieces are no lines.
  std::size_t min_points{5};
  Scalar min_length{Scalar(0.1)};  ///< m; shorter lines are dropped

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where = "LineDetectionParams") const {
    detail::require_positive(where, "max_gap", max_gap);
    detail::require_finite(where, "min_ratio", min_ratio);
    if (!(min_ratio > Scalar(0) && min_ratio <= Scalar(1)))
      detail::throw_invalid_argument(where, "min_ratio", min_ratio, "must lie in (0, 1]");
    detail::require_positive(where, "max_distance", max_distance);
    if (min_points < 2)
      detail::throw_invalid_argument(where, "min_points", min_points, "must be >= 2");
    detail::require_non_negative(where, "min_length", min_length);
  }
};

namespace detail {

/// Squared distance of p from the line through a and b (from a when a == b).
template <int D, std::floating_point Scalar>
[[nodiscard]] Scalar distance_to_chord_sq(const Point<D, Scalar>& p, const Point<D, Scalar>& a,
                                          const Point<D, Scalar>& b) {
  const Point<D, Scalar> ab = b - a, ap = p - a;
  const Scalar len_sq = ab.squaredNorm();
  if (!(len_sq > Scalar(0))) return ap.squaredNorm();
  const Scalar t = ap.dot(ab);
  return std::max(Scalar(0), ap.squaredNorm() - t * t / len_sq);
}

/// The total-least-squares line through points[first, first + count): centroid and principal
/// direction of the scatter matrix; endpoints are the projections of the first and last point.
template <int D, std::floating_point Scalar>
[[nodiscard]] LineSegment<D, Scalar> fit_line_segment(std::span<const Point<D, Scalar>> points,
                                                      std::size_t first, std::size_t count) {
  using Vec = Point<D, Scalar>;
  LineSegment<D, Scalar> s;
  s.first = first;
  s.count = count;
  const PcaFit<D, Scalar> fit = fit_pca<D, Scalar>(points.subspan(first, count));
  const Vec& c = fit.mean;
  Vec dir = fit.principal_direction();
  const Vec& p0 = points[first];
  const Vec& p1 = points[first + count - 1];
  if (dir.dot(p1 - p0) < Scalar(0)) dir = -dir;
  s.centroid = c;
  s.direction = dir;
  s.a = c + dir * dir.dot(p0 - c);
  s.b = c + dir * dir.dot(p1 - c);
  s.rms = std::sqrt(std::max(Scalar(0), fit.covariance.trace() - fit.eigenvalues(D - 1)));
  return s;
}

}  // namespace detail

/// Scratch space of detect_line_segments, reused across calls.
struct LineDetectionScratch {
  std::vector<std::size_t> stack;   ///< index ranges still to split
  std::vector<std::size_t> pieces;  ///< index ranges [s, e] after splitting, in scan order
};

namespace detail {
/// The farthest point of points[s, e] from the chord points[s]-points[e] (squared distance).
template <int D, std::floating_point Scalar>
[[nodiscard]] std::pair<std::size_t, Scalar> farthest_from_chord(
    std::span<const Point<D, Scalar>> points, std::size_t s, std::size_t e) {
  Scalar worst = 0;
  std::size_t at = s;
  for (std::size_t k = s + 1; k < e; ++k) {
    const Scalar d = distance_to_chord_sq(points[k], points[s], points[e]);
    if (d > worst) {
      worst = d;
      at = k;
    }
  }
  return {at, worst};
}
}  // namespace detail

/// §6.1 step 2 on the points of one scan in scan order (non-finite points end a line): appends
/// the line segments found to `out` (with first / count indexing `points`) and returns how many.
/// Runs grown by the gap and ratio criteria are split at their farthest point from the chord
/// while it lies beyond max_distance, and adjacent pieces are merged again where their union
/// passes the same test (split-and-merge: the ratio criterion ends a run only some points after
/// a corner).
template <int D, std::floating_point Scalar>
std::size_t detect_line_segments(std::span<const Point<D, Scalar>> points,
                                 const LineDetectionParams<Scalar>& params,
                                 std::vector<LineSegment<D, Scalar>>& out,
                                 LineDetectionScratch& scratch) {
  params.validate("detect_line_segments");
  const std::size_t n = points.size();
  const std::size_t before = out.size();
  const Scalar gap_sq = params.max_gap * params.max_gap;
  const Scalar split_sq = params.max_distance * params.max_distance;
  const Scalar min_length_sq = params.min_length * params.min_length;
  std::vector<std::size_t>& stack = scratch.stack;
  std::vector<std::size_t>& pieces = scratch.pieces;
  pieces.clear();
  std::size_t i = 0;
  while (i < n) {
    if (!points[i].allFinite()) {
      ++i;
      continue;
    }
    // Grow by the gap and the ratio criterion of Surmann et al.
    const std::size_t start = i;
    Scalar path = 0;
    std::size_t end = i;
    while (end + 1 < n) {
      const Point<D, Scalar>& q = points[end + 1];
      if (!q.allFinite()) break;
      const Scalar step_sq = (q - points[end]).squaredNorm();
      if (step_sq > gap_sq) break;
      const Scalar next_path = path + std::sqrt(step_sq);
      if ((q - points[start]).norm() < params.min_ratio * next_path) break;
      path = next_path;
      ++end;
    }
    // Split the run at its farthest point from the chord (iterative end-point fit).
    stack.clear();
    stack.push_back(start);
    stack.push_back(end);
    while (!stack.empty()) {
      const std::size_t e = stack.back();
      stack.pop_back();
      const std::size_t s = stack.back();
      stack.pop_back();
      const auto [at, worst] = detail::farthest_from_chord(points, s, e);
      if (worst > split_sq) {  // the later piece first, so pieces come out in scan order
        stack.push_back(at);
        stack.push_back(e);
        stack.push_back(s);
        stack.push_back(at);
      } else {
        pieces.push_back(s);
        pieces.push_back(e);
      }
    }
    i = end + 1;
  }
  // Merge adjacent pieces whose union is still straight, then fit and emit.
  const auto emit = [&](std::size_t s, std::size_t e) {
    const std::size_t count = e - s + 1;
    if (count < params.min_points) return;
    if ((points[e] - points[s]).squaredNorm() < min_length_sq) return;
    out.push_back(detail::fit_line_segment(points, s, count));
  };
  for (std::size_t k = 0; k < pieces.size(); k += 2) {
    std::size_t s = pieces[k], e = pieces[k + 1];
    while (k + 2 < pieces.size()) {
      const std::size_t s2 = pieces[k + 2], e2 = pieces[k + 3];
      const bool adjacent =
          s2 <= e + 1 && (s2 == e || (points[s2] - points[e]).squaredNorm() <= gap_sq);
      if (!adjacent || detail::farthest_from_chord(points, s, e2).second > split_sq) break;
      e = e2;
      k += 2;
    }
    emit(s, e);
  }
  return out.size() - before;
}

/// The same with scratch space of its own.
template <int D, std::floating_point Scalar>
std::size_t detect_line_segments(std::span<const Point<D, Scalar>> points,
                                 const LineDetectionParams<Scalar>& params,
                                 std::vector<LineSegment<D, Scalar>>& out) {
  LineDetectionScratch scratch;
  return detect_line_segments(points, params, out, scratch);
}

// ---- step 3: planes --------------------------------------------------------------------------

/// A plane merged from the line segments of consecutive scans: n . p = distance with |n| = 1,
/// fitted by total least squares to the lines' endpoints (weighted by their point counts).
template <std::floating_point Scalar = double>
struct PlaneSegment {
  Point<3, Scalar> normal{0, 0, 1};  ///< unit normal n
  Scalar distance{0};                ///< n . p = distance on the plane (m)
  /// the weighted mean of the lines' endpoints
  Point<3, Scalar> centroid{Point<3, Scalar>::Zero()};
  Scalar rms{0};  ///< root-mean-square distance of the lines' endpoints from the plane (m)
  std::size_t line_count{0};   ///< lines merged into the plane
  std::size_t scan_count{0};   ///< scans contributing lines
  std::size_t point_count{0};  ///< readings behind those lines
  std::size_t first_row{0};    ///< the first scan contributing lines
  std::size_t last_row{0};     ///< the last scan contributing lines
  bool floor{false};           ///< most of its lines are floor lines

  /// n . p - distance: positive on the side the normal points to (m).
  [[nodiscard]] Scalar signed_distance(const Point<3, Scalar>& p) const {
    return normal.dot(p) - distance;
  }
};

/// Parameters of merging the lines of consecutive scans into planes (paper 002 §6.1 step 3).
template <std::floating_point Scalar = double>
struct PlaneMergeParams {
  /// m; a line joins a plane only if both its endpoints lie this close to the fitted plane (or,
  /// while the plane has one line, to the plane through that line and this one).
  Scalar max_distance{Scalar(0.04)};
  /// m; ... and if it passes this close to the plane's most recent line (region growing) ...
  Scalar max_line_distance{Scalar(0.3)};
  /// rad; ... and runs within this angle of it (lines of one plane turn slowly from scan to scan;
  /// this also keeps two walls meeting in a corner apart while a plane has a single line).
  Scalar max_angle{deg_to_rad(Scalar(15))};
  /// The plane's most recent line is at most this many scans back.
  std::size_t max_row_gap{3};
  /// Planes whose lines come from fewer scans are not reported (all lines of one scan lie in its
  /// measurement plane, and lines of two neighbouring scans leave the tilt poorly determined).
  std::size_t min_scans{3};

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where = "PlaneMergeParams") const {
    detail::require_positive(where, "max_distance", max_distance);
    detail::require_positive(where, "max_line_distance", max_line_distance);
    detail::require_positive(where, "max_angle", max_angle);
    if (max_row_gap < 1)
      detail::throw_invalid_argument(where, "max_row_gap", max_row_gap, "must be >= 1");
    if (min_scans < 2)
      detail::throw_invalid_argument(where, "min_scans", min_scans, "must be >= 2");
  }
};

// ---- the four steps on a sweep ---------------------------------------------------------------

/// Parameters of the four per-scan steps of paper 002 §6.1 on a sweep.
template <std::floating_point Scalar = double>
struct SweepReductionParams {
  /// Step 1: m, the largest distance between two points of one cluster.
  Scalar cluster_distance{Scalar(0.05)};
  LineDetectionParams<Scalar> lines{};    ///< step 2: line segments
  PlaneMergeParams<Scalar> planes{};      ///< step 3: planes
  FloorClassifierParams<Scalar> floor{};  ///< step 4: floor classification

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where = "SweepReductionParams") const {
    detail::require_positive(where, "cluster_distance", cluster_distance);
    lines.validate(where);
    planes.validate(where);
    floor.validate(where);
  }
};

/// What SweepReducer made of one sweep; every coordinate in the sweep's base frame.
template <std::floating_point Scalar = double>
struct SweepReduction {
  /// Step 1 centroids that are not floor (Fig. 9: the reduced set of points without the floor).
  std::vector<Point<3, Scalar>> points;
  /// Step 1 centroids classified as floor (step 4).
  std::vector<Point<3, Scalar>> floor_points;
  /// Step 2 line segments of every scan, in scan order; their `plane` indexes `planes`.
  std::vector<LineSegment<3, Scalar>> lines;
  /// Step 3 planes with lines from at least min_scans scans.
  std::vector<PlaneSegment<Scalar>> planes;
  /// Valid readings of the sweep.
  std::size_t input_points{0};

  /// Valid readings per reduced point (step 1, floor included).
  [[nodiscard]] double reduction_ratio() const {
    const std::size_t kept = points.size() + floor_points.size();
    return kept == 0 ? 0.0 : static_cast<double>(input_points) / static_cast<double>(kept);
  }
};

/// Runs the four steps of §6.1 on sweeps (see the file comment). Not thread-safe (scratch space).
template <std::floating_point Scalar = double>
class SweepReducer {
 public:
  /// A 3D point.
  using Vec3 = Point<3, Scalar>;

  /// A reducer with these parameters; throws invalid_argument for invalid ones.
  explicit SweepReducer(const SweepReductionParams<Scalar>& params = {}) : params_(params) {
    params_.validate("SweepReducer");
  }

  /// The parameters.
  [[nodiscard]] const SweepReductionParams<Scalar>& params() const { return params_; }

  /// Reduces one sweep into `out` (its vectors are cleared and reused).
  void reduce(const Sweep<Scalar>& sweep, SweepReduction<Scalar>& out) {
    out.points.clear();
    out.floor_points.clear();
    out.lines.clear();
    out.planes.clear();
    out.input_points = 0;
    const std::size_t width = sweep.cloud.width;
    const std::size_t height = sweep.cloud.height;
    if (width == 0 || height == 0) return;
    if (sweep.cloud.points.size() != width * height)
      detail::throw_invalid_argument(
          "SweepReducer::reduce", "sweep.cloud.points.size()", sweep.cloud.points.size(),
          "must equal width * height = " + std::to_string(width * height));
    const std::span<const Vec3> grid(sweep.cloud.points);
    open_.clear();
    all_planes_.clear();
    for (std::size_t r = 0; r < height; ++r) {
      // The row's sensor origin gives each reading its own noise threshold (floor.hpp).
      const Vec3* origin = sweep.origins.size() == height ? &sweep.origins[r] : nullptr;
      // Step 4 on the organised sweep (it needs the neighbouring scans), step 1 per scan.
      centroids_.clear();
      sizes_.clear();
      columns_.clear();
      floor_votes_.clear();
      std::size_t c = 0;
      while (c < width) {
        const Vec3& p = grid[r * width + c];
        if (!p.allFinite()) {
          ++c;
          continue;
        }
        // One cluster: consecutive finite points all closer than cluster_distance.
        const std::size_t first = c;
        std::size_t floor_count = 0;
        Vec3 sum = Vec3::Zero();
        while (c < width) {
          const Vec3& q = grid[r * width + c];
          if (!q.allFinite()) break;
          bool joins = true;
          for (std::size_t k = first; joins && k < c; ++k)
            joins = (q - grid[r * width + k]).squaredNorm() <
                    params_.cluster_distance * params_.cluster_distance;
          if (!joins) break;
          sum += q;
          if (classify_point(grid, width, height, r, c, params_.floor, origin) == PointClass::floor)
            ++floor_count;
          ++c;
        }
        const std::size_t n = c - first;
        out.input_points += n;
        centroids_.push_back(sum / static_cast<Scalar>(n));
        sizes_.push_back(n);
        columns_.push_back(first);
        floor_votes_.push_back(2 * floor_count > n ? 1 : 0);
      }
      for (std::size_t k = 0; k < centroids_.size(); ++k)
        (floor_votes_[k] != 0 ? out.floor_points : out.points).push_back(centroids_[k]);
      // Step 2 on the scan's centroids.
      const std::size_t first_line = out.lines.size();
      detect_line_segments(std::span<const Vec3>(centroids_), params_.lines, out.lines, scratch_);
      for (std::size_t l = first_line; l < out.lines.size(); ++l) {
        LineSegment<3, Scalar>& line = out.lines[l];
        std::size_t floor_points = 0, points = 0;
        for (std::size_t k = line.first; k < line.first + line.count; ++k) {
          points += sizes_[k];
          floor_points += floor_votes_[k] != 0 ? sizes_[k] : 0;
        }
        line.row = r;
        line.floor = 2 * floor_points > points;
        line.first = columns_[line.first];
        line.count = points;
        // Step 3: merge into the planes grown so far.
        merge(out.lines, l);
      }
    }
    // Report the planes with enough lines, renumbering the lines' plane indices.
    remap_.assign(all_planes_.size(), LineSegment<3, Scalar>::npos);
    for (std::size_t k = 0; k < all_planes_.size(); ++k) {
      const Accumulator& acc = all_planes_[k];
      if (acc.plane.scan_count < params_.planes.min_scans) continue;
      remap_[k] = out.planes.size();
      PlaneSegment<Scalar> plane = acc.plane;
      plane.floor = 2 * acc.floor_lines > acc.plane.line_count;
      out.planes.push_back(plane);
    }
    for (auto& line : out.lines)
      if (line.plane != LineSegment<3, Scalar>::npos) line.plane = remap_[line.plane];
  }

  /// Convenience: a fresh SweepReduction.
  [[nodiscard]] SweepReduction<Scalar> reduce(const Sweep<Scalar>& sweep) {
    SweepReduction<Scalar> out;
    reduce(sweep, out);
    return out;
  }

 private:
  // Weighted moments of the plane's line endpoints and the fitted plane.
  struct Accumulator {
    Scalar weight{0};
    Vec3 sum{Vec3::Zero()};
    Eigen::Matrix<Scalar, 3, 3> outer{Eigen::Matrix<Scalar, 3, 3>::Zero()};
    std::size_t last_line{0};
    std::size_t floor_lines{0};
    PlaneSegment<Scalar> plane{};

    void add(const LineSegment<3, Scalar>& line) {
      const Scalar w = static_cast<Scalar>(line.count) / Scalar(2);
      for (const Vec3* p : {&line.a, &line.b}) {
        weight += w;
        sum += w * *p;
        outer.noalias() += w * *p * p->transpose();
      }
      ++plane.line_count;
      plane.point_count += line.count;
      floor_lines += line.floor ? 1 : 0;
      if (plane.line_count == 1 || line.row != plane.last_row) ++plane.scan_count;
      if (plane.line_count == 1) plane.first_row = line.row;
      plane.last_row = line.row;
      refit();
    }

    void refit() {
      const Vec3 c = sum / weight;
      const PcaFit<3, Scalar> fit =
          pca_of_covariance<3, Scalar>(c, outer / weight - c * c.transpose(), plane.point_count);
      Vec3 n = fit.normal();
      if (n.dot(c) < Scalar(0)) n = -n;  // distance >= 0: the normal points away from P_b
      plane.normal = n;
      plane.centroid = c;
      plane.distance = n.dot(c);
      plane.rms = fit.normal_rms();
    }
  };

  // Distance between two segments, approximated by their endpoints and midpoints.
  static Scalar segment_distance_sq(const LineSegment<3, Scalar>& u,
                                    const LineSegment<3, Scalar>& v) {
    const auto to_segment = [](const Vec3& p, const LineSegment<3, Scalar>& s) {
      const Vec3 ab = s.b - s.a;
      const Scalar len_sq = ab.squaredNorm();
      const Scalar t =
          len_sq > Scalar(0) ? std::clamp((p - s.a).dot(ab) / len_sq, Scalar(0), Scalar(1)) : 0;
      return (s.a + t * ab - p).squaredNorm();
    };
    Scalar best = std::numeric_limits<Scalar>::infinity();
    for (const Vec3& p : {u.a, u.b, Vec3((u.a + u.b) / Scalar(2))})
      best = std::min(best, to_segment(p, v));
    for (const Vec3& p : {v.a, v.b, Vec3((v.a + v.b) / Scalar(2))})
      best = std::min(best, to_segment(p, u));
    return best;
  }

  // Whether `line` lies in the plane of `acc` (or, for a one-line plane, is coplanar with it).
  Scalar plane_fit(const Accumulator& acc, const std::vector<LineSegment<3, Scalar>>& lines,
                   const LineSegment<3, Scalar>& line) const {
    if (acc.plane.line_count >= 2)
      return std::max(std::abs(acc.plane.signed_distance(line.a)),
                      std::abs(acc.plane.signed_distance(line.b)));
    // One line so far: the two lines must be coplanar, i.e. the second line's endpoints lie in
    // the plane through the first line and the second's centroid.
    const LineSegment<3, Scalar>& m = lines[acc.last_line];
    const Vec3 n = m.direction.cross(line.centroid - m.centroid);
    const Scalar norm = n.norm();
    if (!(norm > Scalar(1e-9))) return 0;  // the centroid lies on the first line
    const Vec3 u = n / norm;
    return std::max(std::abs(u.dot(line.a - m.centroid)), std::abs(u.dot(line.b - m.centroid)));
  }

  void merge(std::vector<LineSegment<3, Scalar>>& lines, std::size_t l) {
    LineSegment<3, Scalar>& line = lines[l];
    const PlaneMergeParams<Scalar>& p = params_.planes;
    const Scalar near_sq = p.max_line_distance * p.max_line_distance;
    const Scalar cos_max = std::cos(p.max_angle);
    // Planes whose last line is too many scans back stop growing.
    std::erase_if(open_, [&](std::size_t k) {
      return line.row > all_planes_[k].plane.last_row + p.max_row_gap;
    });
    std::size_t best = LineSegment<3, Scalar>::npos;
    Scalar best_fit = p.max_distance;
    for (const std::size_t k : open_) {
      const Accumulator& acc = all_planes_[k];
      if (acc.plane.last_row == line.row && acc.plane.line_count == 1) continue;
      const LineSegment<3, Scalar>& last = lines[acc.last_line];
      if (std::abs(last.direction.dot(line.direction)) < cos_max) continue;
      if (segment_distance_sq(last, line) > near_sq) continue;
      const Scalar fit = plane_fit(acc, lines, line);
      if (fit <= best_fit) {
        best_fit = fit;
        best = k;
      }
    }
    if (best == LineSegment<3, Scalar>::npos) {
      best = all_planes_.size();
      all_planes_.emplace_back();
      open_.push_back(best);
    }
    Accumulator& acc = all_planes_[best];
    acc.add(line);
    acc.last_line = l;
    line.plane = best;
  }

  SweepReductionParams<Scalar> params_;
  std::vector<Vec3> centroids_;
  std::vector<std::size_t> sizes_, columns_;
  std::vector<unsigned char> floor_votes_;
  LineDetectionScratch scratch_;
  std::vector<Accumulator> all_planes_;
  std::vector<std::size_t> open_;
  std::vector<std::size_t> remap_;
};

}  // namespace rangenav
