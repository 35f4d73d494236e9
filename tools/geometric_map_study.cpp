// geometric_map_study: lesson 08's kitchen runs with the settings of paper 004's pipeline varied,
// to measure what each setting does to Table 1's accuracy, the plane reduction and the key-frame
// pose error (the lesson runs the defaults only).
//
//   geometric_map_study [--full] [--frames N] [--cycles C] [--seed S] [--run KEY] [--verbose]
//                       [--kd-clustering] [--full-res-point-map] [--no-range-noise]
//                       [--offset-test origin|centroid]
//
//   --full                 640 x 480 frames (clustering tolerance and hull alpha 0.15 m, see the
//                          lesson) and 120 frames; by default 160 x 120 and 10 frames
//   --frames N, --cycles C sequence length and back-and-forth cycles in it (a key frame needs
//                          0.15 m or 0.15 rad of motion: one cycle gives at most ~30 key frames)
//   --seed S               seed of the sensor noise and the odometry drift (default 42)
//   --run KEY              only the run "0", "0.005", "0.02" or "objects"
//   --verbose              one line per key frame: pose error and the ICP's outcome
//   --kd-clustering        cluster with kd-tree radius queries instead of image neighbours
//   --full-res-point-map   key frames join the point map at full resolution, not voxel-filtered
//   --no-range-noise       the mapper is not told the sensor's noise (range_noise = 0)
//   --offset-test origin   Eq. (6b) compares the planes' offsets at the world origin, as the paper
//
// Prints one line per run and, last, one JSON line.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "rangenav/mapping/geometric_mapper.hpp"
#include "support/kitchen_truth.hpp"

using namespace rangenav;

namespace {

struct Options {
  bool full = false, kd_clustering = false, full_res_point_map = false, no_range_noise = false;
  bool verbose = false;
  int frames = 0, cycles = 1;
  unsigned seed = 42;
  PlaneOffsetTest offset_test = GeometricMapParameters<double>{}.offset_test;
  std::string only_run;
};

/// The lesson's settings with the options applied.
GeometricMapperParams study_params(const Options& o, double fy, double sigma) {
  GeometricMapperParams p;
  p.key_frames.min_distance = p.key_frames.min_angle = 0.15;
  p.clustering.min_cluster_size = p.planes.min_inliers = o.full ? 2000 : 150;
  p.planes.distance_threshold = std::max(0.02, 2.5 * sigma);
  p.planes.hull.alpha = o.full ? 4.0 / fy / std::sin(2.5 * std::numbers::pi / 180) : 0.1;
  if (o.full) p.clustering.tolerance = p.planes.hull.alpha;
  p.planes.hull.resolution = 0.005;
  p.extraction_leaf = 0.0;
  p.organized_clustering = !o.kd_clustering;
  p.point_map_downsampled = !o.full_res_point_map;
  p.range_noise = o.no_range_noise ? 0.0 : sigma;
  p.merging.offset_test = o.offset_test;
  return p;
}

bool parse(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool value = i + 1 < argc;
    if (a == "--full")
      o.full = true;
    else if (a == "--kd-clustering")
      o.kd_clustering = true;
    else if (a == "--full-res-point-map")
      o.full_res_point_map = true;
    else if (a == "--no-range-noise")
      o.no_range_noise = true;
    else if (a == "--verbose")
      o.verbose = true;
    else if (a == "--frames" && value)
      o.frames = std::max(1, std::atoi(argv[++i]));
    else if (a == "--cycles" && value)
      o.cycles = std::max(1, std::atoi(argv[++i]));
    else if (a == "--seed" && value)
      o.seed = static_cast<unsigned>(std::strtoul(argv[++i], nullptr, 10));
    else if (a == "--run" && value)
      o.only_run = argv[++i];
    else if (a == "--offset-test" && value) {
      const std::string t = argv[++i];
      if (t != "origin" && t != "centroid") return false;
      o.offset_test = t == "origin" ? PlaneOffsetTest::origin : PlaneOffsetTest::centroid;
    } else
      return false;
  }
  if (o.frames == 0) o.frames = o.full ? 120 : 10;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, o)) {
    std::fprintf(stderr,
                 "usage: geometric_map_study [--full] [--frames N] [--cycles C] [--seed S] "
                 "[--run KEY] [--verbose] [--kd-clustering] [--full-res-point-map] "
                 "[--no-range-noise] [--offset-test origin|centroid]\n");
    return 2;
  }
  struct Run {
    const char* key;
    double sigma;
    bool objects;
  };
  std::string json;
  for (const Run run : {Run{"0", 0.0, false}, Run{"0.005", 0.005, false}, Run{"0.02", 0.02, false},
                        Run{"objects", 0.0, true}}) {
    if (!o.only_run.empty() && o.only_run != run.key) continue;
    const sim::Scene scene = kitchen::scene(run.objects);
    const sim::TofCamera camera = kitchen::camera(o.full, run.sigma);
    GeometricMapper mapper(study_params(o, camera.params().intrinsics.fy, run.sigma));
    std::mt19937 rng(o.seed);
    std::normal_distribution<double> odo(0.0, 1.0);
    Pose2d drift;
    std::size_t extracted = 0;
    double error_sum = 0, error_max = 0, cpu = 0;
    std::optional<std::pair<Transform3d, Transform3d>> first;  // truth, estimate
    for (int k = 0; k < o.frames; ++k) {
      const Pose2d robot = kitchen::path(k, o.frames, o.cycles);
      drift = {drift.x + 0.005 * odo(rng), drift.y + 0.005 * odo(rng),
               drift.theta + 0.002 * odo(rng)};
      const Pose2d guess{robot.x + drift.x, robot.y + drift.y, robot.theta + drift.theta};
      const Cloud3d cloud = to_organized_cloud(camera.capture(scene.world, robot, rng));
      const std::clock_t t0 = std::clock();
      const GeometricFrameReport r =
          mapper.process(cloud, sim::robot_transform(guess) * camera.camera_to_robot(), rng);
      cpu += static_cast<double>(std::clock() - t0) / CLOCKS_PER_SEC;
      if (!r.registered) continue;
      const Transform3d truth = sim::robot_transform(robot) * camera.camera_to_robot();
      if (!first) first.emplace(truth, r.pose);
      const Transform3d error =
          (first->first.inverse(Eigen::Isometry) * truth).inverse(Eigen::Isometry) *
          (first->second.inverse(Eigen::Isometry) * r.pose);
      error_sum += error.translation().norm();
      error_max = std::max(error_max, error.translation().norm());
      extracted += r.planes.size();
      if (o.verbose && r.icp)
        std::printf("  frame %3d: pose error %6.1f mm, ICP %s after %d iterations, fitness %.2f\n",
                    k, 1e3 * error.translation().norm(),
                    std::string(to_string(r.icp->reason)).c_str(), r.icp->iterations,
                    r.icp->fitness);
    }
    const kitchen::Accuracy acc = kitchen::accuracy(mapper.map(), scene);
    const double n = std::max<double>(1.0, static_cast<double>(mapper.key_frames()));
    const double reduction =
        mapper.map().empty() ? 0.0 : double(extracted) / double(mapper.map().size());
    std::printf(
        "run %-7s %zu key frames: d_coeff %.4f d_angle %.4f d_dist %.4f RMS_p %.4f, %zu extracted "
        "/ %zu map planes (%.2f), pose error %.1f / %.1f mm, %.1f ms per key frame\n",
        run.key, mapper.key_frames(), acc.d_coeff, acc.d_angle, acc.d_dist, acc.rms_p, extracted,
        mapper.map().size(), reduction, 1e3 * error_sum / n, 1e3 * error_max, 1e3 * cpu / n);
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "%s\"%s\": {\"d_coeff\": %.4f, \"d_angle\": %.4f, \"d_dist\": %.4f, "
                  "\"rms_p\": %.4f, \"plane_reduction\": %.2f, \"map_planes\": %zu, "
                  "\"pose_error_mm\": %.1f, \"ms_per_keyframe\": %.1f}",
                  json.empty() ? "" : ", ", run.key, acc.d_coeff, acc.d_angle, acc.d_dist,
                  acc.rms_p, reduction, mapper.map().size(), 1e3 * error_sum / n, 1e3 * cpu / n);
    json += buf;
  }
  std::printf("{%s}\n", json.c_str());
  return 0;
}
