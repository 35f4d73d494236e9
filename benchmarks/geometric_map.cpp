// Geometric mapping per key frame (paper 004 Table 4: registration 0.027 s, plane extraction
// 0.165 s, merging 0.002 s, all 0.194 s on a Core i7 2.8 GHz), one thread, on a simulated
// 640 x 480 Kinect-like frame of the kitchen (noise sigma 5 mm): the second key frame of a
// sequence, registered against the point map of the first from a guess 5 cm / 3 deg off.
//   registration       voxel filter (5 cm) + frustum ICP against the point map + map update
//   merging            the second key frame's planes into a map holding the first one's
//                      (GeometricMap, Boost.Geometry clipping)
//   plane_extraction   Euclidean clustering + iterative RANSAC + least-squares refit + alpha-shape
//                      hulls on the aligned frame: at full resolution (the paper's choice) and
//                      voxel-filtered to 2 cm first (extraction_leaf)
//   keyframe_total     GeometricMapper::process on the second key frame: all three stages
//   keyframe_running   the same key frame in a running sequence (the mapper going back and
//                      forth between the two poses: maps and buffers of a running mapper)
// and, when PCL is installed, PCL's SACSegmentation (RANSAC plane) + ExtractIndices +
// ProjectInliers + ConcaveHull extracting planes iteratively from the same aligned frame with the
// same threshold, minimum inliers and alpha (without clustering).

#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <random>
#include <span>
#include <vector>

#include "rangenav/geometry/euclidean_clustering.hpp"
#include "rangenav/geometry/plane_extraction.hpp"
#include "rangenav/geometry/voxel_grid.hpp"
#include "rangenav/mapping/geometric_map.hpp"
#include "rangenav/mapping/geometric_mapper.hpp"
#include "rangenav/scan/depth_image.hpp"
#include "rangenav/search/kd_tree.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

#ifdef RANGENAV_HAVE_PCL
#include <pcl/ModelCoefficients.h>
#include <pcl/filters/extract_indices.h>
#include <pcl/filters/project_inliers.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>
#include <pcl/surface/concave_hull.h>
#endif

namespace {

using namespace rangenav;

/// Minor page faults of the process so far (first touches of newly mapped memory).
long minor_faults() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_minflt;
}

struct Frames {
  Cloud3d first, second;
  Transform3d first_pose, second_pose, first_guess, second_guess;
  std::vector<Point3d> second_world;  // finite points of the second frame, true pose
};

const Frames& frames() {
  static const Frames f = [] {
    Frames out;
    const sim::Scene scene = sim::kitchen();
    sim::TofCameraParams cp;
    cp.intrinsics = PinholeIntrinsics<double>::from_fov(640, 480, 57.0 * std::numbers::pi / 180,
                                                        43.0 * std::numbers::pi / 180);
    cp.tilt = 0.35;
    cp.range_max = 6.0;
    cp.noise_sigma_0 = 0.005;
    cp.noise_sigma_2 = 0.0;
    cp.jump_edges = false;
    const sim::TofCamera camera(cp);
    std::mt19937 rng(1);
    const Pose2d a{3.9, 2.0, std::numbers::pi}, b{3.7, 1.8, std::numbers::pi - 0.15};
    const Pose2d guess{b.x + 0.04, b.y - 0.03, b.theta + 0.05};
    const Pose2d first_guess{a.x + 0.04, a.y - 0.03, a.theta + 0.05};
    out.first = to_organized_cloud(camera.capture(scene.world, a, rng));
    out.second = to_organized_cloud(camera.capture(scene.world, b, rng));
    out.first_pose = sim::robot_transform(a) * camera.camera_to_robot();
    out.second_pose = sim::robot_transform(b) * camera.camera_to_robot();
    out.second_guess = sim::robot_transform(guess) * camera.camera_to_robot();
    out.first_guess = sim::robot_transform(first_guess) * camera.camera_to_robot();
    for (const Point3d& p : out.second.points)
      if (p.allFinite()) out.second_world.push_back(out.second_pose * p);
    return out;
  }();
  return f;
}

GeometricMapperParams params(double extraction_leaf) {
  GeometricMapperParams p;
  p.key_frames.min_distance = 0.1;
  p.key_frames.min_angle = 0.1;
  p.extraction_leaf = extraction_leaf;
  const bool full = extraction_leaf == 0;
  p.clustering.tolerance = full ? 0.02 : 0.05;
  p.clustering.min_cluster_size = full ? 2000 : 200;
  p.planes.min_inliers = full ? 2000 : 200;
  p.planes.distance_threshold = 0.02;
  p.planes.hull.alpha = 0.05;
  p.planes.hull.resolution = 0.005;
  return p;
}

/// Arg 1: key frames join the point map voxel-filtered (the default); 0: at full resolution.
void BM_registration(benchmark::State& state) {
  const Frames& f = frames();
  std::size_t planes = 0;
  double error = 0;
  auto p = params(0.02);
  p.point_map_downsampled = state.range(0) != 0;
  std::optional<GeometricMapper> mapper;  // destroyed while paused, see BM_keyframe_total
  for (auto _ : state) {
    state.PauseTiming();
    mapper.reset();
    mapper.emplace(p);
    GeometricFrameReport first;
    mapper->register_frame(f.first, f.first_pose, first);
    GeometricFrameReport report;
    state.ResumeTiming();
    mapper->register_frame(f.second, f.second_guess, report);
    benchmark::DoNotOptimize(report.pose);
    error = (f.second_pose.inverse() * report.pose).translation().norm();
    planes = report.downsampled_points;
  }
  state.counters["error_mm"] = error * 1000;
  state.counters["downsampled"] = static_cast<double>(planes);
}

void BM_plane_extraction(benchmark::State& state) {
  const Frames& f = frames();
  const double leaf = static_cast<double>(state.range(0)) / 1000.0;
  GeometricMapper mapper(params(leaf));
  std::size_t planes = 0, points = 0, inliers = 0;
  double area = 0;
  for (auto _ : state) {
    std::mt19937 rng(7);
    GeometricFrameReport report;
    report.pose = f.second_pose;
    mapper.extract_planes(f.second, report, rng);
    planes = report.planes.size();
    points = report.extraction_points;
    area = 0;
    inliers = 0;
    for (const auto& e : report.planes) {
      area += e.shape.area();
      inliers += e.inliers;
    }
  }
  state.counters["planes"] = static_cast<double>(planes);
  state.counters["points"] = static_cast<double>(points);
  state.counters["area_m2"] = area;
  state.counters["inliers"] = static_cast<double>(inliers);
}

/// The aligned second frame in world coordinates, organised (640 x 480, NaN where no return).
const std::vector<Point3d>& second_world_organized() {
  static const std::vector<Point3d> out = [] {
    const Frames& f = frames();
    std::vector<Point3d> w(f.second.points.size());
    for (std::size_t i = 0; i < w.size(); ++i)
      w[i] = f.second_pose * f.second.points[i];
    return w;
  }();
  return out;
}

/// Clustering alone, full resolution: kd-tree radius queries (Arg 0) or image neighbours (1).
void BM_clustering(benchmark::State& state) {
  const Frames& f = frames();
  const auto p = params(0);
  const std::vector<Point3d>& world = second_world_organized();
  std::size_t clusters = 0;
  for (auto _ : state) {
    if (state.range(0) == 0) {
      std::vector<Point3d> finite;
      finite.reserve(world.size());
      for (const Point3d& q : world)
        if (q.allFinite()) finite.push_back(q);
      const KdTree<3, double> tree(std::move(finite));
      clusters = euclidean_clusters(tree, p.clustering).size();
    } else {
      clusters = organized_euclidean_clusters(std::span<const Point3d>(world), f.second.width,
                                              f.second.height, p.clustering)
                     .size();
    }
  }
  state.counters["clusters"] = static_cast<double>(clusters);
}

/// The whole extraction at full resolution on the organised frame: transform to the world,
/// clustering over image neighbours, iterative RANSAC + refit + alpha-shape hulls per cluster.
void BM_plane_extraction_organized(benchmark::State& state) {
  const Frames& f = frames();
  auto p = params(0);
  p.planes.hull.thinning = static_cast<double>(state.range(0)) / 100.0;
  PlaneExtractor extractor(p.planes);
  extractor.set_viewpoint(Point3d(f.second_pose.translation()));
  std::vector<Point3d> world(f.second.points.size());
  std::vector<ExtractedPlane> planes;
  std::size_t clusters = 0;
  double area = 0;
  for (auto _ : state) {
    std::mt19937 rng(7);
    for (std::size_t i = 0; i < world.size(); ++i)
      world[i] = f.second_pose * f.second.points[i];
    const auto found = organized_euclidean_clusters(std::span<const Point3d>(world), f.second.width,
                                                    f.second.height, p.clustering);
    clusters = found.size();
    planes.clear();
    for (const auto& cluster : found)
      extractor.extract(std::span<const Point3d>(world), cluster, rng, planes);
  }
  area = 0;
  for (const auto& e : planes)
    area += e.shape.area();
  state.counters["planes"] = static_cast<double>(planes.size());
  state.counters["clusters"] = static_cast<double>(clusters);
  state.counters["area_m2"] = area;
  state.counters["inliers"] = 0;
  for (const auto& e : planes)
    state.counters["inliers"] += static_cast<double>(e.inliers);
}

void BM_merging(benchmark::State& state) {
  // The second key frame's planes merged into a map holding the first key frame's.
  const Frames& f = frames();
  GeometricMapper mapper(params(0.02));
  std::mt19937 rng(7);
  GeometricFrameReport first, second;
  first.pose = f.first_pose;
  mapper.extract_planes(f.first, first, rng);
  second.pose = f.second_pose;
  mapper.extract_planes(f.second, second, rng);
  std::size_t merged = 0, shapes = 0;
  for (auto _ : state) {
    state.PauseTiming();
    GeometricMap<double> map;
    for (const auto& p : first.planes)
      map.insert(p.shape);
    state.ResumeTiming();
    merged = 0;
    for (const auto& p : second.planes)
      merged += map.insert(p.shape).merged > 0 ? 1 : 0;
    shapes = map.size();
  }
  state.counters["planes"] = static_cast<double>(second.planes.size());
  state.counters["merged"] = static_cast<double>(merged);
  state.counters["shapes"] = static_cast<double>(shapes);
}

/// The whole pipeline on the second key frame, as GeometricMapper::process runs it: registration
/// (from the guess 5 cm / 3 deg off) + full-resolution extraction + merging into the map holding
/// the first key frame's planes; the "total per key frame" in one measurement.
void BM_keyframe_total(benchmark::State& state) {
  const Frames& f = frames();
  const auto p = params(0);
  std::size_t planes = 0, merged = 0;
  double error = 0;
  long faults = 0;
  // The mapper and the report of an iteration are destroyed in the next one's paused part: their
  // destruction (freeing the maps and the buffers, 2-3 ms) is no part of processing a key frame.
  std::optional<GeometricMapper> mapper;
  std::optional<GeometricFrameReport> report;
  for (auto _ : state) {
    state.PauseTiming();
    report.reset();
    mapper.reset();
    mapper.emplace(p);
    std::mt19937 rng(7);
    mapper->process(f.first, f.first_pose, rng);
    state.ResumeTiming();
    const long faults_before = minor_faults();
    report.emplace(mapper->process(f.second, f.second_guess, rng));
    faults += minor_faults() - faults_before;
    benchmark::DoNotOptimize(report->pose);
    error = (f.second_pose.inverse() * report->pose).translation().norm();
    planes = report->planes.size();
    merged = report->merged;
  }
  state.counters["error_mm"] = error * 1000;
  state.counters["planes"] = static_cast<double>(planes);
  state.counters["merged"] = static_cast<double>(merged);
  state.counters["faults"] =
      benchmark::Counter(static_cast<double>(faults), benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_keyframe_total)->Unit(benchmark::kMillisecond);

/// The same key frame in a running sequence: one mapper goes back and forth between the two
/// poses (odometry guesses 5 cm / 3 deg off each; the first key frame at the true pose), so its
/// point map and geometric map hold the earlier key frames and its buffers have their working size,
/// as for every key frame after the first few. Only the key frames at the second pose are timed.
/// BM_keyframe_total's fresh mapper also pays, in the timed frame, the page faults of its buffers'
/// first growth (its `faults` counter: minor faults of the timed frame, from getrusage; about
/// 2,200 more per iteration fall in its paused part), none once the buffers have grown.
void BM_keyframe_running(benchmark::State& state) {
  const Frames& f = frames();
  GeometricMapper mapper(params(0));
  std::mt19937 rng(7);
  // The map's frame is its first key frame's pose: the first at the true pose, so that the
  // error against the truth is the registration's. Then A, B, A, B: the maps and buffers of a
  // running sequence.
  (void)mapper.process(f.first, f.first_pose, rng);
  (void)mapper.process(f.second, f.second_guess, rng);
  (void)mapper.process(f.first, f.first_guess, rng);
  (void)mapper.process(f.second, f.second_guess, rng);
  std::size_t planes = 0, merged = 0, keyframes = 0;
  double error = 0;
  for (auto _ : state) {
    state.PauseTiming();
    (void)mapper.process(f.first, f.first_guess, rng);
    state.ResumeTiming();
    const GeometricFrameReport report = mapper.process(f.second, f.second_guess, rng);
    benchmark::DoNotOptimize(report.pose);
    keyframes += report.registered ? 1 : 0;
    error = std::max(error, (f.second_pose.inverse() * report.pose).translation().norm());
    planes = report.planes.size();
    merged = report.merged;
  }
  state.counters["max_error_mm"] = error * 1000;
  state.counters["registered"] =
      static_cast<double>(keyframes) / std::max(1.0, static_cast<double>(state.iterations()));
  state.counters["planes"] = static_cast<double>(planes);
  state.counters["merged"] = static_cast<double>(merged);
  state.counters["map_shapes"] = static_cast<double>(mapper.map().size());
}
BENCHMARK(BM_keyframe_running)->Unit(benchmark::kMillisecond);

#ifdef RANGENAV_HAVE_PCL
void BM_pcl_extraction(benchmark::State& state) {
  const Frames& f = frames();
  const double leaf = static_cast<double>(state.range(0)) / 1000.0;
  const std::vector<Point3d> pts =
      leaf > 0 ? voxel_downsample(f.second_world, leaf) : f.second_world;
  pcl::PointCloud<pcl::PointXYZ>::Ptr input(new pcl::PointCloud<pcl::PointXYZ>);
  for (const Point3d& p : pts)
    input->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()),
                                   static_cast<float>(p.z())));
  const auto p = params(leaf);
  std::size_t planes = 0;
  for (auto _ : state) {
    pcl::PointCloud<pcl::PointXYZ>::Ptr remaining(new pcl::PointCloud<pcl::PointXYZ>(*input));
    pcl::SACSegmentation<pcl::PointXYZ> seg;
    seg.setOptimizeCoefficients(true);  // least-squares refit, as ours
    seg.setModelType(pcl::SACMODEL_PLANE);
    seg.setMethodType(pcl::SAC_RANSAC);
    seg.setDistanceThreshold(p.planes.distance_threshold);
    seg.setMaxIterations(p.planes.max_iterations);
    seg.setProbability(p.planes.confidence);
    planes = 0;
    while (remaining->size() >= p.planes.min_inliers) {
      pcl::ModelCoefficients::Ptr coefficients(new pcl::ModelCoefficients);
      pcl::PointIndices::Ptr inliers(new pcl::PointIndices);
      seg.setInputCloud(remaining);
      seg.segment(*inliers, *coefficients);
      if (inliers->indices.size() < p.planes.min_inliers) break;
      pcl::ProjectInliers<pcl::PointXYZ> project;
      project.setModelType(pcl::SACMODEL_PLANE);
      project.setInputCloud(remaining);
      project.setIndices(inliers);
      project.setModelCoefficients(coefficients);
      pcl::PointCloud<pcl::PointXYZ>::Ptr projected(new pcl::PointCloud<pcl::PointXYZ>);
      project.filter(*projected);
      pcl::ConcaveHull<pcl::PointXYZ> hull;
      hull.setInputCloud(projected);
      hull.setAlpha(p.planes.hull.alpha);
      pcl::PointCloud<pcl::PointXYZ> outline;
      hull.reconstruct(outline);
      benchmark::DoNotOptimize(outline.size());
      ++planes;
      pcl::ExtractIndices<pcl::PointXYZ> extract;
      extract.setInputCloud(remaining);
      extract.setIndices(inliers);
      extract.setNegative(true);
      pcl::PointCloud<pcl::PointXYZ>::Ptr rest(new pcl::PointCloud<pcl::PointXYZ>);
      extract.filter(*rest);
      remaining = rest;
    }
  }
  state.counters["planes"] = static_cast<double>(planes);
  state.counters["points"] = static_cast<double>(input->size());
}
BENCHMARK(BM_pcl_extraction)->Arg(0)->Arg(20)->Unit(benchmark::kMillisecond);
#endif

BENCHMARK(BM_registration)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_clustering)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_plane_extraction_organized)->Arg(0)->Arg(50)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_plane_extraction)->Arg(0)->Arg(20)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_merging)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
