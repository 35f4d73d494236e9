// Monte-Carlo localization (paper 001 §IV, issue 8): time of one filter update per scan (odometry
// sampling, likelihood-field weighting of 181 beams, low-variance resampling) for 1k, 10k and 50k
// particles on one core, in the simulated office corridor. Goal: 10k particles at >= 30 Hz.
// The paper found 50k particles too slow on its robot.
//
//   bench_mcl                                   everything
//   bench_mcl --benchmark_filter=update         the full update
//   bench_mcl --benchmark_filter=weight         the sensor model alone
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/localization/mcl.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

using namespace rangenav;

namespace {

struct Setup {
  sim::Scene scene = sim::office_corridor();
  OccupancyGrid grid = OccupancyGrid::covering({0, -4}, {20, 6}, 0.5);
  std::vector<LaserScand> scans;  // 181 beams along the corridor, 0.1 m apart
  std::vector<Pose2d> poses;

  Setup() {
    const sim::LaserScanner2D mapping_laser;
    std::mt19937_64 rng(1);
    for (int k = 0; k <= 94; ++k) {
      const Pose2d pose{0.6 + 0.2 * k, 1.0, 0.0};
      grid.integrate(pose, mapping_laser.scan(scene.world, pose, rng));
    }
    sim::LaserScannerParams p;
    p.geometry = ScanGeometry<double>::from_fov(std::numbers::pi, deg_to_rad(1.0), 0.05, 30.0);
    const sim::LaserScanner2D laser(p);
    for (int k = 0; k < 100; ++k) {
      poses.push_back({2.0 + 0.1 * k, 1.0, 0.0});
      scans.push_back(laser.scan(scene.world, poses.back(), rng));
    }
  }
};

const Setup& setup() {
  static const Setup s;
  return s;
}

/// Every beam of the scan (the issue asks for 181; the default model keeps 30).
LikelihoodFieldParams all_beams() {
  LikelihoodFieldParams p;
  p.max_beams = 0;
  return p;
}

MclParams fixed_count(std::size_t n) {
  MclParams p;
  p.min_particles = n;
  p.max_particles = n;
  p.adapt_particle_count = false;
  p.resample_threshold = 1.0;  // resample every update: the worst case
  return p;
}

void BM_mcl_update(benchmark::State& state) {
  const Setup& s = setup();
  const auto n = static_cast<std::size_t>(state.range(0));
  MonteCarloLocalization<> mcl(OdometryMotionModel(), LikelihoodFieldModel(s.grid, all_beams()),
                               fixed_count(n));
  std::mt19937_64 rng(7);
  mcl.initialize_gaussian(s.poses.front(), {0.2, 0.2, 0.05}, n, rng);
  LikelihoodFieldModel::Observation z;
  std::size_t k = 0;
  for (auto _ : state) {
    const std::size_t i = k % s.scans.size(), j = (k + 1) % s.scans.size();
    state.PauseTiming();
    mcl.sensor_model().prepare(s.scans[j], Pose2d{}, z);
    state.ResumeTiming();
    mcl.update(OdometryReading{s.poses[i], s.poses[j]}, z, rng);
    benchmark::DoNotOptimize(mcl.filter().particles().data());
    ++k;
  }
  state.counters["beams"] = static_cast<double>(z.end_points.size());
  state.counters["Hz"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_mcl_update)->Arg(1000)->Arg(10000)->Arg(50000)->Unit(benchmark::kMillisecond);

void BM_mcl_weight(benchmark::State& state) {
  const Setup& s = setup();
  const auto n = static_cast<std::size_t>(state.range(0));
  const LikelihoodFieldModel field(s.grid, all_beams());
  const auto z = field.prepare(s.scans[10]);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.2);
  std::vector<Pose2d> particles(n);
  for (auto& p : particles)
    p = {s.poses[10].x + noise(rng), s.poses[10].y + noise(rng), noise(rng)};
  for (auto _ : state) {
    double sum = 0;
    for (const auto& p : particles)
      sum += field.log_likelihood(p, z);
    benchmark::DoNotOptimize(sum);
  }
  state.counters["beams"] = static_cast<double>(z.end_points.size());
}
BENCHMARK(BM_mcl_weight)->Arg(1000)->Arg(10000)->Arg(50000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
