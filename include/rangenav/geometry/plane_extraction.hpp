#pragma once
// Iterative RANSAC plane extraction per cluster (paper 004 §3.3): fit a plane to the cluster with
// RANSAC; if it has at least `min_inliers` inliers it is kept and its inliers are removed from the
// cluster, and the fitting is repeated "as long as no new plane can be fitted or the cluster size
// falls below a user defined threshold". An optional orientation constraint admits only planes
// whose normal lies within an angle of an axis (e.g. only horizontal planes: normal near z).
//
// Every accepted plane is refitted by least squares on its inliers (the normal is the smallest
// principal axis of their covariance, Eigen's SelfAdjointEigenSolver) and its inliers are
// collected again against the refitted plane. The inliers are projected onto the plane (Eq. 1-3:
// delta = n . (p - a), p_pr = p - delta n; PlaneFrame::to_plane gives p_pr in the plane's frame)
// and their concave hull is built with alpha shapes (concave_hull.hpp).
//
// Beyond the paper: a RANSAC plane's inliers may fall into several pieces (coplanar surfaces that
// do not touch, or thin strips where the band of the plane crosses other surfaces). Only the
// largest connected piece is taken as the surface and refitted; the other inliers stay in the
// cluster, so a second coplanar surface becomes a plane of its own and a strip of a wall cannot
// tilt a table top in the least-squares refit. A RANSAC plane with enough inliers whose largest
// piece is too small (a band across strips of other surfaces, or small coplanar patches apart)
// does not end the cluster: its inliers leave the cluster unassigned and RANSAC tries again, at
// most `max_failed_hypotheses` times per cluster, so the other planes of the cluster are still
// found. Before the refit the pieces are groups of neighbouring occupied cells of alpha / 2
// (cheap); after it, the pieces of the alpha shape.
//
// For speed (beyond the paper, same method): RANSAC hypotheses are scored on a random subset of
// the cluster (`evaluation_subset`) and only the best is counted on all of it; the refit before
// round 2 (which only gives round 2 its band) sees every `coarse_stride`-th point of a dense
// cluster; the hull thins the plane's interior (ConcaveHullParams::thinning, 0.5 here); scratch
// buffers are reused.
//
// Randomness comes from the caller's engine: with the same engine state the result is identical.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/concave_hull.hpp"
#include "rangenav/geometry/pca.hpp"
#include "rangenav/geometry/planar_polygon.hpp"

namespace rangenav {

/// Parameters of iterative RANSAC plane extraction (paper 004 §3.2-3.3).
struct PlaneExtractionParams {
  /// RANSAC inlier band: |delta| of Eq. (2) below this (m).
  double distance_threshold = 0.02;
  /// A plane needs at least this many inliers to be accepted.
  std::size_t min_inliers = 500;
  /// Stop fitting in a cluster once fewer points than this remain (the paper's user-defined
  /// threshold); 0 = min_inliers.
  std::size_t min_remaining = 0;
  /// RANSAC hypotheses per plane at most.
  int max_iterations = 200;
  /// Stop sampling when a better plane would have been found with this probability.
  double confidence = 0.99;
  /// Hypotheses are scored on this many points drawn at random from the cluster (0 = all of
  /// them); only the best one is counted on the whole cluster. Beyond the paper, for speed: the
  /// inlier ratio of a 10^5-point cluster is estimated to about 1 % from 2000 points.
  std::size_t evaluation_subset = 2000;
  /// Orientation constraint: when set, only planes whose normal is within `max_axis_angle` of
  /// this axis (either sign) are accepted, e.g. (0, 0, 1) for horizontal planes.
  std::optional<Point3d> axis;
  double max_axis_angle = 10.0 * std::numbers::pi / 180.0;  ///< rad
  /// When set, normals are flipped to face this point (e.g. the sensor position).
  std::optional<Point3d> viewpoint;
  /// Round 1 of every plane (the least-squares refit of the RANSAC plane on the largest piece of
  /// its inliers, which gives round 2 the band it collects the surface in) looks at every
  /// coarse_stride-th point of the cluster only (1 = all), or at every point when those are too
  /// sparse to connect the cells of a surface (fewer than 4 sampled inliers per occupied cell).
  /// Beyond the paper, for speed: the final plane, its inliers and hull come from round 2 on all
  /// the points.
  std::size_t coarse_stride = 4;
  /// A RANSAC plane whose band holds at least min_inliers points but whose surface (the largest
  /// piece of its alpha shape) has fewer is a failed hypothesis: its band's points leave the
  /// cluster unassigned and RANSAC tries again, at most this many times per cluster (0: the
  /// cluster ends at the first such plane). A plane whose band holds fewer than min_inliers
  /// points ends the cluster (no plane can be fitted any more, paper 004 §3.3).
  std::size_t max_failed_hypotheses = 3;
  /// Alpha-shape hull of the projected inliers; the interior of the dense planes of a range
  /// camera is thinned in cells of half alpha (ConcaveHullParams::thinning).
  ConcaveHullParams hull{.thinning = 0.5};

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where) const {
    detail::require_positive(where, "params.distance_threshold", distance_threshold);
    if (min_inliers < 3)
      detail::throw_invalid_argument(where, "params.min_inliers", min_inliers, "must be >= 3");
    if (max_iterations < 1)
      detail::throw_invalid_argument(where, "params.max_iterations", max_iterations,
                                     "must be >= 1");
    if (!(confidence > 0 && confidence < 1))
      detail::throw_invalid_argument(where, "params.confidence", confidence, "must be in (0, 1)");
    if (axis && !(axis->allFinite() && axis->norm() > 1e-12))
      detail::throw_invalid_argument(where, "params.axis", axis->norm(),
                                     "(its norm) must be finite and > 0");
    if (!(max_axis_angle >= 0 && max_axis_angle <= std::numbers::pi / 2))
      detail::throw_invalid_argument(where, "params.max_axis_angle", max_axis_angle,
                                     "must be in [0, pi/2]");
    if (viewpoint && !viewpoint->allFinite())
      detail::throw_invalid(where, "argument 'params.viewpoint' must be finite");
    hull.validate(where);
  }
};

/// One extracted planar surface.
struct ExtractedPlane {
  PlanarPolygon<double> shape;  ///< plane, frame and concave hull (in the frame)
  std::size_t inliers = 0;      ///< points of the surface (inliers in its connected piece)
  double rms = 0;               ///< RMS point-to-plane distance of the inliers (m)
};

/// Iterative RANSAC plane extraction; owns scratch buffers reused across calls.
class PlaneExtractor {
 public:
  /// An extractor with these parameters; throws invalid_argument for invalid ones.
  explicit PlaneExtractor(const PlaneExtractionParams& params = {})
      : params_(params), hull_(params.hull) {
    params_.validate("PlaneExtractor");
    if (params_.axis) params_.axis->normalize();
  }

  /// The parameters (the orientation axis normalised).
  [[nodiscard]] const PlaneExtractionParams& params() const { return params_; }

  /// Sets (or clears) the point normals are turned to face, e.g. the sensor of the next frame.
  void set_viewpoint(const std::optional<Point3d>& viewpoint) {
    if (viewpoint && !viewpoint->allFinite())
      detail::throw_invalid("PlaneExtractor::set_viewpoint", "argument 'viewpoint' must be finite");
    params_.viewpoint = viewpoint;
  }

  /// Extracts the planes of one cluster, points[cluster[i]], and appends them to `out`; returns
  /// how many were appended. Non-finite points are ignored. Throws invalid_argument when an
  /// index is out of range.
  template <class Engine>
  std::size_t extract(std::span<const Point3d> points, std::span<const std::uint32_t> cluster,
                      Engine& rng, std::vector<ExtractedPlane>& out) {
    gather(points, cluster, [](const Point3d& p) { return p; });
    return extract_gathered(rng, out);
  }

  /// The same for points given in another frame: the cluster's points are `pose` * points[i]
  /// (e.g. a sensor frame's points and the sensor's pose in the world); the planes come out in
  /// pose's target frame.
  template <class Engine>
  std::size_t extract(std::span<const Point3d> points, std::span<const std::uint32_t> cluster,
                      const Transform3d& pose, Engine& rng, std::vector<ExtractedPlane>& out) {
    const Eigen::Matrix3d rotation = pose.linear();
    const Point3d translation = pose.translation();
    gather(points, cluster,
           [&](const Point3d& p) -> Point3d { return rotation * p + translation; });
    return extract_gathered(rng, out);
  }

  /// Reserves the scratch buffers for clusters of up to `points` points (e.g. a whole frame)
  /// and touches them. Optional: the buffers grow as needed, but growing copies them into fresh
  /// memory whose pages the system maps in on first touch, a page fault each (a few us in a
  /// virtual machine; 489-605 of them in the timed key frame of bench_geometric_map's
  /// BM_keyframe_total with a reservation that did not touch). Reserved once, at the first
  /// frame, no later frame grows or faults in a buffer (the practice of real-time code:
  /// memory is claimed up front, not in the control loop).
  void reserve(std::size_t points) {
    reserve_touched(gathered_, points);
    reserve_touched(others_, points);
    reserve_touched(projected_, points);
    reserve_touched(piece_, points);
    hull_.reserve(points);
  }

  /// Extracts the planes of every point (one cluster holding all of them).
  template <class Engine>
  std::size_t extract(std::span<const Point3d> points, Engine& rng,
                      std::vector<ExtractedPlane>& out) {
    all_.resize(points.size());
    for (std::size_t i = 0; i < points.size(); ++i)
      all_[i] = static_cast<std::uint32_t>(i);
    return extract(points, std::span<const std::uint32_t>(all_), rng, out);
  }

 private:
  /// Copies the cluster's finite points, transformed by `map`, into remaining_ (contiguous, in
  /// cluster order): every pass below reads and partitions them there instead of gathering
  /// through indices.
  template <class Map>
  void gather(std::span<const Point3d> points, std::span<const std::uint32_t> cluster, Map map) {
    if (cluster.size() > std::size_t(std::numeric_limits<std::int32_t>::max()))
      detail::throw_invalid_argument("PlaneExtractor::extract", "cluster.size()", cluster.size(),
                                     "must fit 31 bits");
    gathered_.resize(cluster.size());
    Point3d* const out = gathered_.data();
    const Point3d* const in = points.data();
    const std::size_t size = points.size();
    std::size_t kept = 0;
    for (const std::uint32_t i : cluster) {
      if (i >= size)
        detail::throw_invalid_argument("PlaneExtractor::extract", "cluster index", i,
                                       "must be < points.size() = " + std::to_string(size));
      const Point3d p = map(in[i]);
      out[kept] = p;
      kept += std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()) ? 1 : 0;
    }
    remaining_ = std::span<Point3d>(gathered_).first(kept);
  }

  /// Iterative RANSAC on remaining_ (see extract).
  template <class Engine>
  std::size_t extract_gathered(Engine& rng, std::vector<ExtractedPlane>& out) {
    const std::size_t min_remaining = std::max<std::size_t>(
        3, params_.min_remaining != 0 ? params_.min_remaining : params_.min_inliers);
    const std::size_t before = out.size();
    std::size_t failed = 0;  // failed hypotheses in this cluster (max_failed_hypotheses)
    while (remaining_.size() >= min_remaining) {
      const std::optional<Plane3<double>> hypothesis = ransac(rng);
      if (!hypothesis) break;
      // Two rounds. 1: the inliers of the RANSAC plane -> their largest connected piece -> least-
      // squares refit on it (a strip of another surface crossing the band cannot tilt the
      // plane). 2: the inliers of the refitted plane, whose band covers the whole surface ->
      // alpha shape (in the plane's frame) -> its largest piece is the surface -> refit. The
      // other inliers stay in the cluster for the next planes. Round 1's pieces are the
      // 8-connected groups of occupied cells of alpha / 2 (points of neighbouring cells are at
      // most 1.4 alpha apart, where the alpha shape joins points up to 2 alpha apart), which
      // is much cheaper than a triangulation and only decides what the refit sees.
      // Round 1 looks at every coarse_stride-th remaining point only and reorders nothing: the
      // RANSAC plane's inliers among them are listed by their positions in remaining_, the list
      // narrowed to the largest piece and the refit's moments summed over the listed points.
      // It only gives round 2 its band, so it decides nothing by counts: round 2 counts all
      // the points (the verification of the hypothesis: too few inliers in the surface, no
      // plane).
      Plane3<double> plane = *hypothesis;
      const double cells = 2.0 / params_.hull.alpha;  // round 1's cells of alpha / 2
      const PlaneFrame<double> ransac_frame = PlaneFrame<double>::of(plane);
      const std::size_t stride = std::max<std::size_t>(1, params_.coarse_stride);
      std::optional<std::size_t> piece =
          largest_cell_piece(split_inliers<false>(plane, ransac_frame, cells, stride),
                             stride > 1 ? min_coarse_per_cell : 0.0);
      if (!piece)  // too sparse for the stride: every point
        piece = largest_cell_piece(split_inliers<false>(plane, ransac_frame, cells, 1), 0.0);
      std::size_t surface = *piece;
      Moments moments = Moments::of(remaining_.data(), piece_.data(), surface);
      if (const auto refit = fit_least_squares(moments, plane); refit && admissible(refit->normal))
        plane = *refit;
      const PlaneFrame<double> hull_frame = PlaneFrame<double>::of(plane);
      const std::size_t count = split_inliers<true>(plane, hull_frame, 1.0);
      std::vector<Polygon2<double>> pieces = hull_.compute(projected_, &piece_);
      surface = keep_front(count, [&](std::size_t k) { return piece_[k] == 0; });  // largest piece
      moments = Moments::of(remaining_.data(), surface);
      if (pieces.empty() || surface < params_.min_inliers) {
        // The band holds no surface of min_inliers points. With fewer than that in the whole
        // band no plane can be fitted any more (RANSAC's best has too few inliers): the cluster
        // ends. Else the band is made of small pieces (e.g. strips of several surfaces, or
        // coplanar patches apart) while other planes may remain: its points leave the cluster
        // unassigned, so that RANSAC cannot draw the same plane again, and RANSAC tries again,
        // at most max_failed_hypotheses times per cluster.
        if (count < params_.min_inliers || failed++ >= params_.max_failed_hypotheses) break;
        remaining_ = remaining_.subspan(count);
        continue;
      }
      if (const auto refit = fit_least_squares(moments, plane); refit && admissible(refit->normal))
        plane = *refit;
      if (params_.viewpoint && plane.signed_distance(*params_.viewpoint) < 0)
        plane = plane.flipped();
      emit(moments, plane, hull_frame, std::move(pieces.front()), out);
      remaining_ = remaining_.subspan(surface);  // the surface leaves the cluster
    }
    return out.size() - before;
  }

  [[nodiscard]] bool admissible(const Point3d& normal) const {
    return !params_.axis ||
           std::abs(normal.dot(*params_.axis)) >= std::cos(params_.max_axis_angle) - 1e-12;
  }

  /// The best RANSAC plane of remaining_, or none with fewer than min_inliers inliers.
  /// Hypotheses are scored on a random subset of remaining_ (params.evaluation_subset points,
  /// copied into subset_ so that the scoring loop reads contiguous memory); the best is counted
  /// on all of remaining_.
  template <class Engine>
  std::optional<Plane3<double>> ransac(Engine& rng) {
    const std::size_t n = remaining_.size();
    std::uniform_int_distribution<std::size_t> pick(0, n - 1);
    const double thr = params_.distance_threshold;
    const std::size_t m = params_.evaluation_subset == 0 || params_.evaluation_subset >= n
                              ? n
                              : params_.evaluation_subset;
    subset_.resize(static_cast<Eigen::Index>(m), 3);  // by coordinate: x, y, z columns
    for (std::size_t k = 0; k < m; ++k)
      subset_.row(static_cast<Eigen::Index>(k)) = remaining_[m == n ? k : pick(rng)].transpose();
    std::size_t best_count = 0;
    std::optional<Plane3<double>> best;
    double needed = params_.max_iterations;
    for (int it = 0; it < params_.max_iterations && it < needed; ++it) {
      const std::size_t a = pick(rng), b = pick(rng), c = pick(rng);
      if (a == b || b == c || a == c) continue;
      const Point3d& p = remaining_[a];
      const Point3d normal = (remaining_[b] - p).cross(remaining_[c] - p);
      const double norm = normal.norm();
      if (!(norm > 1e-12)) continue;  // collinear sample
      const Point3d nn = normal / norm;
      if (!admissible(nn)) continue;
      const double d = -nn.dot(p);
      // |nn . q + d| (Eq. 2) of the whole subset, two points per SSE2 instruction, the dot
      // product's terms summed in Eigen's order (x, y, z); then its inliers counted.
      scores_ = (subset_.col(0).array() * nn.x() + subset_.col(1).array() * nn.y() +
                 subset_.col(2).array() * nn.z() + d)
                    .abs();
      const auto count = static_cast<std::size_t>((scores_ < thr).count());
      if (count > best_count) {
        best_count = count;
        best = Plane3<double>{nn, d};
        // Adaptive number of hypotheses: 1 - (1 - w^3)^k >= confidence with inlier ratio w.
        const double w = double(count) / double(m);
        const double miss = 1 - w * w * w;
        needed = miss <= 0 ? 0 : std::log(1 - params_.confidence) / std::log(miss);
      }
    }
    // The verification on the whole cluster is the caller's split_inliers.
    return best;
  }

  /// Sums of q = p - p0 and of q q^T over points p, shifted by the first point p0 for
  /// precision.
  struct Moments {
    Point3d p0 = Point3d::Zero(), sum = Point3d::Zero();
    double xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
    std::size_t count = 0;
    /// sum q q^T over the points.
    [[nodiscard]] Eigen::Matrix3d scatter() const {
      Eigen::Matrix3d s;
      s << xx, xy, xz, xy, yy, yz, xz, yz, zz;
      return s;
    }
    /// The moments of p[0 .. count), in one tight pass over the contiguous points (cheaper than
    /// accumulating them point by point while partitioning).
    static Moments of(const Point3d* p, std::size_t count) {
      return of_points(count, [p](std::size_t k) -> const Point3d& { return p[k]; });
    }
    /// The moments of p[index[0]], ..., p[index[count - 1]], the same sums in the same order as
    /// over those points stored one after the other.
    static Moments of(const Point3d* p, const std::int32_t* index, std::size_t count) {
      return of_points(count, [p, index](std::size_t k) -> const Point3d& {
        return p[static_cast<std::size_t>(index[k])];
      });
    }
    template <class At>
    static Moments of_points(std::size_t count, At at) {
      Moments m;
      if (count == 0) return m;
      m.p0 = at(0);
      m.count = count;
      // The same products and sums, in the same order per sum (so the same bits), two at a
      // time where they pair up: (qx, qy) and its squares, (qx, qy) qz.
      const Eigen::Array2d xy0 = m.p0.head<2>().array();
      const double z0 = m.p0.z();
      Eigen::Array2d s_xy = Eigen::Array2d::Zero(), sq_xy = s_xy, xy_z = s_xy;
      double sz = 0, xy = 0, zz = 0;
      for (std::size_t k = 0; k < count; ++k) {
        const Point3d& pk = at(k);
        const Eigen::Array2d q = pk.head<2>().array() - xy0;
        const double qz = pk.z() - z0;
        s_xy += q;
        sz += qz;
        sq_xy += q * q;
        xy += q.x() * q.y();
        xy_z += q * qz;
        zz += qz * qz;
      }
      m.sum = Point3d(s_xy.x(), s_xy.y(), sz);
      m.xx = sq_xy.x();
      m.xy = xy;
      m.xz = xy_z.x();
      m.yy = sq_xy.y();
      m.yz = xy_z.y();
      m.zz = zz;
      return m;
    }
  };

  /// Least-squares plane of the points summed in `m`: their centroid and smallest principal
  /// axis, on the side of `side`'s normal.
  static std::optional<Plane3<double>> fit_least_squares(const Moments& m,
                                                         const Plane3<double>& side) {
    if (m.count < 3) return std::nullopt;
    const double inv = 1.0 / double(m.count);
    const Point3d mean = m.sum * inv;
    const Point3d centroid = m.p0 + mean;
    Eigen::Matrix3d cov = m.scatter();  // covariance times count, after the next line
    cov.noalias() -= double(m.count) * mean * mean.transpose();
    Point3d normal = pca_of_covariance<3, double>(centroid, cov * inv, m.count).normal();
    if (!normal.allFinite() || normal.norm() < 0.5) return std::nullopt;
    if (normal.dot(side.normal) < 0) normal = -normal;
    return Plane3<double>::through(centroid, normal);
  }

  /// Round 1's piece: narrows piece_[0 .. count) (the inliers' positions in remaining_;
  /// projected_: their plane coordinates in cells, from split_inliers<false>) to the points of
  /// the largest 8-connected group of occupied cells of alpha / 2, in order; returns their count.
  /// None, with nothing narrowed, when the points are fewer than min_per_cell times the
  /// occupied cells (a sample too sparse to connect the cells of a surface).
  std::optional<std::size_t> largest_cell_piece(std::size_t count, double min_per_cell) {
    if (count == 0) return 0;
    double x0 = lo_.x(), y0 = lo_.y(), x1 = hi_.x(), y1 = hi_.y();
    // Cells with a margin of one on each side; a plane too large for a dense grid of a few
    // cells per point is taken as one piece.
    x0 = std::floor(x0) - 1;
    y0 = std::floor(y0) - 1;
    const double wd = std::floor(x1) - x0 + 2, hd = std::floor(y1) - y0 + 2;
    if (!(wd * hd <= 4.0 * double(count) + 4096)) return count;
    const auto w = static_cast<std::size_t>(wd), h = static_cast<std::size_t>(hd);
    constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();
    cells_.assign(w * h, none);    // union-find parent per occupied cell
    cell_count_.assign(w * h, 0);  // points per cell, then per piece at its root
    std::size_t occupied = 0;
    for (std::size_t k = 0; k < count; ++k) {
      const auto cx = static_cast<std::size_t>(projected_[k].x() - x0);  // >= 1, truncation
      const auto cy = static_cast<std::size_t>(projected_[k].y() - y0);  // is floor here
      const std::size_t c = cy * w + cx;
      occupied += cell_count_[c] == 0 ? 1 : 0;
      cells_[c] = static_cast<std::uint32_t>(c);
      ++cell_count_[c];
    }
    if (double(count) < min_per_cell * double(occupied)) return std::nullopt;
    const auto find = [&](std::uint32_t i) {
      while (cells_[i] != i)
        i = cells_[i] = cells_[cells_[i]];
      return i;
    };
    for (std::size_t c = w; c + w < w * h; ++c) {
      if (cells_[c] == none) continue;
      for (const std::size_t nb : {c + 1, c + w - 1, c + w, c + w + 1})
        if (cells_[nb] != none) {
          const std::uint32_t a = find(static_cast<std::uint32_t>(c)),
                              b = find(static_cast<std::uint32_t>(nb));
          if (a != b) cells_[std::max(a, b)] = std::min(a, b);
        }
    }
    // Points per piece, summed at its root (the piece's smallest cell, visited first), every
    // cell pointing at its root from here on; the largest piece (ties: the smallest root).
    std::uint32_t best = 0, best_count = 0;
    for (std::size_t c = 0; c < w * h; ++c) {
      if (cells_[c] == none) continue;
      const std::uint32_t root = find(static_cast<std::uint32_t>(c));
      cells_[c] = root;
      if (root != c) cell_count_[root] += cell_count_[c];
    }
    for (std::size_t c = 0; c < w * h; ++c)
      if (cells_[c] == c && cell_count_[c] > best_count) {
        best_count = cell_count_[c];
        best = static_cast<std::uint32_t>(c);
      }
    std::size_t kept = 0;
    for (std::size_t k = 0; k < count; ++k) {  // each inlier's cell again (no array of them)
      const auto cx = static_cast<std::size_t>(projected_[k].x() - x0);
      const auto cy = static_cast<std::size_t>(projected_[k].y() - y0);
      piece_[kept] = piece_[k];
      kept += cells_[cy * w + cx] == best ? 1 : 0;
    }
    return kept;
  }

  /// Stable partition of remaining_[0 .. count): the points with keep(k) (k their position
  /// before the call) move to the front in order, the others follow in order (through the reused
  /// others_ buffer); returns how many were kept.
  template <class Keep>
  std::size_t keep_front(std::size_t count, Keep keep) {
    if (others_.size() < count) others_.resize(count);
    std::size_t k = 0;  // the kept points before the first other one stay where they are
    while (k < count && keep(k))
      ++k;
    std::size_t kept = k, other = 0;
    for (; k < count; ++k)
      if (keep(k))
        remaining_[kept++] = remaining_[k];
      else
        others_[other++] = remaining_[k];
    std::copy_n(others_.begin(), other, remaining_.begin() + static_cast<std::ptrdiff_t>(kept));
    return kept;
  }

  /// Finds the inliers of `plane` in remaining_ and returns their count. Move: they are moved to
  /// the front of remaining_ (a stable partition); else only every stride-th point is looked at,
  /// remaining_ is left as it is and piece_ lists the inliers' positions in it.
  /// projected_ receives the inliers in `frame`'s plane coordinates (Eq. 1-3) times `scale`, in
  /// order; only round 1 (!Move) sets their box lo_, hi_ (round 2's hull finds its own).
  template <bool Move>
  std::size_t split_inliers(const Plane3<double>& plane, const PlaneFrame<double>& frame,
                            double scale, std::size_t stride = 1) {
    const double thr = params_.distance_threshold;
    const std::size_t n = remaining_.size();
    // others_ is sized in round 1 too, as when round 1 moved points: allocated after round 1's
    // buffers instead, it made glibc give the heap back to the system after every key frame of
    // a fresh mapper and fault it in again (five times the page faults, about +3 ms per key
    // frame).
    if (others_.size() < n) others_.resize(n);
    // Round 1 lists at most ceil(n / stride) positions: piece_ (which the hull shrinks to round
    // 2's count) grows to that only, not to n (its growth is a memset).
    const std::size_t listed = Move ? 0 : (n + stride - 1) / stride;
    if (!Move && piece_.size() < listed) piece_.resize(listed);
    projected_.resize(n);
    // Stable partition with a branch on the inlier test: each point is written once, to its side
    // (inliers with their plane coordinates). The points come in image order, so the test
    // changes only where the band enters or leaves a surface and the branch is mostly predicted;
    // the pass is bound by memory traffic, and the branch-free form (every point written to both
    // sides and its plane coordinates computed for all) moves 88 instead of 40-48 bytes a point
    // and is about 5 % slower. Writes to remaining_ never pass the read position.
    Point3d* const in = remaining_.data();
    [[maybe_unused]] Point3d* const out = others_.data();
    Point2d* const proj = projected_.data();
    std::size_t count = 0;
    [[maybe_unused]] std::size_t other = 0;
    // The point read and written as scalars, the plane coordinates as one pair of columns
    // (Eigen's fixed-size expressions on whole points here spilled to the stack): the same
    // operations in the same order as plane.signed_distance(p) and
    // (R.topRows<2>() * p + offset) * scale, so the same bits.
    const double nx = plane.normal.x(), ny = plane.normal.y(), nz = plane.normal.z();
    const double d = plane.d;
    const Eigen::Array2d nxy(nx, ny);
    // frame.to_plane's first two rows, inlined: x_plane = R (x - o), Eq. (10).
    const Eigen::Matrix<double, 2, 3> rows = frame.world_to_plane.linear().topRows<2>();
    const Point2d c0 = rows.col(0), c1 = rows.col(1), c2 = rows.col(2);
    const Point2d o = frame.world_to_plane.translation().head<2>();
    for (std::size_t k = 0; k < n; k += Move ? 1 : stride) {
      const double x = in[k].x(), y = in[k].y(), z = in[k].z();
      const Eigen::Array2d nxy_xy = nxy * in[k].head<2>().array();  // (nx x, ny y) in one product
      const double delta = nxy_xy.x() + nxy_xy.y() + nz * z + d;    // Eq. (2)
      if (std::abs(delta) < thr) {
        if constexpr (Move) {
          double* const a = in[count].data();
          a[0] = x;
          a[1] = y;
          a[2] = z;
        } else {
          piece_[count] = static_cast<std::int32_t>(k);
        }
        proj[count] = (c0 * x + c1 * y + c2 * z + o) * scale;  // both rows at once
        ++count;
      } else if constexpr (Move) {
        double* const b = out[other].data();
        b[0] = x;
        b[1] = y;
        b[2] = z;
        ++other;
      }
    }
    if constexpr (Move) std::copy(out, out + other, in + count);
    projected_.resize(count);
    if constexpr (!Move) box(count);
    return count;
  }

  /// lo_, hi_: the box of projected_[0 .. count), for largest_cell_piece. In a pass of its own
  /// over the inliers (in split_inliers' loop it became a branch on the inlier test), with four
  /// boxes in flight: one min and max chain waited on the latency of each minpd / maxpd (a fifth
  /// of split_inliers' time).
  void box(std::size_t count) {
    const Point2d* const proj = projected_.data();
    constexpr std::size_t lanes = 4;
    std::array<Point2d, lanes> lo, hi;
    lo.fill(Point2d::Constant(std::numeric_limits<double>::max()));
    hi.fill(Point2d::Constant(std::numeric_limits<double>::lowest()));
    std::size_t k = 0;
    for (; k + lanes <= count; k += lanes)
      for (std::size_t j = 0; j < lanes; ++j) {
        lo[j] = lo[j].cwiseMin(proj[k + j]);
        hi[j] = hi[j].cwiseMax(proj[k + j]);
      }
    for (; k < count; ++k) {
      lo[0] = lo[0].cwiseMin(proj[k]);
      hi[0] = hi[0].cwiseMax(proj[k]);
    }
    for (std::size_t j = 1; j < lanes; ++j) {
      lo[0] = lo[0].cwiseMin(lo[j]);
      hi[0] = hi[0].cwiseMax(hi[j]);
    }
    lo_ = lo[0];
    hi_ = hi[0];
  }

  /// Appends the surface whose points' moments are `m`, on `plane`, its hull `polygon` given in
  /// `hull_frame` (the RANSAC plane's) re-expressed in the refitted plane's frame.
  static void emit(const Moments& m, const Plane3<double>& plane,
                   const PlaneFrame<double>& hull_frame, Polygon2<double> polygon,
                   std::vector<ExtractedPlane>& out) {
    ExtractedPlane e;
    e.shape.plane = plane;
    e.shape.frame = PlaneFrame<double>::of(plane);
    const auto reframe = [&](std::vector<Point2d>& ring) {
      for (Point2d& v : ring)
        v = e.shape.frame.to_plane(hull_frame.to_world(v));  // Eq. (3) onto the refitted plane
    };
    reframe(polygon.outer);
    for (auto& h : polygon.holes)
      reframe(h);
    if (Polygon2<double>::ring_signed_area(polygon.outer) < 0) {  // a flipped normal mirrors
      std::reverse(polygon.outer.begin(), polygon.outer.end());
      for (auto& h : polygon.holes)
        std::reverse(h.begin(), h.end());
    }
    e.shape.polygon = std::move(polygon);
    // The sum of squared distances delta = n . p + d (Eq. 2) from the moments, without another
    // pass over the points: with p = p0 + q and e = n . p0 + d, sum (n . q + e)^2 =
    // n^T (sum q q^T) n + 2 e n . (sum q) + count e^2. Beside the moments' own sums it cancels
    // only the in-plane spread (about 1e-11 of the result for a metre-sized, mm-thick surface).
    const Point3d& n = plane.normal;
    const double e0 = plane.signed_distance(m.p0);
    const double nqq = n.dot(m.scatter() * n);
    const double sum_sq = nqq + 2 * e0 * n.dot(m.sum) + double(m.count) * e0 * e0;
    e.inliers = m.count;
    e.rms = std::sqrt(std::max(0.0, sum_sq) / double(m.count));
    out.push_back(std::move(e));
  }

  /// Round 1 with coarse_stride > 1 needs this many sampled inliers per occupied cell on
  /// average, else it looks at every point (a range camera's surfaces at a few metres have tens
  /// of points per cell of 2.5 cm; samples 2.5 cm apart, one per cell, would leave gaps).
  static constexpr double min_coarse_per_cell = 4.0;

  /// Grows v's capacity to at least n, writing every element up to n once (value
  /// initialisation), so that its pages are mapped in here; v's elements are kept.
  template <class T>
  static void reserve_touched(std::vector<T>& v, std::size_t n) {
    if (v.capacity() >= n) return;
    const std::size_t size = v.size();
    v.resize(n);
    v.resize(size);
  }

  PlaneExtractionParams params_;
  ConcaveHull hull_;
  std::vector<Point3d> gathered_;  // the cluster's finite points (reordered by the passes)
  // The part of gathered_ not yet in a plane (its end; set by gather before every use).
  std::span<Point3d> remaining_;
  std::vector<std::uint32_t> all_;
  std::vector<Point2d> projected_;
  Point2d lo_, hi_;  // bounding box of projected_
  // Round 1: the inliers' positions in remaining_; round 2: the hull piece of each inlier.
  std::vector<std::int32_t> piece_;
  std::vector<Point3d> others_;
  Eigen::Matrix<double, Eigen::Dynamic, 3> subset_;  // RANSAC's evaluation subset
  Eigen::ArrayXd scores_;
  std::vector<std::uint32_t> cells_;
  std::vector<std::uint32_t> cell_count_;
};

}  // namespace rangenav
