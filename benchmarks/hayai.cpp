// HAYAI (paper 003 §3): time per scan on simulated 181- and 361-beam scans with one thread (the
// paper's budget: 10 ms on a 600 MHz Pentium III; goal here: under 20 µs), and drift on the real
// MIT CSAIL log against the SLAM-benchmark relations (Kümmerle et al. 2009).
//
//   bench_hayai                                    everything
//   bench_hayai --benchmark_filter=track           time per scan only
//   bench_hayai --benchmark_filter=csail           the CSAIL log (skipped when the data is absent)
#include <benchmark/benchmark.h>

#include <cmath>
#include <ctime>
#include <filesystem>
#include <numbers>
#include <optional>
#include <random>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/io/carmen.hpp"
#include "rangenav/io/slam_relations.hpp"
#include "rangenav/registration/hayai.hpp"
#include "rangenav/registration/icp.hpp"
#include "rangenav/search/kd_tree.hpp"
#include "rangenav/sim/world.hpp"

using namespace rangenav;

namespace {

// A 14 m x 8 m hall with pillars and cabinets along the walls: corners and jump edges in view.
sim::World hall() {
  sim::World world;
  const std::vector<Point2d> outline{{-7, -4}, {7, -4}, {7, 4}, {-7, 4}};
  world.add_polygon(outline);
  for (double x : {-4.0, 0.0, 4.0}) {
    world.add_box({{x, 2.0}, {0.5, 0.5}, 0.0, 0.0, 2.0});
    world.add_box({{x + 1.0, -2.2}, {0.6, 0.4}, 0.3, 0.0, 2.0});
  }
  world.add_box({{6.5, 0.0}, {1.0, 2.0}, 0.0, 0.0, 2.0});
  world.build_index();
  return world;
}

LaserScand simulate(const sim::World& world, const Pose2d& pose, std::size_t beams, double sigma,
                    std::mt19937& rng) {
  const ScanGeometry<double> geometry{
      -std::numbers::pi / 2, std::numbers::pi / static_cast<double>(beams - 1), beams, 0.05, 30.0};
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<double> ranges(beams);
  for (std::size_t i = 0; i < beams; ++i) {
    const double phi = pose.theta + geometry.angle(i);
    const auto hit = world.cast_ray_2d(pose.position(), {std::cos(phi), std::sin(phi)}, 0.3, 30.0);
    ranges[i] = hit.hit() ? hit.range + noise(rng) : 30.0;
  }
  return LaserScand(geometry, std::move(ranges));
}

// 4 m/s at 75 Hz (5.3 cm per scan) along the hall and back, turning slightly: the wrap-around
// from the last scan to the first is a small step too.
std::vector<LaserScand> drive(std::size_t beams) {
  const auto world = hall();
  std::mt19937 rng(42);
  std::vector<Pose2d> path;
  Pose2d pose{-5.0, 0.0, 0.0};
  for (int k = 0; k < 180; ++k) {
    path.push_back(pose);
    pose = compose(pose, Pose2d{0.053, 0.0, deg_to_rad(k < 90 ? 0.3 : -0.3)});
  }
  std::vector<LaserScand> scans;
  for (const auto& p : path)
    scans.push_back(simulate(world, p, beams, 0.01, rng));
  for (auto it = path.rbegin(); it != path.rend(); ++it)
    scans.push_back(simulate(world, *it, beams, 0.01, rng));
  return scans;
}

void BM_hayai_track(benchmark::State& state) {
  const auto scans = drive(static_cast<std::size_t>(state.range(0)));
  HayaiTracker<double> tracker;
  std::size_t i = 0, steps = 0, ok = 0, features = 0, matched = 0;
  for (auto _ : state) {
    const auto r = tracker.track(scans[i]);
    benchmark::DoNotOptimize(r);
    i = (i + 1) % scans.size();
    ++steps;
    ok += r.match.ok() ? 1 : 0;
    features += r.match.data_features;
    matched += r.match.matched;
  }
  const auto n = static_cast<double>(steps);
  state.counters["success_rate"] = static_cast<double>(ok) / n;
  state.counters["features"] = static_cast<double>(features) / n;
  state.counters["matched"] = static_cast<double>(matched) / n;
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_hayai_track)->Arg(181)->Arg(361)->Unit(benchmark::kMicrosecond);

void BM_hayai_features(benchmark::State& state) {
  const auto scans = drive(static_cast<std::size_t>(state.range(0)));
  HayaiFeatureExtractor<double> extractor;
  std::vector<HayaiFeature<double>> features;
  std::size_t i = 0;
  for (auto _ : state) {
    extractor.extract(scans[i], features);
    benchmark::DoNotOptimize(features.data());
    i = (i + 1) % scans.size();
  }
}
BENCHMARK(BM_hayai_features)->Arg(181)->Arg(361)->Unit(benchmark::kMicrosecond);

// ---- the MIT CSAIL log -----------------------------------------------------------------------

std::filesystem::path data_dir() {
  if (const char* env = std::getenv("RANGENAV_DATA_DIR"); env && *env) return env;
  return RANGENAV_BENCH_DATA_DIR;
}

struct CsailData {
  std::vector<io::CarmenLaser> lasers;
  std::vector<io::SlamRelation> relations;
};

const CsailData* csail() {
  static const std::optional<CsailData> data = []() -> std::optional<CsailData> {
    const auto log = data_dir() / "carmen/mit-csail.clf.gz";
    const auto rel = data_dir() / "slam-benchmark/mit-csail.relations";
    if (!std::filesystem::exists(log) || !std::filesystem::exists(rel)) return std::nullopt;
    return CsailData{io::read_carmen_lasers(log), io::read_slam_relations(rel)};
  }();
  return data ? &*data : nullptr;
}

// mode 0: HAYAI alone (constant-velocity prediction), 1: HAYAI fused with odometry by the EKF,
// 2: odometry alone (the baseline), 3: the ICP tracker for comparison: scan-to-scan PaperIcp
// (decaying distance + unique pairs, paper 002 §6.3) from the odometry increment, which it keeps
// when the alignment does not converge.
void BM_hayai_csail(benchmark::State& state) {
  const CsailData* data = csail();
  if (data == nullptr) {
    state.SkipWithError("MIT CSAIL log or relations not found under RANGENAV_DATA_DIR");
    return;
  }
  const auto mode = state.range(0);
  io::RelationEvaluation evaluation;
  double seconds = 0;
  std::size_t ok = 0;
  for (auto _ : state) {
    HayaiTracker<double> tracker;
    PaperIcp<2, double> icp;
    Pose2d icp_pose{};
    std::vector<double> stamps;
    std::vector<Pose2d> poses;
    Pose2d dead_reckoning{};
    ok = 0;
    seconds = 0;
    for (std::size_t k = 0; k < data->lasers.size(); ++k) {
      const auto& laser = data->lasers[k];
      std::optional<Pose2d> odometry;
      const auto from = k > 0 ? io::laser_odometry(data->lasers[k - 1]) : std::nullopt;
      const auto to = io::laser_odometry(laser);
      if (from && to) odometry = relative(*from, *to);
      if (mode == 2) {
        if (odometry) dead_reckoning = compose(dead_reckoning, *odometry);
        poses.push_back(dead_reckoning);
      } else if (mode == 3) {
        const std::clock_t start = std::clock();
        if (k > 0) {
          const Pose2d guess = odometry.value_or(Pose2d{});
          const KdTree<2, double> model(data->lasers[k - 1].scan);
          const auto r = icp.align(model, laser.scan, guess.to_isometry());
          const bool good =
              r.reason == IcpTermination::converged || r.reason == IcpTermination::max_iterations;
          ok += good ? 1 : 0;
          icp_pose = compose(icp_pose, good ? Pose2d::from_isometry(r.transform) : guess);
        }
        seconds += static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;
        poses.push_back(icp_pose);
      } else {
        const std::clock_t start = std::clock();  // CPU time: robust on a busy machine
        const auto r = (mode == 1 && odometry) ? tracker.track(laser.scan, *odometry)
                                               : tracker.track(laser.scan);
        seconds += static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;
        ok += r.match.ok() ? 1 : 0;
        poses.push_back(r.pose);
      }
      stamps.push_back(laser.timestamp);
    }
    evaluation = io::evaluate_slam_relations(data->relations, stamps, poses);
  }
  const auto scans = static_cast<double>(data->lasers.size());
  state.counters["trans_abs_mean_m"] = evaluation.all.translation_mean;
  state.counters["trans_short_m"] = evaluation.short_gap.translation_mean;
  state.counters["trans_long_m"] = evaluation.long_gap.translation_mean;
  state.counters["rot_abs_mean_deg"] = rad_to_deg(evaluation.all.rotation_mean);
  state.counters["rot_short_deg"] = rad_to_deg(evaluation.short_gap.rotation_mean);
  state.counters["relations"] = static_cast<double>(evaluation.all.count);
  if (mode != 2) {
    state.counters["us_per_scan"] = seconds / scans * 1e6;
    state.counters["success_rate"] = static_cast<double>(ok) / (scans - 1);
  }
}
BENCHMARK(BM_hayai_csail)
    ->ArgName("mode_hayai0_fused1_odometry2_icp3")
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Arg(3)
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
