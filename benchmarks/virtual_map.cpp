// Cost of the egocentric virtual maps of paper 002 §4 on one thread:
//  - BM_ObstacleMapUpdate: one 2D scan of 361 beams into a 720-bin (0.5 deg) obstacle map with
//    transformation (Eq. 4), age-out and replacement (§4.4), the map kept full by the stream;
//  - BM_ToFPipeline: one 176 x 144 time-of-flight frame (SR4000 layout) through the §7.1-7.2
//    pipeline: amplitude threshold, 3x3 median, jump-edge filter (Eq. 13-14), height-image
//    obstacles (Eq. 15) and the virtual scan;
//  - BM_SweepReduction: the four per-scan steps of §6.1 (cluster centroids, line segments,
//    planes, floor classification) on one sweep of the simulated pitching scanner in a room;
//  - BM_FastAtan2 / BM_StdAtan2: the bearing function the map uses.
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "rangenav/egocentric/pitching_stream.hpp"
#include "rangenav/egocentric/sweep_reduction.hpp"
#include "rangenav/egocentric/tof_obstacles.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/scan/pitching.hpp"
#include "rangenav/scan/tof_filters.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/world.hpp"

namespace {

using namespace rangenav;

// A room-like scan: 361 beams over 180 deg, ranges between 1 and 6 m with noise.
LaserScand make_scan(std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<double> ranges(361);
  for (std::size_t i = 0; i < ranges.size(); ++i)
    ranges[i] = 3.0 + 2.0 * std::sin(0.05 * static_cast<double>(i)) + noise(rng);
  return LaserScand(-std::numbers::pi / 2, std::numbers::pi / 360, 0.02, 30.0, ranges);
}

void BM_ObstacleMapUpdate(benchmark::State& state) {
  std::mt19937 rng(1);
  std::vector<LaserScand> scans;
  for (int i = 0; i < 16; ++i)
    scans.push_back(make_scan(rng));
  ObstacleMap<double> map;  // 720 bins
  const PlanarMount<double> mount{Pose2d{0.1, 0.0, 0.0}, 0.3};
  // Fill all 720 bins: the robot turns on the spot while scanning.
  for (int i = 0; i < 40; ++i)
    map.update(Pose2d{0.0, 0.0, 0.2}, scans[0], mount);
  const Pose2d motion{0.004, 0.0005, 0.002};  // 0.3 m/s, 0.15 rad/s at 75 Hz
  std::size_t k = 0;
  for (auto _ : state) {
    auto st = map.update(motion, scans[k++ & 15], mount);
    benchmark::DoNotOptimize(st);
  }
  state.counters["bins_filled"] = static_cast<double>(map.valid_count());
}
BENCHMARK(BM_ObstacleMapUpdate);

// A camera 0.8 m above the floor, tilted 30 deg down, seeing the floor and a 0.2 m box at 1.2 m.
DepthImage<double> make_frame() {
  DepthImage<double> img;
  img.intrinsics =
      PinholeIntrinsics<double>::from_fov(176, 144, deg_to_rad(43.0), deg_to_rad(34.0));
  img.depth.resize(176 * 144);
  img.amplitude.resize(176 * 144);
  Transform3d extr = Transform3d::Identity();
  extr.linear() = pitch_rotation(deg_to_rad(30.0));
  extr.translation() = Point3d(0, 0, 0.8);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.01);
  for (std::size_t r = 0; r < 144; ++r)
    for (std::size_t c = 0; c < 176; ++c) {
      const Point3d d = extr.linear() * img.pixel_point(r, c, 1.0);
      double t = -0.8 / d.z();  // floor
      const Point3d o = extr.translation();
      const double tb = (1.2 - o.x()) / d.x();  // front face of the box
      const Point3d pb = o + tb * d;
      if (tb > 0 && std::abs(pb.y()) < 0.2 && pb.z() < 0.2 && pb.z() >= 0) t = std::min(t, tb);
      img.depth[r * 176 + c] = t + noise(rng);
      img.amplitude[r * 176 + c] = 1000.0 / (t * t);
    }
  return img;
}

void BM_ToFPipeline(benchmark::State& state) {
  const DepthImage<double> raw = make_frame();
  Transform3d extr = Transform3d::Identity();
  extr.linear() = pitch_rotation(deg_to_rad(30.0));
  extr.translation() = Point3d(0, 0, 0.8);
  DepthImage<double> img = raw;
  std::vector<double> scratch;
  JumpEdgeFilter<double> jump(raw.intrinsics, raw.kind);
  HeightImageObstacleDetector<double> detector;
  std::size_t obstacles = 0;
  for (auto _ : state) {
    std::copy(raw.depth.begin(), raw.depth.end(), img.depth.begin());
    apply_amplitude_threshold(img, 20.0);
    apply_median_filter(img, scratch);
    jump.filter(img);
    obstacles = detector.detect(img, extr);
    benchmark::DoNotOptimize(detector.virtual_scan_ranges().data());
  }
  state.counters["obstacle_points"] = static_cast<double>(obstacles);
}
BENCHMARK(BM_ToFPipeline)->Unit(benchmark::kMicrosecond);

// One sweep (-10 to 40 deg at 1 deg per scan, 181 beams) of a 6 x 4.5 m five-walled room.
void BM_SweepReduction(benchmark::State& state) {
  sim::World world;
  const std::vector<Point2d> corners = {{0, 0}, {6, 0}, {6, 3}, {4, 4.5}, {0, 4.5}};
  world.add_polygon(corners, 2.5);
  world.build_index();
  sim::PitchingScannerParams sp;
  sp.noise.sigma = 0.005;
  const sim::PitchingScanner scanner(sp);
  SweepAssembler<double> sweeps(SweepParams<double>{sp.sensor_offset});
  std::mt19937 rng(21);
  const Pose2d pose{1.5, 2.0, 0.4};
  std::size_t k = 0;
  while (!sweeps.push(scanner.scan(world, pose, scanner.scan_time(k), rng), pose))
    ++k;
  const Sweep<double> sweep = sweeps.sweep();
  SweepReducer<double> reducer;
  SweepReduction<double> out;
  for (auto _ : state) {
    reducer.reduce(sweep, out);
    benchmark::DoNotOptimize(out.lines.data());
  }
  state.counters["scans"] = static_cast<double>(sweep.scan_count());
  state.counters["readings"] = static_cast<double>(out.input_points);
  state.counters["reduction_ratio"] = out.reduction_ratio();
  state.counters["lines"] = static_cast<double>(out.lines.size());
  state.counters["planes"] = static_cast<double>(out.planes.size());
}
BENCHMARK(BM_SweepReduction)->Unit(benchmark::kMicrosecond);

template <double (*F)(double, double)>
void BM_Atan2(benchmark::State& state) {
  std::vector<double> xs(1024), ys(1024);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  for (std::size_t i = 0; i < xs.size(); ++i)
    xs[i] = u(rng), ys[i] = u(rng);
  for (auto _ : state) {
    double sum = 0;
    for (std::size_t i = 0; i < xs.size(); ++i)
      sum += F(ys[i], xs[i]);
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * 1024);
}
double fast(double y, double x) {
  return detail::fast_atan2(y, x);
}
double libm(double y, double x) {
  return std::atan2(y, x);
}
BENCHMARK(BM_Atan2<fast>)->Name("BM_FastAtan2");
BENCHMARK(BM_Atan2<libm>)->Name("BM_StdAtan2");

}  // namespace

BENCHMARK_MAIN();
