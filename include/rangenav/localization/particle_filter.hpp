#pragma once
// A generic particle filter (Probabilistic Robotics, Table 4.3) over any state type: the motion
// and sensor models are concepts, so a user's models plug in without virtual calls, and the
// state may carry more than a pose (the door-aware filter of paper 001 §IV keeps Kalman-filtered
// door angles in each particle).
//
//   MotionModel<M, State, Control, Engine>   m.sample(state, control, rng) -> State
//   SensorModel<S, State, Observation>       s.log_likelihood(state, observation) -> double
//
// Weights are kept as logarithms and normalised after every update, so hundreds of beams never
// underflow. Resampling is low-variance (systematic) resampling, Table 4.4, which paper 001
// §IV.4 uses against particle depletion. Randomness comes only from the engine passed in: the same
// engine state gives the same particles.
#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <random>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"

namespace rangenav {

template <class M, class State, class Control, class Engine>
concept MotionModel = requires(const M& m, const State& x, const Control& u, Engine& rng) {
  { m.sample(x, u, rng) } -> std::convertible_to<State>;
};

template <class S, class State, class Observation>
concept SensorModel = requires(const S& s, const State& x, const Observation& z) {
  { s.log_likelihood(x, z) } -> std::convertible_to<double>;
};

/// The most particles a filter holds (2^24): a count beyond it is a caller's error, answered
/// before anything is allocated.
inline constexpr std::size_t max_particle_count = std::size_t{1} << 24;

namespace detail {
/// Throws invalid_argument naming `where` unless 0 < count <= max_particle_count.
inline void require_particle_count(std::string_view where, std::string_view name,
                                   std::size_t count) {
  if (count == 0) throw_invalid_argument(where, name, count, "must be > 0");
  if (count > max_particle_count)
    throw_invalid_argument(where, name, count,
                           "must be <= max_particle_count = " + std::to_string(max_particle_count));
}
}  // namespace detail

/// A weighted state.
template <class State>
struct Particle {
  State state{};         ///< the hypothesis
  double weight{0};      ///< normalised: the weights of a filter sum to 1
  double log_weight{0};  ///< log(weight)
};

/// A particle filter over any state type (see the file comment).
template <class State>
class ParticleFilter {
 public:
  /// A particle of this filter.
  using particle_type = Particle<State>;

  ParticleFilter() = default;
  /// Starts from the given states with equal weights.
  explicit ParticleFilter(std::span<const State> states) { reset(states); }

  /// Replaces the particles by `states` with equal weights. Throws for an empty set.
  void reset(std::span<const State> states) {
    if (states.empty()) detail::throw_invalid("ParticleFilter::reset", "states is empty");
    detail::require_particle_count("ParticleFilter::reset", "states.size()", states.size());
    particles_.resize(states.size());
    for (std::size_t i = 0; i < states.size(); ++i)
      particles_[i].state = states[i];
    set_uniform_weights();
  }

  /// Number of particles.
  [[nodiscard]] std::size_t size() const { return particles_.size(); }
  /// True when the filter has no particles.
  [[nodiscard]] bool empty() const { return particles_.empty(); }
  /// The particles.
  [[nodiscard]] const std::vector<particle_type>& particles() const { return particles_; }
  /// The particles, for a filter that edits them (weights must stay normalised).
  [[nodiscard]] std::vector<particle_type>& particles() { return particles_; }

  /// Moves every particle by the motion model (sampling step).
  template <class Motion, class Control, class Engine>
  requires MotionModel<Motion, State, Control, Engine>
  void predict(const Motion& motion, const Control& u, Engine& rng) {
    for (auto& p : particles_)
      p.state = motion.sample(p.state, u, rng);
  }

  /// Multiplies every weight by the observation likelihood and normalises (importance step).
  /// Returns the log of the average likelihood under the previous weights (the observation's
  /// marginal likelihood), which recovery schemes watch.
  template <class Sensor, class Observation>
  requires SensorModel<Sensor, State, Observation>
  double update(const Sensor& sensor, const Observation& z) {
    double max_lw = -std::numeric_limits<double>::infinity();
    for (auto& p : particles_) {
      const double ll = sensor.log_likelihood(p.state, z);
      p.log_weight += std::isfinite(ll) ? ll : -std::numeric_limits<double>::max() / 4;
      max_lw = std::max(max_lw, p.log_weight);
    }
    double sum = 0;
    for (auto& p : particles_)
      sum += std::exp(p.log_weight - max_lw);
    const double log_sum = max_lw + std::log(sum);
    for (auto& p : particles_) {
      p.log_weight -= log_sum;
      p.weight = std::exp(p.log_weight);
    }
    return log_sum;
  }

  /// 1 / sum(w^2): N for equal weights, 1 when one particle holds all the weight.
  [[nodiscard]] double effective_sample_size() const {
    double s = 0;
    for (const auto& p : particles_)
      s += p.weight * p.weight;
    return s > 0 ? 1.0 / s : 0.0;
  }

  /// Low-variance resampling (Probabilistic Robotics, Table 4.4) to `count` particles with
  /// equal weights: one random offset, then `count` evenly spaced pointers into the cumulative
  /// weights. Throws for count == 0 or count > max_particle_count.
  template <class Engine>
  void resample(std::size_t count, Engine& rng) {
    detail::require_particle_count("ParticleFilter::resample", "count", count);
    if (particles_.empty()) detail::throw_invalid("ParticleFilter::resample", "filter is empty");
    scratch_.resize(count);
    const double step = 1.0 / static_cast<double>(count);
    const double r = std::uniform_real_distribution<double>(0.0, step)(rng);
    double c = particles_[0].weight;
    std::size_t i = 0;
    for (std::size_t m = 0; m < count; ++m) {
      const double u = r + static_cast<double>(m) * step;
      while (u > c && i + 1 < particles_.size())
        c += particles_[++i].weight;
      scratch_[m].state = particles_[i].state;
    }
    particles_.swap(scratch_);
    set_uniform_weights();
  }

  /// Resamples to the current particle count.
  template <class Engine>
  void resample(Engine& rng) {
    resample(particles_.size(), rng);
  }

 private:
  void set_uniform_weights() {
    const double w = 1.0 / static_cast<double>(particles_.size());
    for (auto& p : particles_) {
      p.weight = w;
      p.log_weight = std::log(w);
    }
  }

  std::vector<particle_type> particles_;
  std::vector<particle_type> scratch_;  ///< reused by resample()
};

}  // namespace rangenav
