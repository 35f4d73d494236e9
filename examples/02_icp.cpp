// Tutorial 02: aligning scans with ICP (paper 000 §3.1, paper 002 §6.3 and §7.3).
//
//   02_icp
//
// 2D: the simulated robot takes two laser scans in the apartment, 0.4 m and 12° apart; ICP with
//     the paper's rejectors (exponentially decaying distance threshold + unique model points)
//     corrects a rough odometry guess of the motion.
// 3D: the same in 6-DOF on a synthetic room cloud, and, when ../shared/data holds it, on the KITTI
//     pair of small_gicp against its ground truth.
// Every IcpResult says why ICP stopped, how well it fits, and how well the scene constrains it.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <vector>

#include "rangenav/geometry/voxel_grid.hpp"
#include "rangenav/io/ply.hpp"
#include "rangenav/registration/icp.hpp"
#include "rangenav/search/kd_tree.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

namespace {

template <int D>
void print(const char* title, const rangenav::IcpResult<D, double>& r,
           const rangenav::Transform<D, double>& truth) {
  const rangenav::Transform<D, double> e = r.transform.inverse(Eigen::Isometry) * truth;
  std::printf(
      "%s\n  reason %s after %d iterations, %zu of %zu points matched (fitness %.3f), "
      "%zu pairs kept, rmse %.4f m\n",
      title, rangenav::to_string(r.reason).data(), r.iterations, r.matched_count, r.data_count,
      r.fitness, r.inlier_count, r.rmse);
  if (r.smallest_eigenvalue)
    std::printf("  smallest eigenvalue of the normal equations %.3f (condition %.1f)\n",
                *r.smallest_eigenvalue, *r.condition_number);
  std::printf("  error against the truth: %.2e m, %.2e deg\n", e.translation().norm(),
              std::abs(rangenav::rotation_angle(e)) * 180 / std::numbers::pi);
}

}  // namespace

int main() {
  // ---- 2D: two simulated scans -------------------------------------------------------------
  const auto scene = rangenav::sim::apartment();
  const rangenav::sim::LaserScanner2D scanner;  // SICK S300: 270°, 0.5°, 1 cm noise
  std::mt19937 rng(42);
  const rangenav::Pose2d first = scene.start;
  const rangenav::Pose2d second = rangenav::compose(first, {0.4, 0.1, 12 * std::numbers::pi / 180});
  const auto model_scan = scanner.scan(scene.world, first, rng);
  const auto data_scan = scanner.scan(scene.world, second, rng);

  // The model is indexed once (a nanoflann kd-tree over the scan's valid points); the data
  // scan is any PointCloud. The result maps data points into the model frame: the motion.
  const rangenav::KdTree<2, double> model(model_scan);
  rangenav::PaperIcp<2> icp;  // policies are public typed members:
  icp.rejector<rangenav::DecayingDistanceRejector<double>>().final_distance = 0.05;
  // A rough odometry guess (10 cm and 3 degrees off) as the initial transform.
  const rangenav::Pose2d odometry = rangenav::compose(rangenav::relative(first, second),
                                                      {0.08, -0.06, 3 * std::numbers::pi / 180});
  const auto r2 = icp.align(model, data_scan, odometry.to_isometry());
  print("2D scan to scan (apartment, 0.41 m / 12 deg apart, odometry guess 0.1 m / 3 deg off):", r2,
        rangenav::relative(first, second).to_isometry());

  // ---- 3D: a synthetic room ------------------------------------------------------------------
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3d> room;
  for (int i = 0; i < 20000; ++i) {
    Eigen::Vector3d p(6 * u(rng) - 3, 4 * u(rng) - 2, 3 * u(rng));
    switch (i % 6) {  // the six faces of a 6 x 4 x 3 m room
      case 0:
        p.x() = -3;
        break;
      case 1:
        p.x() = 3;
        break;
      case 2:
        p.y() = -2;
        break;
      case 3:
        p.y() = 2;
        break;
      case 4:
        p.z() = 0;
        break;
      default:
        p.z() = (p.x() > 0 && p.y() > 0) ? 0.8 : 3;
        break;  // a table top in one corner
    }
    room.push_back(p);
  }
  rangenav::Transform3d motion = rangenav::Transform3d::Identity();
  motion.linear() = Eigen::AngleAxisd(0.15, Eigen::Vector3d(0.1, 0.2, 1).normalized()).matrix();
  motion.translation() = Eigen::Vector3d(0.2, -0.1, 0.05);
  std::vector<Eigen::Vector3d> moved;
  for (const auto& p : room)
    moved.push_back(motion.inverse(Eigen::Isometry) * p);
  rangenav::PaperIcp<3> icp3;
  const auto r3 = icp3.align(rangenav::KdTree<3, double>(room), moved);
  print("3D synthetic room (8.6 deg, 0.23 m):", r3, motion);

  // ---- 3D: real data -------------------------------------------------------------------------
  const std::filesystem::path data(RANGENAV_EXAMPLE_DATA_DIR);
  double kitti_error = -1;
  if (std::filesystem::exists(data / "small_gicp/source.ply")) {
    Eigen::Matrix4d m;
    std::ifstream in(data / "small_gicp/T_target_source.txt");
    for (int i = 0; i < 16; ++i)
      in >> m(i / 4, i % 4);
    const auto source = rangenav::voxel_downsample(
        rangenav::io::read_ply<double>(data / "small_gicp/source.ply"), 0.25);
    const rangenav::KdTree<3, double> target(rangenav::voxel_downsample(
        rangenav::io::read_ply<double>(data / "small_gicp/target.ply"), 0.25));
    rangenav::Icp<3, double, rangenav::MaxDistanceRejector<double>> kitti_icp;  // 1.0 m
    const auto rk = kitti_icp.align(target, source);
    print("3D KITTI pair (small_gicp), 0.25 m voxels, identity guess, 1.0 m:", rk,
          rangenav::Transform3d(m));
    kitti_error =
        (rk.transform.inverse(Eigen::Isometry) * rangenav::Transform3d(m)).translation().norm();
  } else {
    std::printf("(KITTI pair not found under %s: skipped)\n", data.string().c_str());
  }

  std::printf(
      "{\"icp2d_converged\":%s,\"icp2d_error_m\":%.6f,\"icp3d_converged\":%s,"
      "\"icp3d_error_m\":%.6f,\"kitti_error_m\":%.4f}\n",
      r2.converged ? "true" : "false",
      (r2.transform.inverse(Eigen::Isometry) * rangenav::relative(first, second).to_isometry())
          .translation()
          .norm(),
      r3.converged ? "true" : "false",
      (r3.transform.inverse(Eigen::Isometry) * motion).translation().norm(), kitti_error);
  return 0;
}
