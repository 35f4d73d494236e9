// 05_tof_obstacles: obstacles from a time-of-flight camera, fused with a 2D laser scan into one
// obstacle map (paper 002 §7.1-7.2 and §7.4, Fig. 13-15).
//
// The robot stands in front of the couch table of the simulated apartment. Its 2D laser (0.30 m
// above the floor) passes under the table top and sees only the thin legs; a SwissRanger-like
// ToF camera (176 x 144 pixels, 43 x 34 deg) on a pan-tilt head 1.1 m high is pointed by the
// gaze controller of Eq. (16) at the floor ahead of the robot. Each frame goes through
//   1. the amplitude threshold (weak, far or peripheral returns),
//   2. a 3x3 median filter (the jump-edge filter is sensitive to noise),
//   3. the jump-edge filter of Eq. (13)-(14), which removes the simulator's mixed pixels,
//   4. the height image and the obstacle test of Eq. (15),
//   5. the virtual scan (one reading per image column, max range where no obstacle),
// and the virtual scan's obstacles are fused with the laser scan in an ObstacleMap.
//
// Then the same detection runs on real organised RGB-D clouds from ../shared/data (pcl_test,
// mrpt_pbmap) when they are present, or on the PCD files given as arguments, each turned into a
// depth image by support/cloud_depth_image.hpp. Their camera pose is not known, so a level camera
// is assumed and only the height differences of Eq. (15) count.
//
// Usage: 05_tof_obstacles [cloud.pcd ...]. The last line printed is JSON.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "rangenav/egocentric/gaze.hpp"
#include "rangenav/egocentric/tof_obstacles.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/io/pcd.hpp"
#include "rangenav/scan/tof_filters.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

#include "support/cloud_depth_image.hpp"

using namespace rangenav;

namespace {

// CPU milliseconds per call of f, averaged over `repeat` calls (CPU time, so that a busy machine
// does not inflate it).
template <class F>
double cpu_ms(F&& f, int repeat) {
  const std::clock_t t0 = std::clock();
  for (int i = 0; i < repeat; ++i)
    f();
  return 1e3 * static_cast<double>(std::clock() - t0) / CLOCKS_PER_SEC / repeat;
}

std::string real_cloud_json(const std::filesystem::path& path) {
  const Cloud3d cloud = io::read_pcd<double>(path);
  if (!cloud.is_organized()) {
    std::printf("%s: not organised, skipped\n", path.filename().string().c_str());
    return {};
  }
  const DepthImage<double> raw = examples::depth_image_from_cloud(cloud);
  std::size_t valid = 0;
  for (const double d : raw.depth)
    valid += DepthImage<double>::is_valid_depth(d) ? 1 : 0;
  JumpEdgeFilter<double> jump(raw.intrinsics, raw.kind);
  // Unknown camera pose: a level camera at height 0; the corridor and the stair test are off.
  HeightImageParams<double> hp;
  hp.z_min = -100, hp.z_max = 100, hp.below_floor = 100;
  HeightImageObstacleDetector<double> detector(hp);
  DepthImage<double> img = raw;
  std::vector<double> scratch;
  std::size_t jumps = 0, obstacles = 0;
  const double ms = cpu_ms(
      [&] {
        std::copy(raw.depth.begin(), raw.depth.end(), img.depth.begin());
        apply_median_filter(img, scratch);
        jumps = jump.filter(img);
        obstacles = detector.detect(img, Transform3d::Identity());
      },
      3);
  const LaserScan<double> scan = detector.virtual_scan();
  std::printf(
      "%s: %zu x %zu, %zu valid, %zu jump edges removed, %zu obstacle points, "
      "virtual scan %zu / %zu beams, %.1f ms CPU\n",
      path.filename().string().c_str(), cloud.width, cloud.height, valid, jumps, obstacles,
      scan.valid_count(), scan.size(), ms);
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "{\"file\": \"%s\", \"pixels\": %zu, \"valid\": %zu, \"jump_edges\": %zu, "
                "\"obstacle_points\": %zu, \"virtual_scan_beams\": %zu, \"ms\": %.2f}",
                path.filename().string().c_str(), cloud.size(), valid, jumps, obstacles,
                scan.valid_count(), ms);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  const sim::Scene scene = sim::apartment();
  const Pose2d robot{3.0, 3.3, -std::numbers::pi / 2};  // facing the couch table, 1.2 m away
  std::mt19937 rng(7);

  // Gaze control (Eq. 16): driving ahead at 0.2 m/s, look at the floor beyond d_min.
  GazeParams<double> gaze;
  gaze.d_min = 1.2;
  sim::TofCamera camera;
  const Point3d head = camera.params().mount.translation();
  const Point3d target = gaze_target(0.2, 0.0, 0.0, gaze);
  const PanTilt<double> pt = look_at(head, target);
  camera.set_pan_tilt(pt.pan, pt.tilt);
  std::printf("gaze: look-at point (%.2f, %.2f, %.2f) m -> pan %.1f deg, tilt %.1f deg\n",
              target.x(), target.y(), target.z(), rad_to_deg(pt.pan), rad_to_deg(pt.tilt));

  const DepthImage<double> raw = camera.capture(scene.world, robot, rng);
  const std::vector<double> truth = camera.true_depth(scene.world, robot);
  const Transform3d extrinsics = camera.camera_to_robot();
  const std::size_t w = raw.width(), h = raw.height();

  DepthImage<double> img = raw, before_jump = raw;  // before_jump: the jump-edge filter's input
  std::vector<double> scratch;
  JumpEdgeFilter<double> jump(raw.intrinsics, raw.kind);
  HeightImageObstacleDetector<double> detector;  // ε_H = 3 cm, corridor [0, 1] m
  std::size_t weak = 0, jumps = 0, obstacle_pixels = 0;
  const auto pipeline = [&] {
    std::copy(raw.depth.begin(), raw.depth.end(), img.depth.begin());
    weak = apply_amplitude_threshold(img, 50.0);  // ~4.5 m at 1000 / d^2
    apply_median_filter(img, scratch);
    before_jump.depth = img.depth;
    jumps = jump.filter(img);
    obstacle_pixels = detector.detect(img, extrinsics);
  };
  const double frame_ms = cpu_ms(pipeline, 20);  // the same result every time
  const LaserScan<double> virtual_scan = detector.virtual_scan();

  // The simulator's truth, for the jump-edge filter's input (the median may carry a mixed value
  // into a neighbour): mixed pixels are those whose reading is far from the true depth of the
  // pixel centre; real edges are correct pixels next to a much deeper neighbour.
  const auto [mixed, mixed_removed, edges, edges_kept] =
      camera.score_jump_edges(truth, before_jump, img);

  // Fusion with the 2D laser (Fig. 15): both into one obstacle map.
  const LaserScan<double> laser = sim::LaserScanner2D().scan(scene.world, robot, rng);
  ObstacleMap<double> fused;
  fused.insert(laser, PlanarMount<double>{Pose2d{}, 0.30});
  const double laser_ahead = fused.bin(fused.bin_index(0.0)).range;
  fused.insert(detector.obstacle_points());
  const double fused_ahead = fused.bin(fused.bin_index(0.0)).range;
  const double vscan_ahead = virtual_scan.range(virtual_scan.size() / 2);
  const double table = 3.3 - 2.1;  // the couch table's top edge, straight ahead

  std::printf(
      "frame %zu x %zu: %zu weak returns removed, %zu jump edges removed "
      "(%zu of %zu simulated mixed pixels, %zu of %zu real edge pixels kept)\n",
      w, h, weak, jumps, mixed_removed, mixed, edges_kept, edges);
  std::printf(
      "obstacles: %zu pixels; virtual scan: %zu of %zu beams; straight ahead: virtual "
      "scan %.3f m, 2D laser %.3f m, fused map %.3f m (table top at %.3f m)\n",
      obstacle_pixels, virtual_scan.valid_count(), virtual_scan.size(), vscan_ahead, laser_ahead,
      fused_ahead, table);
  std::printf(
      "pipeline: %.2f ms CPU per frame (amplitude, median, jump edges, Eq. 15, virtual scan)\n",
      frame_ms);

  std::vector<std::filesystem::path> files;
  for (int i = 1; i < argc; ++i)
    files.emplace_back(argv[i]);
  if (files.empty()) {
    const std::filesystem::path data = RANGENAV_EXAMPLE_DATA_DIR;
    for (const char* f : {"pcl_test/milk_cartoon_all_small_clorox.pcd", "pcl_test/office1.pcd",
                          "mrpt_pbmap/pointcloud0.pcd", "mrpt_pbmap/pointcloud1.pcd"})
      if (std::filesystem::exists(data / f)) files.push_back(data / f);
    if (files.empty()) std::printf("real clouds: %s not found, skipped\n", data.string().c_str());
  }
  std::string real = "[";
  for (const auto& f : files) {
    const std::string j = real_cloud_json(f);
    if (j.empty()) continue;
    real += (real.size() > 1 ? ", " : "") + j;
  }
  real += "]";

  std::printf(
      "{\"sim\": {\"mixed_pixels\": %zu, \"mixed_removed\": %zu, \"edge_pixels\": %zu, "
      "\"edge_pixels_kept\": %zu, \"obstacle_pixels\": %zu, \"virtual_scan_beams\": %zu, "
      "\"table_top_m\": %.3f, \"virtual_scan_ahead_m\": %.3f, \"laser_ahead_m\": %.3f, "
      "\"fused_ahead_m\": %.3f, \"frame_ms\": %.3f}, \"real\": %s}\n",
      mixed, mixed_removed, edges, edges_kept, obstacle_pixels, virtual_scan.valid_count(), table,
      vscan_ahead, laser_ahead, fused_ahead, frame_ms, real.c_str());
  return 0;
}
