// The Freiburg SLAM benchmark's metric (Kümmerle et al. 2009) for rangenav's incremental mapper
// on the MIT CSAIL log, and its speed.
//
//   bench_slam_relations TRAJECTORY RELATIONS   evaluates a trajectory file (`t x y theta`, e.g.
//                                               03_slam_carmen's trajectory.txt) and exits;
//   bench_slam_relations [benchmark flags]      maps ../shared/data/carmen/mit-csail.clf.gz with
//                                               IncrementalMapper<2> in the papers' setup and
//                                               LaserSlamMapper with laser_slam_params() (one
//                                               thread, no loop closure), prints the errors
//                                               against slam-benchmark/mit-csail.relations (all,
//                                               short < 2 s, long), the sparse-map sizes, then
//                                               times the whole log per iteration (scans per
//                                               second) for both, and for the papers' setup
//                                               with a GrowingKdTree map index.

#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <numbers>
#include <optional>
#include <vector>

#include "rangenav/io/carmen.hpp"
#include "rangenav/io/slam_relations.hpp"
#include "rangenav/io/trajectory.hpp"
#include "rangenav/mapping/incremental_mapper.hpp"

namespace {

const std::filesystem::path data_dir(RANGENAV_BENCH_DATA_DIR);

void print_errors(const rangenav::io::RelationEvaluation& e) {
  const auto deg = [](double rad) { return rad * 180.0 / std::numbers::pi; };
  const std::pair<const char*, const rangenav::io::RelationErrors*> groups[] = {
      {"all", &e.all}, {"short (< 2 s)", &e.short_gap}, {"long (>= 2 s)", &e.long_gap}};
  for (const auto& [name, g] : groups)
    std::printf("  %-14s %5zu relations: %.4f +- %.4f m, %.3f +- %.3f deg\n", name, g->count,
                g->translation_mean, g->translation_stddev, deg(g->rotation_mean),
                deg(g->rotation_stddev));
  if (e.missing) std::printf("  %zu relations without a trajectory pose\n", e.missing);
}

struct Run {
  std::vector<double> stamps;
  std::vector<rangenav::Pose2d> poses;
  std::size_t map_points = 0, offered = 0, memory = 0, rejected = 0;
};

template <class Mapper>
Run map_log(const std::vector<rangenav::io::CarmenLaser>& lasers, Mapper mapper) {
  Run run;
  for (const auto& laser : lasers) {
    std::optional<rangenav::Transform2d> odom;
    if (laser.odom_pose) odom = laser.odom_pose->to_isometry();
    const auto update = mapper.process(laser.scan, odom);
    if (update.icp && !update.registration_accepted) ++run.rejected;
    run.stamps.push_back(laser.timestamp);
    run.poses.push_back(rangenav::Pose2d::from_isometry(update.pose));
  }
  run.map_points = mapper.map().size();
  run.offered = mapper.map().points_offered();
  run.memory = mapper.map().memory_bytes();
  return run;
}

const std::vector<rangenav::io::CarmenLaser>& csail() {
  static const auto lasers = rangenav::io::read_carmen_lasers(data_dir / "carmen/mit-csail.clf.gz");
  return lasers;
}

rangenav::IncrementalMapper<2> paper_mapper() {
  return rangenav::IncrementalMapper<2>();
}
// The papers' setup with the map indexed by the growing kd-tree instead of the 2D grid.
using KdTreeMapper = rangenav::IncrementalMapper<2, double, rangenav::PaperIcp<2>,
                                                 rangenav::GrowingKdTree<2, double>>;
KdTreeMapper kd_tree_mapper() {
  return KdTreeMapper();
}
rangenav::LaserSlamMapper<double> laser_mapper() {
  return rangenav::LaserSlamMapper<double>(rangenav::laser_slam_params<double>());
}

template <class Make>
void time_mapper(benchmark::State& state, Make make) {
  if (!std::filesystem::exists(data_dir / "carmen/mit-csail.clf.gz")) {
    state.SkipWithError("carmen/mit-csail.clf.gz not found");
    return;
  }
  const auto& lasers = csail();
  for (auto _ : state)
    benchmark::DoNotOptimize(map_log(lasers, make()));
  state.counters["scans_per_second"] = benchmark::Counter(
      static_cast<double>(lasers.size()) * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate);
}
void BM_rangenav_mapper_csail(benchmark::State& state) {
  time_mapper(state, paper_mapper);
}
void BM_rangenav_mapper_kd_tree_csail(benchmark::State& state) {
  time_mapper(state, kd_tree_mapper);
}
void BM_rangenav_laser_mapper_csail(benchmark::State& state) {
  time_mapper(state, laser_mapper);
}
BENCHMARK(BM_rangenav_mapper_csail)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_rangenav_mapper_kd_tree_csail)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_rangenav_laser_mapper_csail)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && argv[1][0] != '-' && argv[2][0] != '-') {
    std::vector<double> stamps;
    std::vector<rangenav::Pose2d> poses;
    for (const auto& p : rangenav::io::read_xytheta(argv[1])) {
      stamps.push_back(p.timestamp);
      poses.push_back(p.pose);
    }
    std::printf("%s against %s:\n", argv[1], argv[2]);
    print_errors(rangenav::io::evaluate_slam_relations(rangenav::io::read_slam_relations(argv[2]),
                                                       stamps, poses));
    return 0;
  }
  const auto relations = data_dir / "slam-benchmark/mit-csail.relations";
  if (std::filesystem::exists(data_dir / "carmen/mit-csail.clf.gz") &&
      std::filesystem::exists(relations)) {
    const auto rel = rangenav::io::read_slam_relations(relations);
    const auto report = [&](const char* name, const Run& run) {
      std::printf("%s on MIT CSAIL (%zu scans, no loop closure):\n", name, run.stamps.size());
      print_errors(rangenav::io::evaluate_slam_relations(rel, run.stamps, run.poses));
      std::printf(
          "  sparse map: %zu of %zu offered points stored (eps_D = 0.15 m), %zu bytes "
          "(%.1f B per stored point); %zu registrations rejected\n",
          run.map_points, run.offered, run.memory,
          static_cast<double>(run.memory) /
              static_cast<double>(std::max<std::size_t>(run.map_points, 1)),
          run.rejected);
    };
    report("IncrementalMapper<2> (papers' setup)", map_log(csail(), paper_mapper()));
    report("LaserSlamMapper (laser_slam_params)", map_log(csail(), laser_mapper()));
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
