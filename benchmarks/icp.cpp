// ICP speed and accuracy beside PCL and Open3D, in the same run, one thread each:
//   2D: scan-to-scan matching of the MIT CSAIL log (1988 scans x 361 beams), every scan against
//       the previous one with the odometry increment as initial guess (same guesses for all);
//       rangenav's scan-to-map tracking (IncrementalMapper) is timed in bench_slam_relations.
//   3D: the KITTI pair of small_gicp, both clouds voxel-downsampled to 0.25 m, identity guess,
//       1.0 m maximum correspondence distance; the time includes building the search structure;
//       the error against T_target_source.txt is printed.
//   3D: PCL's bunny scans bun4 -> bun0.
// Open3D uses OpenMP: run with OMP_NUM_THREADS=1 for the one-thread comparison.

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <vector>

#include "rangenav/geometry/voxel_grid.hpp"
#include "rangenav/io/carmen.hpp"
#include "rangenav/io/pcd.hpp"
#include "rangenav/io/ply.hpp"
#include "rangenav/registration/icp.hpp"
#include "rangenav/search/kd_tree.hpp"

#ifdef RANGENAV_HAVE_PCL
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/icp.h>
#endif
#ifdef RANGENAV_HAVE_OPEN3D
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/Registration.h>
#include <open3d/pipelines/registration/TransformationEstimation.h>
#endif

namespace {

const std::filesystem::path data_dir(RANGENAV_BENCH_DATA_DIR);

// ---- inputs ------------------------------------------------------------------------------------

struct ScanPairs {
  std::vector<std::vector<Eigen::Vector2d>> scans;  // valid points of every scan
  std::vector<rangenav::Transform2d> guesses;       // odometry increment from scan i-1 to i
};

const ScanPairs& csail() {
  static const ScanPairs pairs = [] {
    ScanPairs p;
    const auto lasers = rangenav::io::read_carmen_lasers(data_dir / "carmen/mit-csail.clf.gz");
    for (std::size_t i = 0; i < lasers.size(); ++i) {
      p.scans.push_back(lasers[i].scan.valid_points());
      p.guesses.push_back(
          i == 0
              ? rangenav::Transform2d::Identity()
              : rangenav::relative(*lasers[i - 1].odom_pose, *lasers[i].odom_pose).to_isometry());
    }
    return p;
  }();
  return pairs;
}

struct Pair3 {
  std::vector<Eigen::Vector3d> source, target;
  rangenav::Transform3d truth = rangenav::Transform3d::Identity();
};

const Pair3& kitti() {
  static const Pair3 pair = [] {
    Pair3 p;
    p.source = rangenav::voxel_downsample(
        rangenav::io::read_ply<double>(data_dir / "small_gicp/source.ply"), 0.25);
    p.target = rangenav::voxel_downsample(
        rangenav::io::read_ply<double>(data_dir / "small_gicp/target.ply"), 0.25);
    Eigen::Matrix4d m;
    std::ifstream in(data_dir / "small_gicp/T_target_source.txt");
    for (int i = 0; i < 16; ++i)
      in >> m(i / 4, i % 4);
    p.truth = rangenav::Transform3d(m);
    return p;
  }();
  return pair;
}

const Pair3& bunny() {
  static const Pair3 pair = [] {
    Pair3 p;
    p.source = rangenav::io::read_pcd<double>(data_dir / "pcl_test/bun4.pcd").points;
    p.target = rangenav::io::read_pcd<double>(data_dir / "pcl_test/bun0.pcd").points;
    return p;
  }();
  return pair;
}

void report_3d(benchmark::State& state, const Pair3& pair, const Eigen::Matrix4d& result,
               int iterations) {
  const rangenav::Transform3d e =
      rangenav::Transform3d(result).inverse(Eigen::Isometry) * pair.truth;
  state.counters["err_m"] = e.translation().norm();
  state.counters["err_deg"] = rangenav::rotation_angle(e) * 180 / std::numbers::pi;
  state.counters["iterations"] = iterations;
}

bool have_data(benchmark::State& state, const std::filesystem::path& file) {
  if (std::filesystem::exists(data_dir / file)) return true;
  state.SkipWithError(("data file not found: " + (data_dir / file).string()).c_str());
  return false;
}

// ---- rangenav ----------------------------------------------------------------------------------

void BM_rangenav_2d_scan_to_scan(benchmark::State& state) {
  if (!have_data(state, "carmen/mit-csail.clf.gz")) return;
  const auto& in = csail();
  rangenav::PaperIcp<2> icp;
  icp.params.check_degeneracy = false;
  for (auto _ : state) {
    for (std::size_t i = 1; i < in.scans.size(); ++i) {
      const rangenav::KdTree<2, double> tree(in.scans[i - 1]);
      benchmark::DoNotOptimize(icp.align(tree, in.scans[i], in.guesses[i]));
    }
  }
  state.counters["scans_per_second"] = benchmark::Counter(
      static_cast<double>(in.scans.size() - 1) * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate);
}

void BM_rangenav_3d_kitti(benchmark::State& state) {
  if (!have_data(state, "small_gicp/source.ply")) return;
  const auto& pair = kitti();
  rangenav::Icp<3, double, rangenav::MaxDistanceRejector<double>> icp;
  icp.params.check_degeneracy = false;
  rangenav::IcpResult<3, double> r;
  for (auto _ : state) {
    const rangenav::KdTree<3, double> tree(pair.target);
    r = icp.align(tree, pair.source);
    benchmark::DoNotOptimize(r);
  }
  report_3d(state, pair, r.transform.matrix(), r.iterations);
}

void BM_rangenav_3d_bunny(benchmark::State& state) {
  if (!have_data(state, "pcl_test/bun0.pcd")) return;
  const auto& pair = bunny();
  rangenav::Icp<3, double, rangenav::MaxDistanceRejector<double>> icp;
  icp.rejector<rangenav::MaxDistanceRejector<double>>().max_distance = 0.05;
  icp.params.check_degeneracy = false;
  rangenav::IcpResult<3, double> r;
  for (auto _ : state) {
    const rangenav::KdTree<3, double> tree(pair.target);
    r = icp.align(tree, pair.source);
    benchmark::DoNotOptimize(r);
  }
  state.counters["rmse_mm"] = r.rmse * 1000;
  state.counters["angle_deg"] = rangenav::rotation_angle(r.transform) * 180 / std::numbers::pi;
  state.counters["iterations"] = r.iterations;
}

BENCHMARK(BM_rangenav_2d_scan_to_scan)->Unit(benchmark::kMillisecond)->Iterations(2);
BENCHMARK(BM_rangenav_3d_kitti)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK(BM_rangenav_3d_bunny)->Unit(benchmark::kMillisecond);

// ---- PCL
// -----------------------------------------------------------------------------------------
#ifdef RANGENAV_HAVE_PCL
template <class Points>
pcl::PointCloud<pcl::PointXYZ>::Ptr to_pcl(const Points& pts) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr c(new pcl::PointCloud<pcl::PointXYZ>);
  for (const auto& p : pts)
    c->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()),
                               p.size() == 3 ? static_cast<float>(p[p.size() - 1]) : 0.0f));
  return c;
}

Eigen::Matrix4f lift(const rangenav::Transform2d& t) {
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m.block<2, 2>(0, 0) = t.linear().cast<float>();
  m.block<2, 1>(0, 3) = t.translation().cast<float>();
  return m;
}

void BM_pcl_2d_scan_to_scan(benchmark::State& state) {
  if (!have_data(state, "carmen/mit-csail.clf.gz")) return;
  const auto& in = csail();
  std::vector<pcl::PointCloud<pcl::PointXYZ>::Ptr> clouds;
  for (const auto& s : in.scans)
    clouds.push_back(to_pcl(s));
  pcl::PointCloud<pcl::PointXYZ> aligned;
  for (auto _ : state) {
    for (std::size_t i = 1; i < clouds.size(); ++i) {
      pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
      icp.setInputTarget(clouds[i - 1]);
      icp.setInputSource(clouds[i]);
      icp.setMaxCorrespondenceDistance(0.5);
      icp.setMaximumIterations(30);
      icp.align(aligned, lift(in.guesses[i]));
      benchmark::DoNotOptimize(icp.getFinalTransformation());
    }
  }
  state.counters["scans_per_second"] = benchmark::Counter(
      static_cast<double>(in.scans.size() - 1) * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate);
}

void BM_pcl_3d_kitti(benchmark::State& state) {
  if (!have_data(state, "small_gicp/source.ply")) return;
  const auto& pair = kitti();
  const auto source = to_pcl(pair.source), target = to_pcl(pair.target);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  Eigen::Matrix4d result = Eigen::Matrix4d::Identity();
  for (auto _ : state) {
    pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;  // builds its kd-tree
    icp.setInputTarget(target);
    icp.setInputSource(source);
    icp.setMaxCorrespondenceDistance(1.0);
    icp.setMaximumIterations(50);
    icp.setTransformationEpsilon(1e-6);
    icp.align(aligned);
    result = icp.getFinalTransformation().cast<double>();
  }
  report_3d(state, pair, result, 0);
}

void BM_pcl_3d_bunny(benchmark::State& state) {
  if (!have_data(state, "pcl_test/bun0.pcd")) return;
  const auto& pair = bunny();
  const auto source = to_pcl(pair.source), target = to_pcl(pair.target);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  Eigen::Matrix4d result = Eigen::Matrix4d::Identity();
  for (auto _ : state) {
    pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
    icp.setInputTarget(target);
    icp.setInputSource(source);
    icp.setMaxCorrespondenceDistance(0.05);
    icp.setMaximumIterations(50);
    icp.setTransformationEpsilon(1e-6);
    icp.align(aligned);
    result = icp.getFinalTransformation().cast<double>();
  }
  state.counters["angle_deg"] =
      Eigen::AngleAxisd(result.block<3, 3>(0, 0)).angle() * 180 / std::numbers::pi;
}

BENCHMARK(BM_pcl_2d_scan_to_scan)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_pcl_3d_kitti)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK(BM_pcl_3d_bunny)->Unit(benchmark::kMillisecond);
#endif

// ---- Open3D
// --------------------------------------------------------------------------------------
#ifdef RANGENAV_HAVE_OPEN3D
template <class Points>
open3d::geometry::PointCloud to_open3d(const Points& pts) {
  open3d::geometry::PointCloud c;
  for (const auto& p : pts)
    c.points_.emplace_back(p.x(), p.y(), p.size() == 3 ? p[p.size() - 1] : 0.0);
  return c;
}

void BM_open3d_2d_scan_to_scan(benchmark::State& state) {
  if (!have_data(state, "carmen/mit-csail.clf.gz")) return;
  const auto& in = csail();
  std::vector<open3d::geometry::PointCloud> clouds;
  for (const auto& s : in.scans)
    clouds.push_back(to_open3d(s));
  namespace reg = open3d::pipelines::registration;
  for (auto _ : state) {
    for (std::size_t i = 1; i < clouds.size(); ++i) {
      Eigen::Matrix4d guess = Eigen::Matrix4d::Identity();
      guess.block<2, 2>(0, 0) = in.guesses[i].linear();
      guess.block<2, 1>(0, 3) = in.guesses[i].translation();
      benchmark::DoNotOptimize(reg::RegistrationICP(clouds[i], clouds[i - 1], 0.5, guess,
                                                    reg::TransformationEstimationPointToPoint(),
                                                    reg::ICPConvergenceCriteria(1e-6, 1e-6, 30)));
    }
  }
  state.counters["scans_per_second"] = benchmark::Counter(
      static_cast<double>(in.scans.size() - 1) * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate);
}

void BM_open3d_3d_kitti(benchmark::State& state) {
  if (!have_data(state, "small_gicp/source.ply")) return;
  const auto& pair = kitti();
  const auto source = to_open3d(pair.source), target = to_open3d(pair.target);
  namespace reg = open3d::pipelines::registration;
  reg::RegistrationResult r;
  for (auto _ : state) {
    r = reg::RegistrationICP(source, target, 1.0, Eigen::Matrix4d::Identity(),
                             reg::TransformationEstimationPointToPoint(),
                             reg::ICPConvergenceCriteria(1e-6, 1e-6, 50));
  }
  report_3d(state, pair, r.transformation_, 0);
}

void BM_open3d_3d_bunny(benchmark::State& state) {
  if (!have_data(state, "pcl_test/bun0.pcd")) return;
  const auto& pair = bunny();
  const auto source = to_open3d(pair.source), target = to_open3d(pair.target);
  namespace reg = open3d::pipelines::registration;
  reg::RegistrationResult r;
  for (auto _ : state) {
    r = reg::RegistrationICP(source, target, 0.05, Eigen::Matrix4d::Identity(),
                             reg::TransformationEstimationPointToPoint(),
                             reg::ICPConvergenceCriteria(1e-6, 1e-6, 50));
  }
  state.counters["rmse_mm"] = r.inlier_rmse_ * 1000;
  state.counters["angle_deg"] =
      Eigen::AngleAxisd(r.transformation_.block<3, 3>(0, 0)).angle() * 180 / std::numbers::pi;
}

BENCHMARK(BM_open3d_2d_scan_to_scan)->Unit(benchmark::kMillisecond)->Iterations(2);
BENCHMARK(BM_open3d_3d_kitti)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK(BM_open3d_3d_bunny)->Unit(benchmark::kMillisecond);
#endif

}  // namespace

BENCHMARK_MAIN();
