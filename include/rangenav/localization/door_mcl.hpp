#pragma once
// Door-aware Monte-Carlo localization (paper 001 §IV): a Rao-Blackwellized particle filter whose
// particles carry, besides a pose, one Kalman-filtered opening angle per door (Eq. 3). Per update:
//   1. sampling: the pose by the odometry motion model, the door angles by the random walk
//      d_t = d_{t-1} + N(0, sigma_d^2) (their variances grow by sigma_d^2);
//   2. importance (Eq. 4-5): each beam's end point is associated by maximum likelihood with the
//      static map (likelihood field, doors removed) or with a door leaf; the door term
//      marginalises the particle's angle estimate (Eq. 6) to first order: the end point's
//      distance d to the leaf at the mean angle, with variance sigma_hit^2 + J^2 P, where
//      J = dd/dangle = (distance of the foot point along the leaf);
//   3. door state update: the scan's Douglas-Peucker polygon (Boost.Geometry simplify, once per
//      scan) is transformed to each particle's pose; a segment with an end near a door's hinge,
//      of similar length and within the door's opening range (widened by a margin) measures the
//      door's angle; if none is found, a longer segment passing close to the hinge and running
//      over the leaf's extent (a door flush with its wall) does. A linear Kalman filter fuses the
//      measured angle;
//   4. low-variance resampling, to the particle count KLD-sampling gives for the poses (as in
//      MonteCarloLocalization: the count adapts to the pose uncertainty, §V.C).
// Door angles are openings relative to DoorModel::reference_angle (0 .. opening_max observed).
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <bit>
#include <boost/geometry.hpp>
#include <boost/geometry/geometries/linestring.hpp>
#include <boost/geometry/geometries/point_xy.hpp>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/localization/free_space_sampling.hpp"
#include "rangenav/localization/likelihood_field.hpp"
#include "rangenav/localization/mcl.hpp"
#include "rangenav/localization/odometry_motion_model.hpp"
#include "rangenav/localization/particle_filter.hpp"
#include "rangenav/mapping/doors.hpp"
#include "rangenav/scan/laser_scan.hpp"

namespace rangenav {

/// The most doors a DoorAwareMcl tracks (each particle holds a fixed array: no allocation).
inline constexpr std::size_t max_tracked_doors = 16;

/// One door's opening angle estimate in a particle: N(mean, variance), rad.
struct DoorAngleEstimate {
  double mean{0};      ///< rad, from the door's reference angle
  double variance{0};  ///< rad^2
};

/// A particle's state: the pose and the door angle estimates (doors beyond the map's count are
/// unused).
struct DoorAwareState {
  Pose2d pose{};                                             ///< the robot's pose in the map frame
  std::array<DoorAngleEstimate, max_tracked_doors> doors{};  ///< one estimate per door of the map
};

/// Parameters of door-aware MCL (paper 001 §IV).
struct DoorAwareMclParams {
  OdometryMotionParams motion{};          ///< odometry motion model
  LikelihoodFieldParams field{};          ///< the static map's sensor model
  double sigma_d{deg_to_rad(3.0)};        ///< door random walk per update (rad)
  double angle_sigma{deg_to_rad(3.0)};    ///< std. dev. of a measured door angle (rad)
  double dp_epsilon{0.03};                ///< Douglas-Peucker tolerance (m)
  double jump_distance{0.3};              ///< scan points farther apart start a new polyline
  double hinge_tolerance{0.2};            ///< segment end this close to the hinge (m)
  double length_tolerance{0.25};          ///< |segment length - leaf length| (m)
  double range_margin{deg_to_rad(15.0)};  ///< widening of the observed opening range
  double hinge_line_distance{0.08};       ///< fallback: segment line this close to the hinge
  /// Particle count adaptation (KLD-sampling over the poses) and the resampling threshold,
  /// the same as standard MCL's (§V.B compares both filters with the same parameters).
  MclParams sampling{};

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where) const {
    motion.validate(where);
    field.validate(where);
    detail::require_non_negative(where, "sigma_d", sigma_d);
    detail::require_positive(where, "angle_sigma", angle_sigma);
    detail::require_positive(where, "dp_epsilon", dp_epsilon);
    detail::require_positive(where, "jump_distance", jump_distance);
    detail::require_positive(where, "hinge_tolerance", hinge_tolerance);
    detail::require_positive(where, "length_tolerance", length_tolerance);
    detail::require_non_negative(where, "range_margin", range_margin);
    detail::require_positive(where, "hinge_line_distance", hinge_line_distance);
    sampling.validate(where);
  }
};

/// A scan prepared once for all particles: beam end points and the Douglas-Peucker segments,
/// both in the robot frame.
struct DoorAwareObservation {
  std::vector<Eigen::Vector2f> end_points;            ///< end points of the used beams
  std::vector<std::pair<Point2d, Point2d>> segments;  ///< the scan's Douglas-Peucker segments
};

/// Monte-Carlo localization with a Kalman-filtered opening angle per door in every particle
/// (paper 001 §IV, Rao-Blackwellised over the door states).
class DoorAwareMcl {
 public:
  /// `grid` is the static map with the doors removed (remove_doors()); `doors` the detected doors
  /// (at most max_tracked_doors, each with finite values and a positive leaf length).
  DoorAwareMcl(const OccupancyGrid& grid, std::span<const DoorModel> doors,
               const DoorAwareMclParams& params = {})
      : params_(params),
        motion_(params.motion),
        field_(grid, params.field),
        doors_(doors.begin(), doors.end()) {
    params_.validate("DoorAwareMcl");
    if (doors_.size() > max_tracked_doors)
      detail::throw_invalid_argument("DoorAwareMcl", "doors.size()", doors_.size(),
                                     "must be <= " + std::to_string(max_tracked_doors));
    for (std::size_t k = 0; k < doors_.size(); ++k) {
      const DoorModel& d = doors_[k];
      if (!(d.hinge.allFinite() && std::isfinite(d.reference_angle) &&
            std::isfinite(d.opening_min) && std::isfinite(d.opening_max) &&
            d.opening_min <= d.opening_max && std::isfinite(d.leaf_length) && d.leaf_length > 0))
        detail::throw_invalid_argument(
            "DoorAwareMcl", "doors[k]", k,
            "needs a finite hinge and reference angle, opening_min <= opening_max (finite) and "
            "a finite leaf_length > 0");
    }
    build_cell_tables(grid);
  }

  /// The parameters.
  [[nodiscard]] const DoorAwareMclParams& params() const { return params_; }
  /// The doors the filter tracks.
  [[nodiscard]] const std::vector<DoorModel>& doors() const { return doors_; }
  /// The particles.
  [[nodiscard]] const ParticleFilter<DoorAwareState>& filter() const { return filter_; }
  /// The static map's likelihood field.
  [[nodiscard]] const LikelihoodFieldModel& field() const { return field_; }

  /// Poses from N(mean, diag(sigma^2)); each door's angle starts uniform over its observed range
  /// (mean in the middle, variance range^2 / 12). Throws invalid_argument as
  /// MonteCarloLocalization::initialize_gaussian() does.
  template <class Engine>
  void initialize_gaussian(const Pose2d& mean, const Eigen::Vector3d& sigma, std::size_t count,
                           Engine& rng) {
    constexpr std::string_view where = "DoorAwareMcl::initialize_gaussian";
    detail::require_particle_count(where, "count", count);
    const std::vector<Pose2d> poses = detail::sample_gaussian_poses(mean, sigma, count, rng, where);
    states_.resize(count);
    for (std::size_t i = 0; i < count; ++i) {
      states_[i].pose = poses[i];
      init_doors(states_[i]);
    }
    filter_.reset(states_);
  }

  /// Global localization: poses uniform over the grid's free cells.
  template <class Engine>
  void initialize_uniform(const OccupancyGrid& grid, std::size_t count, Engine& rng,
                          double free_probability = 0.25) {
    const std::vector<Pose2d> poses = sample_free_space_poses(grid, count, rng, free_probability,
                                                              "DoorAwareMcl::initialize_uniform");
    states_.resize(count);
    for (std::size_t i = 0; i < count; ++i) {
      states_[i].pose = poses[i];
      init_doors(states_[i]);
    }
    filter_.reset(states_);
  }

  /// Prepares a scan taken by a sensor at `sensor_pose` in the robot frame (buffers reused).
  /// Throws invalid_argument for a non-finite sensor pose.
  template <class S>
  void prepare(const LaserScan<S>& scan, const Pose2d& sensor_pose,
               DoorAwareObservation& out) const {
    namespace bg = boost::geometry;
    using BgPoint = bg::model::d2::point_xy<double>;
    using Line = bg::model::linestring<BgPoint>;
    detail::require_finite("DoorAwareMcl::prepare", "sensor_pose.x", sensor_pose.x);
    detail::require_finite("DoorAwareMcl::prepare", "sensor_pose.y", sensor_pose.y);
    detail::require_finite("DoorAwareMcl::prepare", "sensor_pose.theta", sensor_pose.theta);
    out.end_points.clear();
    out.segments.clear();
    const auto& valid = scan.valid_indices();
    for_each_used_beam(valid.size(), params_.field, [&](std::size_t k) {
      const auto& q = scan.point(valid[k]);
      out.end_points.push_back(
          sensor_pose.transform_point(Point2d(double(q.x()), double(q.y()))).cast<float>());
    });
    // Runs of neighbouring valid beams without a jump, each simplified by Douglas-Peucker.
    Line run, simple;
    const auto flush = [&] {
      if (run.size() >= 2) {
        simple.clear();
        bg::simplify(run, simple, params_.dp_epsilon);
        for (std::size_t i = 1; i < simple.size(); ++i)
          out.segments.emplace_back(Point2d(simple[i - 1].x(), simple[i - 1].y()),
                                    Point2d(simple[i].x(), simple[i].y()));
      }
      run.clear();
    };
    const double jump_sq = params_.jump_distance * params_.jump_distance;
    Point2d last(0, 0);
    for (std::size_t k = 0; k < valid.size(); ++k) {
      const auto& q = scan.point(valid[k]);
      const Point2d p = sensor_pose.transform_point(Point2d(double(q.x()), double(q.y())));
      if (!run.empty() && ((p - last).squaredNorm() > jump_sq || valid[k] != valid[k - 1] + 1))
        flush();
      run.emplace_back(p.x(), p.y());
      last = p;
    }
    flush();
  }

  /// One step of §IV: sampling, importance (Eq. 5-6), door state update, resampling. Throws
  /// invalid_argument before initialisation and for a non-finite odometry reading.
  template <class Engine>
  void update(const OdometryReading& u, const DoorAwareObservation& z, Engine& rng) {
    if (filter_.empty()) detail::throw_invalid("DoorAwareMcl::update", "not initialised");
    OdometryMotionModel::validate(u, "DoorAwareMcl::update");
    const double var_d = params_.sigma_d * params_.sigma_d;
    for (auto& p : filter_.particles()) {
      p.state.pose = motion_.sample(p.state.pose, u, rng);
      for (std::size_t k = 0; k < doors_.size(); ++k)
        p.state.doors[k].variance += var_d;
    }
    const Weigher weigher{this};
    filter_.update(weigher, z);
    for (auto& p : filter_.particles())
      update_doors(p.state, z, segments_);
    const std::size_t target =
        params_.sampling.adapt_particle_count
            ? kld_particle_count(
                  filter_.particles(), [](const auto& p) -> const Pose2d& { return p.state.pose; },
                  params_.sampling, bins_)
            : filter_.size();
    if (target != filter_.size() ||
        filter_.effective_sample_size() <
            params_.sampling.resample_threshold * static_cast<double>(filter_.size()))
      filter_.resample(target, rng);
  }

  /// Number of particles.
  [[nodiscard]] std::size_t particle_count() const { return filter_.size(); }

  /// Weighted mean pose. Throws invalid_argument before initialisation.
  [[nodiscard]] Pose2d estimate() const {
    if (filter_.empty()) detail::throw_invalid("DoorAwareMcl::estimate", "not initialised");
    double x = 0, y = 0, c = 0, s = 0;
    for (const auto& p : filter_.particles()) {
      x += p.weight * p.state.pose.x;
      y += p.weight * p.state.pose.y;
      c += p.weight * std::cos(p.state.pose.theta);
      s += p.weight * std::sin(p.state.pose.theta);
    }
    return {x, y, std::atan2(s, c)};
  }

  /// Weighted mean opening angle of door k (relative to its reference angle). Throws
  /// invalid_argument before initialisation and for k >= doors().size().
  [[nodiscard]] double door_angle(std::size_t k) const {
    require_door(k, "DoorAwareMcl::door_angle");
    double a = 0;
    for (const auto& p : filter_.particles())
      a += p.weight * p.state.doors[k].mean;
    return a;
  }

  /// Door k's opening angle over the particle set: the weighted mean of the particles' means and
  /// the variance of the mixture (mean of their variances plus the spread of their means).
  [[nodiscard]] DoorAngleEstimate door_estimate(std::size_t k) const {
    require_door(k, "DoorAwareMcl::door_estimate");
    const double mean = door_angle(k);
    double var = 0;
    for (const auto& p : filter_.particles()) {
      const double d = p.state.doors[k].mean - mean;
      var += p.weight * (p.state.doors[k].variance + d * d);
    }
    return {mean, var};
  }

  /// log p(z_j | x, doors) of one beam end point `e` in the map frame: the better of the static
  /// map's likelihood field and the leaves of the doors at the angles estimated in `x` (maximum
  /// likelihood association, §IV.2); the door term is Eq. (6) to first order. x.pose is not used.
  [[nodiscard]] double end_point_log_likelihood(const Point2d& e, const DoorAwareState& x) const {
    const double sigma_sq = params_.field.sigma_hit * params_.field.sigma_hit;
    const double z_rand = params_.field.z_rand / params_.field.range_max;
    double best = field_.log_likelihood_at(e);
    for (std::size_t k = 0; k < doors_.size(); ++k) {
      const DoorModel& d = doors_[k];
      const Point2d r = e - d.hinge;
      const double reach = d.leaf_length + 3 * params_.field.sigma_hit;
      if (r.squaredNorm() > reach * reach) continue;
      const double a = d.reference_angle + x.doors[k].mean;
      const Point2d dir(std::cos(a), std::sin(a));
      const double t = std::clamp(r.dot(dir), 0.0, d.leaf_length);
      const double dist_sq = (r - t * dir).squaredNorm();
      // Eq. (6) to first order: the distance moves by t per radian of the leaf.
      const double var = sigma_sq + t * t * x.doors[k].variance;
      const double p = params_.field.z_hit * std::exp(-0.5 * dist_sq / var) /
                           std::sqrt(2 * std::numbers::pi * var) +
                       z_rand;
      best = std::max(best, std::log(p));
    }
    return best;
  }

  /// log p(z | x, doors) of one particle (Eq. 5, ML association per beam, Eq. 6 linearised):
  /// the sum over the end points of end_point_log_likelihood(), computed with the same
  /// arithmetic but without the work that cannot change the maximum (see build_cell_tables()):
  /// only the doors whose leaf can reach the end point's cell are tested, the leaf directions
  /// are computed once per particle, and a door term whose Gaussian is bounded below the static
  /// map's term is not evaluated (no exp/log).
  [[nodiscard]] double log_likelihood(const DoorAwareState& x,
                                      const DoorAwareObservation& z) const {
    const double c = std::cos(x.pose.theta), s = std::sin(x.pose.theta);
    const double sigma_sq = params_.field.sigma_hit * params_.field.sigma_hit;
    const double z_rand = params_.field.z_rand / params_.field.range_max;
    std::array<Point2d, max_tracked_doors> dir;
    for (std::size_t k = 0; k < doors_.size(); ++k) {
      const double a = doors_[k].reference_angle + x.doors[k].mean;
      dir[k] = Point2d(std::cos(a), std::sin(a));
    }
    double sum = 0;
    for (const Eigen::Vector2f& q : z.end_points) {
      const Point2d e(x.pose.x + c * q.x() - s * q.y(), x.pose.y + s * q.x() + c * q.y());
      const std::ptrdiff_t i = field_.cell_index(e);
      double best = field_.log_likelihood_of_cell(i);
      const auto cell = i < 0 ? off_map_cell_ : cells_[static_cast<std::size_t>(i)];
      for (std::uint32_t mask = cell.doors; mask != 0; mask &= mask - 1) {
        const auto k = static_cast<std::size_t>(std::countr_zero(mask));
        const DoorModel& d = doors_[k];
        const Point2d r = e - d.hinge;
        const double reach = d.leaf_length + 3 * params_.field.sigma_hit;
        if (r.squaredNorm() > reach * reach) continue;
        const double t = std::clamp(r.dot(dir[k]), 0.0, d.leaf_length);
        const double dist_sq = (r - t * dir[k]).squaredNorm();
        const double var = sigma_sq + t * t * x.doors[k].variance;
        if (0.5 * dist_sq > cell.max_exponent * var) continue;  // cannot beat `best`
        const double p = params_.field.z_hit * std::exp(-0.5 * dist_sq / var) /
                             std::sqrt(2 * std::numbers::pi * var) +
                         z_rand;
        best = std::max(best, std::log(p));
      }
      sum += best;
    }
    return sum;
  }

 private:
  void require_door(std::size_t k, std::string_view where) const {
    if (filter_.empty()) detail::throw_invalid(where, "not initialised");
    if (k >= doors_.size())
      detail::throw_invalid_argument(where, "k", k,
                                     "must be < doors().size() = " + std::to_string(doors_.size()));
  }

  struct Weigher {
    const DoorAwareMcl* self;
    [[nodiscard]] double log_likelihood(const DoorAwareState& x,
                                        const DoorAwareObservation& z) const {
      return self->log_likelihood(x, z);
    }
  };

  void init_doors(DoorAwareState& x) const {
    for (std::size_t k = 0; k < doors_.size(); ++k) {
      const double range = doors_[k].opening_max - doors_[k].opening_min;
      x.doors[k] = {doors_[k].opening_min + range / 2,
                    std::max(range * range / 12, params_.angle_sigma * params_.angle_sigma)};
    }
  }

  /// Per grid cell: the doors whose leaf term end_point_log_likelihood() can evaluate for an
  /// end point in the cell, and the largest exponent 0.5 d^2 / var with which a door's term can
  /// still exceed the cell's static term.
  struct CellDoors {
    std::uint32_t doors{0};  ///< bit k: door k's reach (leaf + 3 sigma_hit) meets the cell
    float max_exponent{std::numeric_limits<float>::infinity()};  ///< rounded up
  };

  /// Precomputes CellDoors over the grid (and for end points off the map). Both are exact
  /// bounds, not approximations: the reach test is the one end_point_log_likelihood() makes,
  /// widened to the whole cell, and with var >= sigma_hit^2 a door term
  /// z_hit exp(-q) / sqrt(2 pi var) + z_rand / z_max (q = 0.5 d^2 / var) is at most
  /// z_hit exp(-q) / (sigma_hit sqrt(2 pi)) + z_rand / z_max, which stays below the static term
  /// exp(best) (by a relative 1e-12, far above the rounding of exp and log) once
  /// q > -log((exp(best) (1 - 1e-12) - z_rand / z_max) / z_hit * sigma_hit sqrt(2 pi)):
  /// log(p) < best then, and max(best, log(p)) is best.
  void build_cell_tables(const OccupancyGrid& grid) {
    const double s = params_.field.sigma_hit;
    const double z_rand = params_.field.z_rand / params_.field.range_max;
    const auto max_exponent = [&](double best) {
      constexpr float never = std::numeric_limits<float>::infinity();
      if (!(params_.field.z_hit > 0)) return never;
      const double g = (std::exp(best) * (1 - 1e-12) - z_rand) / params_.field.z_hit;
      if (!(g > 0)) return never;
      const double q = -std::log(g * s * std::sqrt(2 * std::numbers::pi));
      // A margin over the rounding of q and of the test's product; the float is rounded up.
      const double bound = q + 1e-9 * (1 + std::abs(q));
      const auto f = static_cast<float>(bound);
      return double(f) >= bound ? f : std::nextafter(f, std::numeric_limits<float>::infinity());
    };
    const auto reach_of = [&](const DoorModel& d) {
      return d.leaf_length + 3 * params_.field.sigma_hit + 1e-9;
    };
    const double res = grid.resolution();
    cells_.assign(grid.cell_count(), CellDoors{});
    for (int y = 0; y < grid.height(); ++y)
      for (int x = 0; x < grid.width(); ++x) {
        const std::size_t i = grid.linear({x, y});
        const Point2d lo(grid.origin().x() + x * res, grid.origin().y() + y * res);
        const Point2d hi = lo + Point2d(res, res);
        for (std::size_t k = 0; k < doors_.size(); ++k) {
          // Distance from the hinge to the cell's square.
          const Point2d& h = doors_[k].hinge;
          const Point2d gap = (lo - h).cwiseMax(h - hi).cwiseMax(0.0);
          if (gap.norm() <= reach_of(doors_[k])) cells_[i].doors |= std::uint32_t{1} << k;
        }
        if (cells_[i].doors != 0)
          cells_[i].max_exponent =
              max_exponent(field_.log_likelihood_of_cell(static_cast<std::ptrdiff_t>(i)));
      }
    off_map_cell_.doors = doors_.empty() ? 0 : (std::uint32_t{1} << doors_.size()) - 1;
    off_map_cell_.max_exponent = max_exponent(field_.log_likelihood_of_cell(-1));
  }

  /// Step 3: a measured angle per door from the scan's segments seen from the particle's pose,
  /// fused by a linear Kalman filter (H = 1). The segments are transformed once per particle;
  /// a segment is tested against a door only when its bounding box, widened by the largest
  /// distance from the hinge either test below accepts (an end within hinge_tolerance; a line
  /// within hinge_line_distance of the hinge whose segment starts within 0.1 leaf lengths of
  /// it), holds the hinge: the other segments fail both tests, so the result is the same.
  void update_doors(DoorAwareState& x, const DoorAwareObservation& z,
                    std::vector<std::pair<Point2d, Point2d>>& segments) const {
    const double c = std::cos(x.pose.theta), s = std::sin(x.pose.theta);
    const auto to_map = [&](const Point2d& q) {
      return Point2d(x.pose.x + c * q.x() - s * q.y(), x.pose.y + s * q.x() + c * q.y());
    };
    segments.clear();
    for (const auto& [qa, qb] : z.segments)
      segments.emplace_back(to_map(qa), to_map(qb));
    const double r_var = params_.angle_sigma * params_.angle_sigma;
    const double hinge_sq = params_.hinge_tolerance * params_.hinge_tolerance;
    for (std::size_t k = 0; k < doors_.size(); ++k) {
      const DoorModel& d = doors_[k];
      const double lo = d.opening_min - params_.range_margin;
      const double hi = d.opening_max + params_.range_margin;
      const double box =
          std::max(params_.hinge_tolerance, params_.hinge_line_distance + 0.1 * d.leaf_length) +
          1e-3;
      bool found = false;
      double measured = 0, fallback = 0, fallback_length = 0;
      for (const auto& [a, b] : segments) {
        if (d.hinge.x() < std::min(a.x(), b.x()) - box ||
            d.hinge.x() > std::max(a.x(), b.x()) + box ||
            d.hinge.y() < std::min(a.y(), b.y()) - box ||
            d.hinge.y() > std::max(a.y(), b.y()) + box)
          continue;
        const double da = (a - d.hinge).squaredNorm(), db = (b - d.hinge).squaredNorm();
        const Point2d far = da < db ? b : a;
        const double length = (b - a).norm();
        if (std::min(da, db) < hinge_sq &&
            std::abs((far - d.hinge).norm() - d.leaf_length) < params_.length_tolerance) {
          const double opening = angle_difference(
              std::atan2(far.y() - d.hinge.y(), far.x() - d.hinge.x()), d.reference_angle);
          if (opening >= lo && opening <= hi) {
            measured = opening;
            found = true;
            break;
          }
        }
        // A door flush with its wall merges with it: a longer segment whose line passes through
        // the hinge still gives the leaf's direction (up to a half turn).
        if (length > d.leaf_length && length > fallback_length) {
          const Point2d u = (b - a) / length;
          const Point2d h = d.hinge - a;
          if (std::abs(u.x() * h.y() - u.y() * h.x()) < params_.hinge_line_distance) {
            for (const double flip : {0.0, std::numbers::pi}) {
              const double opening =
                  angle_difference(std::atan2(u.y(), u.x()) + flip, d.reference_angle);
              // It must run over the whole leaf, not merely lie on the line through the hinge
              // (the walls beside an open door do that).
              const double leaf = d.reference_angle + opening;
              const Point2d v(std::cos(leaf), std::sin(leaf));
              const double pa = (a - d.hinge).dot(v), pb = (b - d.hinge).dot(v);
              const bool covers =
                  std::min(pa, pb) < 0.1 * d.leaf_length && std::max(pa, pb) > 0.9 * d.leaf_length;
              if (opening >= lo && opening <= hi && covers) {
                fallback = opening;
                fallback_length = length;
              }
            }
          }
        }
      }
      if (!found && fallback_length > 0) {
        measured = fallback;
        found = true;
      }
      if (!found) continue;
      DoorAngleEstimate& e = x.doors[k];
      const double gain = e.variance / (e.variance + r_var);
      e.mean += gain * (measured - e.mean);
      e.variance *= 1 - gain;
    }
  }

  DoorAwareMclParams params_;
  OdometryMotionModel motion_;
  LikelihoodFieldModel field_;
  std::vector<DoorModel> doors_;
  ParticleFilter<DoorAwareState> filter_;
  std::vector<DoorAwareState> states_;
  std::vector<std::pair<std::uint64_t, double>> bins_;  ///< scratch for the KLD count
  std::vector<CellDoors> cells_;                        ///< per grid cell (build_cell_tables)
  CellDoors off_map_cell_;                              ///< for end points off the grid
  std::vector<std::pair<Point2d, Point2d>> segments_;   ///< scratch: a particle's segments
};

}  // namespace rangenav
