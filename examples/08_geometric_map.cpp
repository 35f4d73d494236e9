// Lesson 08: a geometric (plane) map from a depth camera (paper 004, Fig. 1 and §3-4).
//
// A map of planar polygons is far smaller than a point cloud and says what the surfaces are: a
// floor, a wall, a table top. In this lesson a Kinect-like camera moves back and forth in front
// of the simulated kitchen (a counter, its front, the wall behind, the floor, a table with a
// cereal box and a bottle), its odometry guess drifting, and every frame goes through paper
// 004's pipeline, GeometricMapper:
//   1. key frames: a frame is processed once the guess has moved far enough;
//   2. registration: a voxel filter, then frustum ICP against the point map built so far
//      (point-to-plane); a frame whose fitness is too low is rejected;
//   3. extraction: Euclidean clusters of the aligned frame, planes in each by iterative RANSAC,
//      each plane's inliers projected onto it and outlined by an alpha shape (Eq. 1-3);
//   4. aggregation: a new polygon similar to a map shape (Eq. 6) and intersecting it merges with
//      it into their union on the weighted average plane (Eq. 7-12).
// As in the paper's §4 it runs four times, with range noise sigma 0, 0.005 and 0.02 m and with
// non-planar objects added, and prints Table 1's accuracy against the simulator's true planes,
// the plane reduction (extractions per map plane) and the data reduction of Table 5.
//
// Run it as `08_geometric_map [--full]`: 160 x 120 frames and a 10-frame sequence by default,
// 640 x 480 and 120 frames with --full. It writes 08_geometric_map.svg (top view) and .ply (the
// map as a cloud) of the noise-free run; the last line printed is JSON. Variations of the
// pipeline's settings are measured by tools/geometric_map_study, and the same pipeline on real
// RGB-D and stereo frames (MRPT's and PCL's) runs in tools/geometric_map_real_frames.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <numbers>
#include <optional>
#include <random>
#include <string>

#include "rangenav/io/ply.hpp"
#include "rangenav/io/svg.hpp"
#include "rangenav/mapping/geometric_mapper.hpp"
#include "support/kitchen_truth.hpp"

using namespace rangenav;

namespace {

/// The mapper's settings for this camera. Key frames every 0.15 m / 0.15 rad; clusters and
/// planes of at least 150 points (2000 at 640 x 480); a RANSAC band of 2 cm or 2.5 sigma.
GeometricMapperParams mapper_params(const sim::TofCamera& camera, bool full, double sigma) {
  GeometricMapperParams params;
  params.key_frames.min_distance = 0.15;
  params.key_frames.min_angle = 0.15;
  params.clustering.min_cluster_size = full ? 2000 : 150;
  params.planes.min_inliers = full ? 2000 : 150;
  params.planes.distance_threshold = std::max(0.02, 2.5 * sigma);
  params.planes.hull.alpha = 0.1;
  params.planes.hull.resolution = 0.005;
  if (full) {
    // Two image neighbours on a surface seen at a grazing angle g from range r lie about
    // r * dtheta / sin(g) apart (dtheta ~ 1 / fy between rows): the counter top, seen from 3-4 m
    // at 2-3 deg, has rows 8-16 cm apart. Clustering tolerance and alpha for a 4 m working range
    // and grazing angles down to 2.5 deg: 0.15 m. (At 160 x 120 the counter top spans one or two
    // rows, too few for a plane whatever the tolerance: 5 cm stays.)
    constexpr double working_range = 4.0, min_grazing = 2.5 * std::numbers::pi / 180;
    params.clustering.tolerance =
        working_range / camera.params().intrinsics.fy / std::sin(min_grazing);
    params.planes.hull.alpha = params.clustering.tolerance;
  }
  params.extraction_leaf = 0.0;  // extract from the full-resolution frame
  // The sensor's noise: the registration widens its voxel leaf to 5 sigma and, above 1 cm, its
  // normals' PCA, since a 5 cm voxel filter does not average 2 cm of noise away.
  params.range_noise = sigma;
  return params;
}

/// One run of the lesson: the camera path through the kitchen, mapped; prints what Table 1 and
/// Table 5 of the paper print and returns the run's JSON member.
std::string map_kitchen(const std::string& key, double sigma, bool objects, bool full) {
  const sim::Scene scene = kitchen::scene(objects);
  const sim::TofCamera camera = kitchen::camera(full, sigma);
  GeometricMapper mapper(mapper_params(camera, full, sigma));
  const int frames = full ? 120 : 10;

  std::mt19937 rng(42);
  std::normal_distribution<double> odo(0.0, 1.0);
  Pose2d drift{0, 0, 0};  // the odometry guess drifts by a random walk
  std::size_t extracted = 0, raw_points = 0;
  double pose_error_sum = 0, pose_error_max = 0, cpu = 0;
  std::optional<Transform3d> first_truth;
  Transform3d first_pose = Transform3d::Identity();
  for (int k = 0; k < frames; ++k) {
    const Pose2d robot = kitchen::path(k, frames, 1);
    drift = {drift.x + 0.005 * odo(rng), drift.y + 0.005 * odo(rng),
             drift.theta + 0.002 * odo(rng)};
    const Pose2d guess{robot.x + drift.x, robot.y + drift.y, robot.theta + drift.theta};
    // The frame: an organised cloud in the camera's body frame, and the camera's pose guess.
    const Cloud3d cloud = to_organized_cloud(camera.capture(scene.world, robot, rng));
    const Transform3d pose_guess = sim::robot_transform(guess) * camera.camera_to_robot();
    const std::clock_t t0 = std::clock();
    const GeometricFrameReport report = mapper.process(cloud, pose_guess, rng);
    cpu += static_cast<double>(std::clock() - t0) / CLOCKS_PER_SEC;
    if (!report.registered) continue;
    // The key frame's pose against the simulator's truth, relative to the first key frame (the
    // map's frame is that frame's pose guess).
    const Transform3d truth = sim::robot_transform(robot) * camera.camera_to_robot();
    if (!first_truth) first_truth = truth, first_pose = report.pose;
    const Transform3d true_motion = first_truth->inverse(Eigen::Isometry) * truth;
    const Transform3d motion = first_pose.inverse(Eigen::Isometry) * report.pose;
    const double err = (true_motion.inverse(Eigen::Isometry) * motion).translation().norm();
    pose_error_sum += err;
    pose_error_max = std::max(pose_error_max, err);
    for (const auto& p : cloud.points)
      raw_points += p.allFinite() ? 1 : 0;
    extracted += report.planes.size();
  }

  const GeometricMap<double>& map = mapper.map();
  const kitchen::Accuracy acc = kitchen::accuracy(map, scene);
  const double key_frames = static_cast<double>(mapper.key_frames());
  const double ms = key_frames > 0 ? 1e3 * cpu / key_frames : 0.0;
  const double reduction = map.empty() ? 0.0 : double(extracted) / double(map.size());
  const double pose_error_mean = key_frames > 0 ? pose_error_sum / key_frames : 0.0;
  std::printf("run %-7s key frames %zu, planes extracted %zu, in the map %zu (reduction %.2f)\n",
              key.c_str(), mapper.key_frames(), extracted, map.size(), reduction);
  std::printf(
      "  d_coeff %.4f  d_angle %.4f rad  d_dist %.4f m  RMS_p %.4f m  (%zu of the map's "
      "planes associated with the %zu true planes)\n",
      acc.d_coeff, acc.d_angle, acc.d_dist, acc.rms_p, acc.associated, scene.planes.size());
  // The map's other shapes lie on real surfaces without a labelled plane: the side walls, the
  // cereal box, the table's edges and legs, the bottle, the counter top's front edge.
  std::printf("  map shapes per true plane:");
  for (std::size_t i = 0; i < scene.planes.size(); ++i)
    std::printf(" %s %zu,", scene.planes[i].name.c_str(), acc.shapes_per_plane[i]);
  std::printf(" on other surfaces %zu\n", map.size() - acc.associated);
  // Table 5: three 32-bit values per point; the map: 3 per vertex and 4 per plane.
  const double raw_kb = double(raw_points * 12) / 1e3;
  const double point_kb = double(mapper.point_map().size() * 12) / 1e3;
  const double geo_kb = double(map.bytes()) / 1e3;
  std::printf(
      "  data: raw %zu points %.1f kB -> point map %zu points %.1f kB (%.2f%%) -> geometric map "
      "%zu vertices, %zu planes %.2f kB (%.3f%%)\n",
      raw_points, raw_kb, mapper.point_map().size(), point_kb, 100 * point_kb / raw_kb,
      map.vertex_count(), map.size(), geo_kb, 100 * geo_kb / raw_kb);
  std::printf("  %.1f ms CPU per key frame (registration, extraction, merging)\n", ms);
  std::printf("  key-frame pose error against the truth: mean %.1f mm, max %.1f mm\n",
              1e3 * pose_error_mean, 1e3 * pose_error_max);

  if (key == "0") {  // the noise-free map: a top view and the map as a cloud
    io::SvgDrawing svg;
    svg.layer("point map").points(mapper.point_map().points(), {"#999999", "none", 1, 1, 1});
    svg.layer("planes");
    for (const auto& shape : map.shapes())
      svg.polygon(shape.surface.outer_world(), {"#1f77b4", "#1f77b4", 1.5, 0.25, 1.5});
    svg.save("08_geometric_map.svg");
    Cloud3d out;
    for (const Point3d& p : mapper.point_map().points())
      out.points.push_back(mapper.map_origin() * p);
    for (const auto& shape : map.shapes())
      for (const Point3d& v : shape.surface.outer_world())
        out.points.push_back(v);
    out.width = out.points.size();
    io::write_ply("08_geometric_map.ply", out);
    std::printf("  wrote 08_geometric_map.svg and 08_geometric_map.ply\n");
  }
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "\"%s\": {\"d_coeff\": %.4f, \"d_angle\": %.4f, \"d_dist\": %.4f, \"rms_p\": %.4f, "
                "\"plane_reduction\": %.2f, \"map_planes\": %zu, \"true_planes\": %zu, "
                "\"ms_per_keyframe\": %.1f, \"pose_error_mm\": %.1f}",
                key.c_str(), acc.d_coeff, acc.d_angle, acc.d_dist, acc.rms_p, reduction, map.size(),
                scene.planes.size(), ms, 1e3 * pose_error_mean);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  const bool full = argc > 1 && std::string(argv[1]) == "--full";
  std::string json = "{" + map_kitchen("0", 0.0, false, full);
  json += ", " + map_kitchen("0.005", 0.005, false, full);
  json += ", " + map_kitchen("0.02", 0.02, false, full);
  json += ", " + map_kitchen("objects", 0.0, true, full);
  std::printf("%s}\n", json.c_str());
  return 0;
}
