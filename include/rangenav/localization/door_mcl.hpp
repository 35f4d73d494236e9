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
#include <boost/geometry.hpp>
#include <boost/geometry/geometries/linestring.hpp>
#include <boost/geometry/geometries/point_xy.hpp>
#include <cmath>
#include <cstddef>
#include <cstdint>
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
  double mean{0};
  double variance{0};
};

/// A particle's state: the pose and the door angle estimates (doors beyond the map's count are
/// unused).
struct DoorAwareState {
  Pose2d pose{};
  std::array<DoorAngleEstimate, max_tracked_doors> doors{};
};

struct DoorAwareMclParams {
  OdometryMotionParams motion{};
  LikelihoodFieldParams field{};
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
  std::vector<Eigen::Vector2f> end_points;
  std::vector<std::pair<Point2d, Point2d>> segments;
};

class DoorAwareMcl {
 public:
  /// `grid` is the static map with the doors removed (remove_doors()); `doors` the detected doors.
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
  }

  [[nodiscard]] const DoorAwareMclParams& params() const { return params_; }
  [[nodiscard]] const std::vector<DoorModel>& doors() const { return doors_; }
  [[nodiscard]] const ParticleFilter<DoorAwareState>& filter() const { return filter_; }
  [[nodiscard]] const LikelihoodFieldModel& field() const { return field_; }

  /// Poses from N(mean, diag(sigma^2)); each door's angle starts uniform over its observed range
  /// (mean in the middle, variance range^2 / 12).
  template <class Engine>
  void initialize_gaussian(const Pose2d& mean, const Eigen::Vector3d& sigma, std::size_t count,
                           Engine& rng) {
    constexpr std::string_view where = "DoorAwareMcl::initialize_gaussian";
    if (count == 0) detail::throw_invalid_argument(where, "count", count, "must be > 0");
    if (!(sigma.allFinite() && (sigma.array() >= 0).all()))
      detail::throw_invalid(where, "sigma must be finite and >= 0");
    const auto draw = [&](double s) {
      return s > 0 ? std::normal_distribution<double>(0.0, s)(rng) : 0.0;
    };
    states_.resize(count);
    for (auto& x : states_) {
      x.pose = {mean.x + draw(sigma.x()), mean.y + draw(sigma.y()),
                normalize_angle(mean.theta + draw(sigma.z()))};
      init_doors(x);
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
  template <class S>
  void prepare(const LaserScan<S>& scan, const Pose2d& sensor_pose,
               DoorAwareObservation& out) const {
    namespace bg = boost::geometry;
    using BgPoint = bg::model::d2::point_xy<double>;
    using Line = bg::model::linestring<BgPoint>;
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

  /// One step of §IV: sampling, importance (Eq. 5-6), door state update, resampling.
  template <class Engine>
  void update(const OdometryReading& u, const DoorAwareObservation& z, Engine& rng) {
    if (filter_.empty()) detail::throw_invalid("DoorAwareMcl::update", "not initialised");
    const double var_d = params_.sigma_d * params_.sigma_d;
    for (auto& p : filter_.particles()) {
      p.state.pose = motion_.sample(p.state.pose, u, rng);
      for (std::size_t k = 0; k < doors_.size(); ++k)
        p.state.doors[k].variance += var_d;
    }
    const Weigher weigher{this};
    filter_.update(weigher, z);
    for (auto& p : filter_.particles())
      update_doors(p.state, z);
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

  [[nodiscard]] std::size_t particle_count() const { return filter_.size(); }

  /// Weighted mean pose.
  [[nodiscard]] Pose2d estimate() const {
    double x = 0, y = 0, c = 0, s = 0;
    for (const auto& p : filter_.particles()) {
      x += p.weight * p.state.pose.x;
      y += p.weight * p.state.pose.y;
      c += p.weight * std::cos(p.state.pose.theta);
      s += p.weight * std::sin(p.state.pose.theta);
    }
    return {x, y, std::atan2(s, c)};
  }

  /// Weighted mean opening angle of door k (relative to its reference angle).
  [[nodiscard]] double door_angle(std::size_t k) const {
    double a = 0;
    for (const auto& p : filter_.particles())
      a += p.weight * p.state.doors[k].mean;
    return a;
  }

  /// Door k's opening angle over the particle set: the weighted mean of the particles' means and
  /// the variance of the mixture (mean of their variances plus the spread of their means).
  [[nodiscard]] DoorAngleEstimate door_estimate(std::size_t k) const {
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

  /// log p(z | x, doors) of one particle (Eq. 5, ML association per beam, Eq. 6 linearised).
  [[nodiscard]] double log_likelihood(const DoorAwareState& x,
                                      const DoorAwareObservation& z) const {
    const double c = std::cos(x.pose.theta), s = std::sin(x.pose.theta);
    double sum = 0;
    for (const Eigen::Vector2f& q : z.end_points)
      sum += end_point_log_likelihood(
          Point2d(x.pose.x + c * q.x() - s * q.y(), x.pose.y + s * q.x() + c * q.y()), x);
    return sum;
  }

 private:
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

  /// Step 3: a measured angle per door from the scan's segments seen from the particle's pose,
  /// fused by a linear Kalman filter (H = 1).
  void update_doors(DoorAwareState& x, const DoorAwareObservation& z) const {
    const double c = std::cos(x.pose.theta), s = std::sin(x.pose.theta);
    const auto to_map = [&](const Point2d& q) {
      return Point2d(x.pose.x + c * q.x() - s * q.y(), x.pose.y + s * q.x() + c * q.y());
    };
    const double r_var = params_.angle_sigma * params_.angle_sigma;
    const double hinge_sq = params_.hinge_tolerance * params_.hinge_tolerance;
    for (std::size_t k = 0; k < doors_.size(); ++k) {
      const DoorModel& d = doors_[k];
      const double lo = d.opening_min - params_.range_margin;
      const double hi = d.opening_max + params_.range_margin;
      bool found = false;
      double measured = 0, fallback = 0, fallback_length = 0;
      for (const auto& [qa, qb] : z.segments) {
        const Point2d a = to_map(qa), b = to_map(qb);
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
};

}  // namespace rangenav
