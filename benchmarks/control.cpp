// Controller step times: path tracker (Eq. 7 of paper 000) with and without the blocked-segment
// check against a 541-beam scan, pose controller (paper 003 §2.2.3), the three reactive
// behaviours on the same scan, and one motor-control cycle (feed-forward + PI, paper 003 §2.1).
// Kurt3D's loop runs at 100 Hz and paper 000's at 50-100 Hz: a step must fit in well under 1 ms.

#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "rangenav/control/indiveri_path_tracker.hpp"
#include "rangenav/control/indiveri_pose_controller.hpp"
#include "rangenav/control/motor_control.hpp"
#include "rangenav/control/reactive.hpp"

namespace {

using rangenav::Point2d;
using rangenav::Pose2d;

// A SICK S300-like scan (270 degrees, 0.5 degree steps) in a 2 m wide corridor.
rangenav::LaserScan<double> corridor_scan() {
  const auto geo = rangenav::ScanGeometry<double>::from_fov(rangenav::deg_to_rad(270.0),
                                                            rangenav::deg_to_rad(0.5), 0.05, 30.0);
  std::vector<double> ranges(geo.beam_count);
  for (std::size_t i = 0; i < ranges.size(); ++i) {
    const double s = std::sin(geo.angle(i));
    ranges[i] = std::abs(s) > 1e-3 ? std::min(29.0, 1.0 / std::abs(s)) : 29.0;
  }
  return {geo, ranges};
}

rangenav::LocalFramePath zigzag() {
  std::vector<Point2d> wp;
  for (int i = 0; i < 20; ++i)
    wp.emplace_back(2.0 * i, i % 2 == 0 ? 0.0 : 1.0);
  return rangenav::LocalFramePath(wp);
}

void BM_PathTrackerStep(benchmark::State& state) {
  rangenav::IndiveriPathTracker tracker;
  tracker.set_path(zigzag());
  Pose2d pose{0.5, 0.1, 0.2};
  for (auto _ : state) {
    const auto cmd = tracker.step(pose);
    benchmark::DoNotOptimize(cmd.omega);
    pose.y = -pose.y;  // keep it from being hoisted
  }
}
BENCHMARK(BM_PathTrackerStep);

// A tracker step on `path` with the blocked-segment check against the corridor scan.
void time_step_with_scan_check(benchmark::State& state, const rangenav::LocalFramePath& path) {
  rangenav::IndiveriPathTracker tracker;
  tracker.set_path(path);
  const auto scan = corridor_scan();
  Pose2d pose{0.5, 0.1, 0.2};
  for (auto _ : state) {
    const auto cmd = tracker.step(pose, scan);
    benchmark::DoNotOptimize(cmd.replan);
    pose.y = -pose.y;
  }
  state.counters["beams"] = static_cast<double>(scan.size());
}

void BM_PathTrackerStepWithScanCheck(benchmark::State& state) {
  time_step_with_scan_check(state, zigzag());
}
BENCHMARK(BM_PathTrackerStepWithScanCheck);

// The same check on a Voronoi chain: 2 cm segments, so the 1.5 m lookahead spans 75 of them.
void BM_PathTrackerStepDenseChainScanCheck(benchmark::State& state) {
  std::vector<Point2d> wp;
  for (int i = 0; i <= 500; ++i)
    wp.emplace_back(0.02 * i, 0.0);
  time_step_with_scan_check(state, rangenav::LocalFramePath(wp));
}
BENCHMARK(BM_PathTrackerStepDenseChainScanCheck);

void BM_PoseControllerStep(benchmark::State& state) {
  const rangenav::IndiveriPoseController controller;
  Pose2d pose{1.0, 0.5, 2.0};
  const Pose2d target{0.0, 0.0, 0.3};
  for (auto _ : state) {
    const auto cmd = controller.step(pose, target);
    benchmark::DoNotOptimize(cmd.omega);
    pose.x = -pose.x;
  }
}
BENCHMARK(BM_PoseControllerStep);

void BM_ReactiveBehavioursScan(benchmark::State& state) {
  rangenav::ReactiveBehaviours behaviours;
  const auto scan = corridor_scan();
  for (auto _ : state) {
    const auto cmd = behaviours.apply(0.3, 0.0, scan);
    benchmark::DoNotOptimize(cmd.omega);
  }
  state.counters["beams"] = static_cast<double>(scan.size());
}
BENCHMARK(BM_ReactiveBehavioursScan);

void BM_MotorControllerStep(benchmark::State& state) {
  std::vector<double> pwm, speed;
  for (int i = 0; i <= 1023; ++i) {
    pwm.push_back(i);
    speed.push_back(5.2 * (1.0 - std::exp(-i / 400.0)));
  }
  rangenav::MotorController motor(rangenav::SpeedPwmTable(pwm, speed));
  double v = 0.0;
  for (auto _ : state) {
    const double u = motor.step(1.5, v);
    v += 0.01 * (u / 400.0 - v);
    benchmark::DoNotOptimize(u);
  }
  state.counters["table_entries"] = 1024;
}
BENCHMARK(BM_MotorControllerStep);

}  // namespace

BENCHMARK_MAIN();
