// geometric_map_real_frames: lesson 08's pipeline (paper 004, GeometricMapper) on real frames
// from ../shared/data (RANGENAV_DATA_DIR): MRPT's plane-based-map demo (4 organised RGB-D frames
// with camera poses) and PCL's stereo table scene (one 640 x 480 frame, no pose). The lesson maps
// the simulated kitchen, whose true planes score the map; these frames have no ground truth, so
// this prints what the mapper found: per frame the ICP's correction of the given pose and the
// planes extracted and merged, then every shape of the map (plane, area, vertices, holes).
//
//   geometric_map_real_frames [data_dir]
//
// A data set that is absent is skipped. The last line printed is JSON.

#include <cstdio>
#include <filesystem>
#include <numbers>
#include <random>
#include <string>

#include "rangenav/io/mrpt_pose.hpp"
#include "rangenav/io/pcd.hpp"
#include "rangenav/mapping/geometric_mapper.hpp"

using namespace rangenav;

namespace {

/// A cloud from a camera's optical frame (x right, y down, z ahead) in its body frame (x ahead,
/// y left, z up), as the mapper expects; and the body -> optical rotation.
Transform3d body_to_optical() {
  Transform3d t = Transform3d::Identity();
  t.linear() << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  return t;
}
Cloud3d optical_to_body(Cloud3d cloud) {
  const Transform3d t = body_to_optical().inverse();
  for (auto& p : cloud.points)
    p = t * p;
  return cloud;
}

void print_shapes(const GeometricMap<double>& map) {
  for (const auto& s : map.shapes()) {
    const auto& pl = s.surface.plane;
    std::printf(
        "    shape %zu: n = (%+.3f, %+.3f, %+.3f), d = %+.3f m, area %.3f m^2, %zu vertices, %zu "
        "holes, delta %.0f\n",
        s.id, pl.normal.x(), pl.normal.y(), pl.normal.z(), pl.d, s.surface.area(),
        s.surface.polygon.outer.size(), s.surface.polygon.holes.size(), s.delta);
  }
}

/// The same pipeline on real frames; returns their JSON members.
std::string real_data(const std::filesystem::path& dir) {
  std::string json;
  std::mt19937 rng(5);
  if (std::filesystem::exists(dir / "mrpt_pbmap/pointcloud0.pcd")) {  // 4 frames with poses
    GeometricMapperParams params;
    params.key_frames.min_distance = params.key_frames.min_angle = 0.0;  // every frame
    params.clustering.min_cluster_size = params.planes.min_inliers = 300;
    params.planes.hull.alpha = 0.08;
    params.planes.hull.resolution = 0.005;
    GeometricMapper mapper(params);
    std::size_t extracted = 0, merged = 0;
    for (int k = 0; k < 4; ++k) {
      const std::string n = std::to_string(k);
      const Cloud3d cloud =
          optical_to_body(io::read_pcd<double>(dir / ("mrpt_pbmap/pointcloud" + n + ".pcd")));
      const Transform3d pose =
          io::read_mrpt_pose(dir / ("mrpt_pbmap/pose" + n + ".mat")) * body_to_optical();
      const GeometricFrameReport r = mapper.process(cloud, pose, rng);
      const Transform3d correction = pose.inverse() * r.pose;
      std::printf(
          "mrpt_pbmap frame %d: %s, ICP correction %.3f m %.2f deg, %zu planes, %zu merged\n", k,
          r.registered ? "registered" : "rejected", correction.translation().norm(),
          rotation_angle(correction) * 180 / std::numbers::pi, r.planes.size(), r.merged);
      extracted += r.planes.size();
      merged += r.merged;
    }
    std::printf("  map: %zu shapes from %zu planes\n", mapper.map().size(), extracted);
    print_shapes(mapper.map());
    json += ", \"mrpt_pbmap\": {\"planes_extracted\": " + std::to_string(extracted) +
            ", \"merged\": " + std::to_string(merged) +
            ", \"map_planes\": " + std::to_string(mapper.map().size()) + "}";
  }
  const auto table = dir / "pcl_test/table_scene_mug_stereo_textured.pcd";
  if (std::filesystem::exists(table)) {  // one 640 x 480 frame, no pose
    GeometricMapperParams params;
    params.clustering.min_cluster_size = params.planes.min_inliers = 2000;
    params.clustering.tolerance = 0.02;
    params.planes.distance_threshold = 0.015;
    params.planes.hull.alpha = 0.03;
    params.planes.hull.resolution = 0.002;
    params.extraction_leaf = 0.005;  // a 5 mm voxel filter bounds the extraction's cost
    GeometricMapper mapper(params);
    const GeometricFrameReport r =
        mapper.process(optical_to_body(io::read_pcd<double>(table)), Transform3d::Identity(), rng);
    std::printf(
        "table_scene_mug_stereo_textured: %zu points for extraction, %zu clusters, %zu planes, "
        "%zu shapes after merging\n",
        r.extraction_points, r.clusters, r.planes.size(), mapper.map().size());
    print_shapes(mapper.map());
    json += ", \"table_scene\": {\"planes_extracted\": " + std::to_string(r.planes.size()) +
            ", \"map_planes\": " + std::to_string(mapper.map().size()) + "}";
  }
  return json;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string json = real_data(argc > 1 ? argv[1] : RANGENAV_EXAMPLE_DATA_DIR);
  std::printf("{%s}\n", json.empty() ? "" : json.c_str() + 2);  // members start with ", "
  return 0;
}
