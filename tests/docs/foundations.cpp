// The snippets of docs/core.md, docs/scan.md, docs/sim.md and docs/io.md, compiled and run; each
// test checks what the page says the snippet does.

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <string>
#include <variant>
#include <vector>

#include <catch2/catch.hpp>

#include "docs_support.hpp"
#include "rangenav/rangenav.hpp"

namespace docs = rangenav::docs_test;

TEST_CASE("core: points, poses and clouds", "[docs]") {
  // [snippet:poses]
  const rangenav::Pose2d robot{1.0, 2.0, std::numbers::pi / 2};  // x, y (m), theta (rad)
  const rangenav::Pose2d ahead = rangenav::compose(robot, {0.5, 0.0, 0.0});  // 0.5 m forward
  const rangenav::Pose2d increment = rangenav::relative(robot, ahead);       // (0.5, 0, 0)
  const rangenav::Transform2d T = robot.to_isometry();  // Eigen::Isometry2d: robot -> parent
  const rangenav::Point2d in_world = T * rangenav::Point2d(1.0, 0.0);      // (1, 3)
  const double heading = rangenav::normalize_angle(3 * std::numbers::pi);  // pi, in (-pi, pi]
  // [snippet-end]
  CHECK(ahead.position().isApprox(rangenav::Point2d(1.0, 2.5)));
  CHECK(increment.position().isApprox(rangenav::Point2d(0.5, 0.0)));
  CHECK(std::abs(increment.theta) < 1e-12);
  CHECK(in_world.isApprox(rangenav::Point2d(1.0, 3.0)));
  CHECK(heading == Approx(std::numbers::pi));

  // [snippet:clouds]
  std::vector<Eigen::Vector2d> scan_points{{1.0, 0.0}, {0.0, 2.0}};  // a cloud
  Eigen::Matrix3Xd matrix(3, 2);                                     // a cloud: one point a column
  matrix << 0, 1, 0, 0, 0, 1;
  rangenav::Cloud3d cloud;  // a cloud with optional intensities, colours, normals
  cloud.points = {{0, 0, 0}, {1, 0, 0}, {0, 0, NAN}};
  cloud.width = cloud.points.size();
  static_assert(rangenav::PointCloudOf<decltype(scan_points), 2>);
  static_assert(rangenav::PointCloudOf<Eigen::Matrix3Xd, 3>);
  const std::size_t n = rangenav::traits::size(matrix);          // 2
  const Eigen::Vector3d p = rangenav::traits::point(matrix, 1);  // (1, 0, 1)
  const auto dense = rangenav::finite_points(cloud);             // the 2 finite points
  // [snippet-end]
  CHECK(n == 2);
  CHECK(p.isApprox(Eigen::Vector3d(1, 0, 1)));
  CHECK(dense.size() == 2);
}

TEST_CASE("core: bad input throws an error naming the argument", "[docs]") {
  std::string message;
  // [snippet:errors]
  try {
    const rangenav::LaserScan<double> scan(-1.0, /*angle_increment=*/0.0, 0.05, 30.0, {1.0, 2.0});
  } catch (const rangenav::invalid_argument& e) {  // a rangenav::error, a std::runtime_error
    message = e.what();  // "rangenav: LaserScan: argument 'angle_increment' = 0 must be ..."
  }
  // [snippet-end]
  CHECK(message.find("angle_increment") != std::string::npos);
  CHECK(message.rfind("rangenav: ", 0) == 0);
}

TEST_CASE("core: robust kernels", "[docs]") {
  // [snippet:robust-kernel]
  const auto huber = rangenav::RobustKernel<double>::huber(0.1);  // delta: 0.1 m
  const double s = 0.3 * 0.3;                                     // a squared residual
  const double rho = huber.rho(s);                                // the robust cost of it
  const double weight = huber.weight(s);  // rho'(s): its IRLS weight, 1 inside delta
  // [snippet-end]
  CHECK(rho < s);
  CHECK(weight == Approx(0.1 / 0.3));
}

TEST_CASE("scan: a laser scan, its points and a pitched scan in 3D", "[docs]") {
  std::vector<double> ranges(541, 2.0);
  ranges[10] = std::numeric_limits<double>::quiet_NaN();
  ranges[20] = 30.0;
  // [snippet:laser-scan]
  // SICK S300: 270 deg at 0.5 deg = 541 beams, readings from 0.05 m up to 30 m ("no return").
  const auto geometry = rangenav::ScanGeometry<double>::from_fov(
      rangenav::deg_to_rad(270.0), rangenav::deg_to_rad(0.5), 0.05, 30.0);
  const rangenav::LaserScan<double> scan(geometry, ranges);
  const rangenav::Point2d p = scan.point(270);  // beam 270 (straight ahead): (2, 0), sensor frame
  const bool valid = scan.is_valid(10);         // false: NaN, inf, 0, < range_min, >= range_max
  const auto& points = scan.valid_points();     // the valid beams' points; the scan is a cloud too

  // The same scan taken by a scanner pitched down by 20 deg (Eq. 3 of paper 002), mounted 0.1 m
  // ahead of and 0.4 m above the robot's origin: 3D points in the robot frame.
  const std::vector<rangenav::Point3d> points3 =
      rangenav::pitched_points(scan, rangenav::deg_to_rad(20.0), rangenav::Point3d(0.1, 0, 0.4));
  // [snippet-end]
  CHECK(p.isApprox(rangenav::Point2d(2.0, 0.0), 1e-12));
  CHECK_FALSE(valid);
  CHECK_FALSE(scan.is_valid(20));
  CHECK(points.size() == 539);
  REQUIRE(points3.size() == 539);
  // Beam 270 (straight ahead; beams 10 and 20 are invalid, so it is valid point 268): 2 m along
  // a beam pitched 20 deg down from 0.4 m, i.e. 0.68 m lower.
  REQUIRE(scan.valid_indices()[268] == 270);
  CHECK(points3[268].z() == Approx(0.4 - 2.0 * std::sin(rangenav::deg_to_rad(20.0))));
}

TEST_CASE("scan: a depth image becomes an organised cloud", "[docs]") {
  // [snippet:depth-image]
  rangenav::DepthImage<double> image;
  image.intrinsics = rangenav::PinholeIntrinsics<double>::from_fov(
      176, 144, rangenav::deg_to_rad(43.0), rangenav::deg_to_rad(34.0));  // SR4000
  image.kind = rangenav::DepthKind::radial;  // ToF cameras measure along the ray
  image.depth.assign(176 * 144, 1.5);        // a sphere of 1.5 m around the camera
  const rangenav::Cloud3d cloud = rangenav::to_organized_cloud(image);  // camera body frame:
  // x ahead, y left, z up; 176 x 144 points, invalid pixels kept in place as NaN
  // [snippet-end]
  REQUIRE(cloud.is_organized());
  CHECK(cloud.width == 176);
  CHECK(cloud.height == 144);
  for (const auto& q : cloud.points)
    CHECK(q.norm() == Approx(1.5));
}

TEST_CASE("sim: a scene, sensors and a robot", "[docs]") {
  // [snippet:simulator]
  using namespace rangenav::sim;
  const Scene scene = apartment();  // world + named objects + start pose + tour (paper 002 Fig. 2)
  std::mt19937 rng(42);             // every reading is deterministic for a seed
  const LaserScanner2D laser;       // SICK S300: 270 deg at 0.5 deg, level at 0.30 m
  const rangenav::LaserScan<double> scan = laser.scan(scene.world, scene.start, rng);
  const PitchingScanner pitching;  // paper 002 §3.3: a 181-beam scan every 13.32 ms
  const rangenav::PitchedScan<double> nod = pitching.scan(scene.world, scene.start, 0.5, rng);
  const TofCamera tof;  // SR4000: 176 x 144, 43 x 34 deg, mixed pixels at jump edges
  const rangenav::DepthImage<double> depth = tof.capture(scene.world, scene.start, rng);
  DifferentialDriveRobot robot({}, scene.start);  // (v, omega) at 50 Hz, odometry with errors
  const StepResult step = robot.step(scene.world, 0.3, 0.1, rng);  // moved, or stopped by contact
  const SceneObject& table = scene.object("couch_table");          // ground truth: bounds and parts
  // [snippet-end]
  CHECK(scan.size() == 541);
  CHECK(scan.valid_count() > 400);
  CHECK(nod.scan.size() == 181);
  CHECK(depth.width() == 176);
  CHECK(step.moved);
  CHECK(robot.odometry().position() != scene.start.position());
  CHECK(table.max.z() > 0.3);  // its top lies above the 2D laser's plane
}

TEST_CASE("io: CARMEN logs and trajectories", "[docs]") {
  const docs::ScratchDir dir("docs_io_carmen");
  const std::filesystem::path log_path = dir / "tour.clf";
  const docs::SimulatedLog truth = docs::write_apartment_log(log_path);
  const std::filesystem::path tum_path = dir / "tour.tum", txt_path = dir / "tour.txt";
  // [snippet:carmen]
  rangenav::io::CarmenReader reader(log_path);  // plain or gzip; streams, never loads the file
  std::vector<double> stamps;
  std::vector<rangenav::Pose2d> poses;
  while (auto record = reader.next())
    if (auto* laser = std::get_if<rangenav::io::CarmenLaser>(&*record)) {
      // laser->scan: a LaserScan; laser->odom_pose, laser->laser_pose: the record's poses
      stamps.push_back(laser->timestamp);
      poses.push_back(*laser->odom_pose);
    }
  rangenav::io::write_tum(tum_path, stamps, poses);        // t tx ty tz qx qy qz qw
  rangenav::io::write_xytheta(txt_path, stamps, poses);    // t x y theta
  const auto back = rangenav::io::read_xytheta(txt_path);  // std::vector<StampedPose2d>
  // [snippet-end]
  REQUIRE(poses.size() == truth.poses.size());
  REQUIRE(back.size() == poses.size());
  CHECK(back.back().pose.x == Approx(poses.back().x).margin(1e-6));
  CHECK(std::filesystem::file_size(tum_path) > 0);
}

TEST_CASE("io: KITTI poses and transform matrices", "[docs]") {
  const docs::ScratchDir dir("docs_io_matrices");
  std::ofstream(dir / "T_base_lidar.txt") << "0 -1 0 0.20\n1 0 0 0.05\n0 0 1 0.90\n0 0 0 1\n";
  // [snippet:matrices]
  const rangenav::Transform3d base_lidar =
      rangenav::io::read_transform_matrix(dir / "T_base_lidar.txt");  // 3 or 4 rows of 4 numbers
  const std::vector<rangenav::Transform3d> written{base_lidar, base_lidar.inverse()};
  rangenav::io::write_kitti(dir / "poses.txt", written);  // r11 r12 r13 tx ... r33 tz per line
  const std::vector<rangenav::Transform3d> poses = rangenav::io::read_kitti(dir / "poses.txt");
  // [snippet-end]
  CHECK(base_lidar.translation().isApprox(Eigen::Vector3d(0.20, 0.05, 0.90)));
  CHECK((base_lidar * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d(0.20, 1.05, 0.90)));
  REQUIRE(poses.size() == 2);
  CHECK((poses[0] * poses[1]).matrix().isIdentity(1e-8));
}

TEST_CASE("io: PLY, PCD and SVG", "[docs]") {
  const docs::ScratchDir dir("docs_io_files");
  rangenav::Cloud3d cloud;
  for (int i = 0; i < 100; ++i)
    cloud.points.emplace_back(0.01 * i, std::sin(0.1 * i), 0.5);
  cloud.width = cloud.points.size();
  const std::filesystem::path ply = dir / "cloud.ply", pcd = dir / "cloud.pcd",
                              svg_path = dir / "map.svg";
  // [snippet:clouds-io]
  rangenav::io::write_ply(ply, cloud);  // binary little endian; PlyFormat::ascii on request
  rangenav::io::write_pcd(pcd, cloud, rangenav::io::PcdFormat::binary_compressed);
  const rangenav::Cloud3d from_ply = rangenav::io::read_ply<double>(ply);
  const rangenav::Cloud3f from_pcd = rangenav::io::read_pcd<float>(pcd);  // any PCD, as floats
  // [snippet-end]
  CHECK(from_ply.points == cloud.points);
  CHECK(from_pcd.size() == cloud.size());

  const std::vector<rangenav::Pose2d> poses{{0, 0, 0}, {1, 0, 0.3}, {2, 0.5, 0.6}};
  // [snippet:svg]
  rangenav::io::SvgDrawing svg;  // world coordinates in metres, y up; fits itself to the content
  svg.layer("map").points(cloud, {.stroke = "#444", .point_radius_px = 1});  // any 2D/3D cloud
  svg.layer("trajectory").path(poses, {.stroke = "crimson", .stroke_width_px = 2});
  svg.layer("robot").pose(poses.back(), 0.5, {.stroke = "navy", .fill = "navy"});
  svg.circle({2.0, 1.0}, 0.3, {.fill = "orange"});  // also polyline, polygon, segment, text
  svg.save(svg_path);  // each layer an <g id="..."> group; io_error if it cannot be written
  // [snippet-end]
  CHECK(std::filesystem::file_size(svg_path) > 0);
}
