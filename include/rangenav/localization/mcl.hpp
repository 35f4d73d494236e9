#pragma once
// Monte-Carlo localization (Probabilistic Robotics, Table 8.2) of a planar pose on top of the
// generic ParticleFilter: any MotionModel over OdometryReading and any SensorModel over Pose2d
// plug in (by default the odometry motion model and the likelihood field). Per update:
// sample the motion, weight by the scan, then resample with low-variance resampling when the
// effective sample size falls below a fraction of the particles. The particle count adapts to
// the pose uncertainty with KLD-sampling's bound (Fox 2003): with k histogram bins of
// (x, y, theta) holding weight,
//   n = (k - 1) / (2 epsilon) * (1 - 2 / (9 (k - 1)) + sqrt(2 / (9 (k - 1))) z_{1-delta})^3,
// clamped to [min_particles, max_particles]: many particles while the belief is spread (global
// localization), few once it has converged (tracking). A bin counts when it holds at least the
// weight of one particle, i.e. when resampling is expected to draw from it.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <random>
#include <span>
#include <string_view>
#include <utility>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/localization/free_space_sampling.hpp"
#include "rangenav/localization/likelihood_field.hpp"
#include "rangenav/localization/odometry_motion_model.hpp"
#include "rangenav/localization/particle_filter.hpp"
#include "rangenav/mapping/occupancy_grid.hpp"

namespace rangenav {

/// Parameters of MonteCarloLocalization: particle counts, KLD-sampling and resampling.
struct MclParams {
  std::size_t min_particles{500};           ///< KLD lower bound (>= 1)
  std::size_t max_particles{50000};         ///< KLD upper bound (>= min_particles)
  bool adapt_particle_count{true};          ///< false: keep the count given at initialisation
  double kld_epsilon{0.05};                 ///< KL bound between sample and true posterior
  double kld_z{2.326};                      ///< upper 1 - delta quantile of N(0, 1), delta = 0.01
  double bin_size_xy{0.5};                  ///< KLD histogram bin (m)
  double bin_size_theta{deg_to_rad(10.0)};  ///< KLD histogram bin (rad)
  double resample_threshold{0.5};           ///< resample when N_eff < this * N, in (0, 1]

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where) const {
    if (min_particles == 0)
      detail::throw_invalid_argument(where, "min_particles", min_particles, "must be >= 1");
    if (max_particles < min_particles)
      detail::throw_invalid_argument(where, "max_particles", max_particles,
                                     "must be >= min_particles = " + std::to_string(min_particles));
    detail::require_particle_count(where, "max_particles", max_particles);
    detail::require_positive(where, "kld_epsilon", kld_epsilon);
    detail::require_finite(where, "kld_z", kld_z);
    detail::require_positive(where, "bin_size_xy", bin_size_xy);
    detail::require_positive(where, "bin_size_theta", bin_size_theta);
    if (!(resample_threshold > 0 && resample_threshold <= 1))
      detail::throw_invalid_argument(where, "resample_threshold", resample_threshold,
                                     "must be in (0, 1]");
  }
};

namespace detail {
/// `count` poses drawn from N(mean, diag(sigma^2)), headings normalised; the initialisation of
/// both filters. Throws invalid_argument naming `where` for a non-finite mean, a negative or
/// non-finite sigma, or a drawn pose that is not finite (mean and sigma too large).
template <class Engine>
[[nodiscard]] std::vector<Pose2d> sample_gaussian_poses(const Pose2d& mean,
                                                        const Eigen::Vector3d& sigma,
                                                        std::size_t count, Engine& rng,
                                                        std::string_view where) {
  require_finite(where, "mean.x", mean.x);
  require_finite(where, "mean.y", mean.y);
  require_finite(where, "mean.theta", mean.theta);
  if (!(sigma.allFinite() && (sigma.array() >= 0).all()))
    throw_invalid(where, "sigma must be finite and >= 0");
  const auto draw = [&](double s) {
    return s > 0 ? std::normal_distribution<double>(0.0, s)(rng) : 0.0;
  };
  std::vector<Pose2d> poses(count);
  for (auto& x : poses) {
    x.x = mean.x + draw(sigma.x());
    x.y = mean.y + draw(sigma.y());
    x.theta = normalize_angle(mean.theta + draw(sigma.z()));
    if (!(std::isfinite(x.x) && std::isfinite(x.y) && std::isfinite(x.theta)))
      throw_invalid(where,
                    "a pose drawn from N(mean, sigma^2) is not finite: mean or sigma "
                    "too large");
  }
  return poses;
}
}  // namespace detail

/// KLD-sampling's particle count for k occupied bins (before clamping).
[[nodiscard]] inline double kld_particle_bound(std::size_t k, double epsilon, double z) {
  if (k <= 1) return 1.0;
  const double km1 = static_cast<double>(k - 1);
  const double a = 2.0 / (9.0 * km1);
  const double b = 1.0 - a + std::sqrt(a) * z;
  return km1 / (2.0 * epsilon) * b * b * b;
}

/// KLD-sampling's particle count (clamped to [min_particles, max_particles]) for a weighted
/// particle set whose poses `pose_of(particle)` returns; `bins` is scratch (reused).
template <class State, class PoseOf>
[[nodiscard]] std::size_t kld_particle_count(const std::vector<Particle<State>>& ps, PoseOf pose_of,
                                             const MclParams& params,
                                             std::vector<std::pair<std::uint64_t, double>>& bins) {
  bins.clear();
  const double inv_xy = 1.0 / params.bin_size_xy, inv_th = 1.0 / params.bin_size_theta;
  // The key keeps 21 bits per axis; saturating first keeps a far (or NaN) pose from overflowing
  // the conversion (such a user motion model's particles share the edge bins).
  const auto bin = [](double v) {
    constexpr double bound = double(std::int64_t{1} << 40);
    if (!(v > -bound)) return -(std::int64_t{1} << 40);
    if (!(v < bound)) return std::int64_t{1} << 40;
    return static_cast<std::int64_t>(std::floor(v));
  };
  for (const auto& p : ps) {
    const Pose2d& x = pose_of(p);
    const auto bx = bin(x.x * inv_xy);
    const auto by = bin(x.y * inv_xy);
    const auto bt = bin(x.theta * inv_th);
    const std::uint64_t key = (static_cast<std::uint64_t>(bx & 0x1FFFFF) << 42) |
                              (static_cast<std::uint64_t>(by & 0x1FFFFF) << 21) |
                              static_cast<std::uint64_t>(bt & 0x1FFFFF);
    bins.emplace_back(key, p.weight);
  }
  std::sort(bins.begin(), bins.end());
  const double one_particle = 1.0 / static_cast<double>(ps.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < bins.size();) {
    double w = 0;
    const std::uint64_t key = bins[i].first;
    for (; i < bins.size() && bins[i].first == key; ++i)
      w += bins[i].second;
    if (w >= one_particle) ++k;
  }
  const double n = kld_particle_bound(k, params.kld_epsilon, params.kld_z);
  return std::clamp(static_cast<std::size_t>(std::ceil(n)), params.min_particles,
                    params.max_particles);
}

/// Monte-Carlo localization (Probabilistic Robotics Table 8.2 with KLD-sampling, Table 8.4)
/// over any MotionModel and SensorModel of a Pose2d.
template <class Motion = OdometryMotionModel, class Sensor = LikelihoodFieldModel>
class MonteCarloLocalization {
 public:
  /// A filter with these models and parameters and no particles (initialize_* next).
  MonteCarloLocalization(Motion motion, Sensor sensor, const MclParams& params = {})
      : motion_(std::move(motion)), sensor_(std::move(sensor)), params_(params) {
    params_.validate("MonteCarloLocalization");
  }

  /// The parameters.
  [[nodiscard]] const MclParams& params() const { return params_; }
  /// The motion model.
  [[nodiscard]] const Motion& motion_model() const { return motion_; }
  /// The sensor model (prepare observations with it).
  [[nodiscard]] const Sensor& sensor_model() const { return sensor_; }
  /// The particles.
  [[nodiscard]] const ParticleFilter<Pose2d>& filter() const { return filter_; }
  /// Number of particles.
  [[nodiscard]] std::size_t particle_count() const { return filter_.size(); }

  /// Starts from `count` poses drawn from N(mean, diag(sigma^2)) (position tracking). Throws
  /// invalid_argument for count == 0, a non-finite mean, a negative or non-finite sigma, or a
  /// mean and sigma so large that a drawn pose is not finite.
  template <class Engine>
  void initialize_gaussian(const Pose2d& mean, const Eigen::Vector3d& sigma, std::size_t count,
                           Engine& rng) {
    constexpr std::string_view where = "MonteCarloLocalization::initialize_gaussian";
    detail::require_particle_count(where, "count", count);
    states_ = detail::sample_gaussian_poses(mean, sigma, count, rng, where);
    filter_.reset(states_);
  }

  /// Global localization: `count` poses uniform over the grid's free cells (probability below
  /// `free_probability`) with uniform headings. Throws when the grid has no free cell.
  template <class Engine>
  void initialize_uniform(const OccupancyGrid& grid, std::size_t count, Engine& rng,
                          double free_probability = 0.25) {
    states_ = sample_free_space_poses(grid, count, rng, free_probability,
                                      "MonteCarloLocalization::initialize_uniform");
    filter_.reset(states_);
  }

  /// One filter step: motion by the odometry reading, weighting by the observation, adaptive
  /// low-variance resampling. Returns the log marginal likelihood of the observation.
  /// Throws invalid_argument before initialisation and, for a motion model with a static
  /// validate(u, where) (OdometryMotionModel's: finite readings), for a control it rejects.
  template <class Control, class Observation, class Engine>
  double update(const Control& u, const Observation& z, Engine& rng) {
    constexpr std::string_view where = "MonteCarloLocalization::update";
    if (filter_.empty()) detail::throw_invalid(where, "not initialised");
    if constexpr (requires { Motion::validate(u, where); }) Motion::validate(u, where);
    filter_.predict(motion_, u, rng);
    const double log_marginal = filter_.update(sensor_, z);
    const std::size_t target = params_.adapt_particle_count ? kld_count() : filter_.size();
    if (target != filter_.size() ||
        filter_.effective_sample_size() <
            params_.resample_threshold * static_cast<double>(filter_.size()))
      filter_.resample(target, rng);
    return log_marginal;
  }

  /// Weighted mean pose (circular mean of the headings). Throws invalid_argument before
  /// initialisation.
  [[nodiscard]] Pose2d estimate() const {
    if (filter_.empty())
      detail::throw_invalid("MonteCarloLocalization::estimate", "not initialised");
    double x = 0, y = 0, c = 0, s = 0;
    for (const auto& p : filter_.particles()) {
      x += p.weight * p.state.x;
      y += p.weight * p.state.y;
      c += p.weight * std::cos(p.state.theta);
      s += p.weight * std::sin(p.state.theta);
    }
    return {x, y, std::atan2(s, c)};
  }

  /// Weighted covariance of (x, y, theta) about estimate() (heading differences wrapped).
  [[nodiscard]] Eigen::Matrix3d covariance() const {
    if (filter_.empty())
      detail::throw_invalid("MonteCarloLocalization::covariance", "not initialised");
    const Pose2d m = estimate();
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& p : filter_.particles()) {
      const Eigen::Vector3d d(p.state.x - m.x, p.state.y - m.y,
                              normalize_angle(p.state.theta - m.theta));
      cov += p.weight * d * d.transpose();
    }
    return cov;
  }

  /// KLD-sampling's particle count for the current weighted set.
  [[nodiscard]] std::size_t kld_count() {
    return kld_particle_count(
        filter_.particles(), [](const auto& p) -> const Pose2d& { return p.state; }, params_,
        bins_);
  }

 private:
  Motion motion_;
  Sensor sensor_;
  MclParams params_;
  ParticleFilter<Pose2d> filter_;
  std::vector<Pose2d> states_;                          ///< scratch for initialisation
  std::vector<std::pair<std::uint64_t, double>> bins_;  ///< scratch for kld_count()
};

}  // namespace rangenav
