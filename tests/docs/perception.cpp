// The snippets of docs/egocentric.md, docs/geometry.md and docs/mapping.md (geometric maps),
// compiled and run in the simulator; each test checks what the page says against the truth.

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

#include "docs_support.hpp"
#include "rangenav/rangenav.hpp"

using namespace rangenav;

TEST_CASE("egocentric: a pitching scanner's obstacle map sees what a 2D laser misses", "[docs]") {
  // A corridor with a 10 cm box on the floor, 3 m ahead of the robot: below a 2D laser's plane.
  sim::World world;
  world.add_wall({{-1.0, -1.5}, {8.0, -1.5}});
  world.add_wall({{-1.0, 1.5}, {8.0, 1.5}});
  world.add_wall({{8.0, -1.5}, {8.0, 1.5}});
  world.add_box({{3.1, 0.0}, {0.2, 0.3}, 0.0, 0.0, 0.10});
  world.build_index();
  const sim::PitchingScanner scanner;
  std::mt19937 rng(4);
  std::vector<std::pair<PitchedScan<double>, Pose2d>> stream;  // standing still for 3 s
  for (std::size_t k = 0; scanner.scan_time(k) < 3.0; ++k)
    stream.emplace_back(scanner.scan(world, {0, 0, 0}, scanner.scan_time(k), rng), Pose2d{});
  const Point3d sensor_offset = scanner.params().sensor_offset;
  LaserScan<double> structure;
  // [snippet:obstacle-map]
  ObstacleMap<double> obstacles({}, ObstacleMapPolicy{.z_min = 0.0, .z_max = 1.0});  // 720 bins
  PitchingObstacleExtractor<double> extractor(sensor_offset);  // floor removed (§4.2)
  SweepAssembler<double> sweeps({sensor_offset});              // one cloud per nod (§6.1)
  Pose2d previous_odometry;
  for (const auto& [pitched_scan, odometry] : stream) {  // a PitchedScan and the odometry pose
    // §4.4: move the stored points by the pose shift (Eq. 4), age them out, insert the new ones
    obstacles.update(relative(previous_odometry, odometry), extractor.push(pitched_scan, odometry));
    if (sweeps.push(pitched_scan, odometry))
      structure = structure_scan(sweeps.sweep());  // farthest reading per bearing: the walls
    previous_odometry = odometry;
  }
  const LaserScan<double> as_scan = obstacles.to_laser_scan();  // for any 2D scan algorithm
  // [snippet-end]
  double ahead = 1e9;  // the nearest point within a bin of straight ahead
  for (std::size_t k = obstacles.bin_index(0.0) - 1; k <= obstacles.bin_index(0.0) + 1; ++k)
    ahead = std::min(ahead, obstacles.bin(k).range);
  CHECK(ahead == Approx(3.0).margin(0.05));  // the box, not the wall at 8 m
  CHECK(as_scan.size() == obstacles.size());
  REQUIRE(structure.size() > 0);
  CHECK(structure.valid_count() > 0);
}

TEST_CASE("egocentric: obstacles from a ToF camera, fused with a 2D laser", "[docs]") {
  const sim::Scene scene = sim::apartment();
  const Pose2d robot{3.0, 3.3, -std::numbers::pi / 2};  // facing the couch table, 1.2 m away
  std::mt19937 rng(7);
  sim::TofCamera camera;
  const PanTilt<double> gaze =
      look_at(Point3d(camera.params().mount.translation()),
              gaze_target(0.2, 0.0, 0.0, GazeParams<double>{.d_min = 1.2}));
  camera.set_pan_tilt(gaze.pan, gaze.tilt);  // Eq. (16): look at the floor ahead
  DepthImage<double> image = camera.capture(scene.world, robot, rng);
  const Transform3d camera_to_robot = camera.camera_to_robot();
  const LaserScan<double> laser_scan = sim::LaserScanner2D().scan(scene.world, robot, rng);
  // [snippet:tof]
  std::vector<double> scratch;  // reused between frames
  JumpEdgeFilter<double> jump_edges(image.intrinsics, image.kind);
  HeightImageObstacleDetector<double> detector;  // epsilon_H = 3 cm, corridor [0, 1] m
  apply_amplitude_threshold(image, 50.0);        // weak, far or peripheral returns
  apply_median_filter(image, scratch);           // 3 x 3
  jump_edges.filter(image);                      // mixed pixels, Eq. (13)-(14) of paper 002
  detector.detect(image, camera_to_robot);       // height image and Eq. (15)
  const LaserScan<double> virtual_scan = detector.virtual_scan();  // one reading per column

  ObstacleMap<double> fused;  // the 2D laser and the camera in one map (paper 002 Fig. 15)
  fused.insert(laser_scan, PlanarMount<double>{.pose = {}, .height = 0.30});
  fused.insert(detector.obstacle_points());
  // [snippet-end]
  const double table_top = 3.3 - 2.1;  // the couch table's top edge, straight ahead
  const double laser_ahead = laser_scan.range(laser_scan.size() / 2);
  CHECK(laser_ahead > table_top + 0.1);  // the 2D laser passes under the table top
  CHECK(fused.bin(fused.bin_index(0.0)).range == Approx(table_top).margin(0.05));
  CHECK(virtual_scan.valid_count() > 0);
}

TEST_CASE("geometry: clusters, planes and concave hulls of a noisy box corner", "[docs]") {
  // Three faces of a 1 m cube corner, sampled every 2 cm with 2 mm of noise, and a far blob.
  std::mt19937 noise_rng(1);
  std::normal_distribution<double> noise(0.0, 0.002);
  std::vector<Point3d> points;
  for (double u = 0.01; u < 1.0; u += 0.02)
    for (double v = 0.01; v < 1.0; v += 0.02) {
      points.emplace_back(u, v, noise(noise_rng));  // floor z = 0
      points.emplace_back(u, noise(noise_rng), v);  // wall y = 0
      points.emplace_back(noise(noise_rng), u, v);  // wall x = 0
    }
  for (int i = 0; i < 50; ++i)
    points.emplace_back(5.0 + 0.01 * i, 5.0, 5.0);
  // [snippet:planes]
  const std::vector<Point3d> thinned = voxel_downsample(points, 0.03);  // centroid per voxel
  const KdTree<3, double> tree(thinned);
  const auto clusters = euclidean_clusters(tree, {.tolerance = 0.1, .min_cluster_size = 100});
  std::mt19937 rng(1);                 // RANSAC draws: same seed, same planes
  PlaneExtractionParams plane_params;  // RANSAC band: 2 cm
  plane_params.min_inliers = 200;
  PlaneExtractor extractor(plane_params);
  std::vector<ExtractedPlane> planes;
  for (const auto& cluster : clusters)  // each cluster: indices into `thinned`
    extractor.extract(std::span<const Point3d>(thinned), cluster, rng, planes);
  // planes[i].shape: the plane (n, d), its frame and the alpha-shape outline of its inliers
  // [snippet-end]
  CHECK(clusters.size() == 1);  // the blob is below min_cluster_size
  REQUIRE(planes.size() == 3);
  for (const ExtractedPlane& p : planes) {
    const Point3d n = p.shape.plane.normal.cwiseAbs();
    CHECK(n.maxCoeff() > 0.999);              // axis-aligned
    CHECK(std::abs(p.shape.plane.d) < 0.01);  // through the origin
    CHECK(p.shape.area() == Approx(1.0).epsilon(0.1));
  }

  std::vector<Point2d> disc;
  for (double x = -1; x <= 1; x += 0.02)
    for (double y = -1; y <= 1; y += 0.02)
      if (x * x + y * y <= 1 && !(std::abs(x) < 0.3 && std::abs(y) < 0.3)) disc.emplace_back(x, y);
  // [snippet:hull]
  const std::vector<Polygon2<double>> shapes = concave_hull(disc, {.alpha = 0.05});
  // shapes[0].outer: counter-clockwise; shapes[0].holes: clockwise; largest piece first
  // [snippet-end]
  REQUIRE(shapes.size() == 1);
  CHECK(shapes[0].holes.size() == 1);
  CHECK(shapes[0].area() == Approx(std::numbers::pi - 0.36).epsilon(0.03));
}

TEST_CASE("mapping: a geometric map of the simulated kitchen", "[docs]") {
  const sim::Scene kitchen = sim::kitchen();
  sim::TofCameraParams cp;  // a Kinect-like depth camera at 160 x 120, noise-free
  cp.intrinsics = PinholeIntrinsics<double>::from_fov(160, 120, deg_to_rad(57.0), deg_to_rad(43.0));
  cp.tilt = 0.35;
  cp.range_max = 6.0;
  cp.noise_sigma_0 = cp.noise_sigma_2 = 0.0;
  cp.jump_edges = false;
  const sim::TofCamera camera(cp);
  std::mt19937 sim_rng(2);
  std::vector<std::pair<Cloud3d, Transform3d>> frames;  // the camera moving along the kitchen
  for (int i = 0; i < 5; ++i) {
    const Pose2d robot{3.9, 1.6 + 0.2 * i, std::numbers::pi};
    frames.emplace_back(to_organized_cloud(camera.capture(kitchen.world, robot, sim_rng)),
                        sim::robot_transform(robot) * camera.camera_to_robot());
  }
  // [snippet:geometric-mapper]
  GeometricMapperParams params;  // paper 004's pipeline (Fig. 1); tuned for a 160 x 120 camera:
  params.key_frames.min_distance = 0.15;  // m between key frames
  params.clustering.min_cluster_size = 150;
  params.planes.min_inliers = 150;
  params.planes.hull.alpha = 0.1;  // m, the largest circumradius the alpha shape keeps
  GeometricMapper mapper(params);
  std::mt19937 rng(1);
  for (const auto& [cloud, odometry] : frames) {  // organised cloud, sensor frame; pose guess
    const GeometricFrameReport report = mapper.process(cloud, odometry, rng);
    if (!report.registered) continue;  // not a key frame, or rejected for a low fitness
    // report.planes: this key frame's planes; report.merged: how many joined map shapes
  }
  // mapper.map().shapes(): the map's planar polygons; mapper.point_map(): its sparse point map
  // [snippet-end]
  REQUIRE(mapper.map().shapes().size() >= 3);
  std::size_t on_true_planes = 0;
  for (const auto& shape : mapper.map().shapes())
    for (const auto& truth : kitchen.planes)
      if (std::abs(shape.surface.plane.normal.dot(truth.normal)) > std::cos(deg_to_rad(3.0)) &&
          std::abs(truth.normal.dot(shape.centroid) + truth.d) < 0.03) {
        ++on_true_planes;
        break;
      }
  CHECK(on_true_planes >= 3);  // floor, wall, kitchen front at least
}
