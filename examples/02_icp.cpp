// Tutorial 02: registering two clouds with one call, rangenav::align().
//
//   02_icp
//
// Registration finds the rigid motion that lays one cloud (the source) onto another (the
// target). align() runs the whole pipeline (voxel filter, kd-tree, normals or covariances, ICP)
// and says why it stopped, how well the clouds fit and how well the scene constrains the answer.
// The lesson: 1. one call on two laser scans; 2. the three residuals (point-to-point,
// point-to-plane, GICP) on a 3D scene; 3. how sure a match is, and a prior for a corridor;
// 4. outliers and a robust kernel; 5. threads; 6. real lidar data when ../shared/data has it.

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <random>
#include <vector>

#include "rangenav/io/ply.hpp"
#include "rangenav/io/trajectory.hpp"
#include "rangenav/registration/align.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

using namespace rangenav;

namespace {

/// Translation error (m) and rotation error (deg) of an estimate against the truth.
template <int D>
std::pair<double, double> pose_error(const Transform<D, double>& estimate,
                                     const Transform<D, double>& truth) {
  const Transform<D, double> e = estimate.inverse(Eigen::Isometry) * truth;
  return {e.translation().norm(), std::abs(rotation_angle(e)) * 180 / std::numbers::pi};
}

/// Points on the faces of a 6 x 4 x 3 m room with a table (what a depth camera would see).
std::vector<Eigen::Vector3d> room(std::mt19937& rng, double noise) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> n(0.0, noise);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 12000; ++i) {
    Eigen::Vector3d p(6 * u(rng) - 3, 4 * u(rng) - 2, 3 * u(rng));
    const int face = i % 6;
    if (face < 2)
      p.x() = face == 0 ? -3 : 3;
    else if (face < 4)
      p.y() = face == 2 ? -2 : 2;
    else
      p.z() = face == 4 ? 0 : (p.x() > 0 && p.y() > 0 ? 0.8 : 3);  // a table in one corner
    pts.push_back(p + Eigen::Vector3d(n(rng), n(rng), n(rng)));
  }
  return pts;
}

}  // namespace

int main() {
  std::mt19937 rng(42);

  // ---- 1. One call: two laser scans ----------------------------------------------------------
  // The simulated robot scans the apartment twice, 0.4 m and 12 degrees apart. align(target,
  // source, guess, settings) returns the transform that maps source points into the target
  // frame: here the robot's motion. The guess is odometry, 10 cm and 3 degrees off.
  const auto scene = sim::apartment();
  const sim::LaserScanner2D scanner;  // 270 deg, 0.5 deg steps, 1 cm noise
  const Pose2d first = scene.start;
  const Pose2d second = compose(first, {0.4, 0.1, 12 * std::numbers::pi / 180});
  const auto target2 = scanner.scan(scene.world, first, rng).valid_points();
  const auto source2 = scanner.scan(scene.world, second, rng).valid_points();
  const Transform2d motion2 = relative(first, second).to_isometry();
  const Transform2d odometry = motion2 * make_transform2(0.08, -0.06, 0.05);
  AlignSettings<double> settings;  // GICP, 1 m correspondence distance, one thread
  settings.max_correspondence_distance = 0.5;
  const auto scan = align(target2, source2, odometry, settings);
  const auto [scan_m, scan_deg] = pose_error<2>(scan.transform, motion2);
  std::printf(
      "1. two scans: %s after %d iterations, fitness %.2f, rmse %.3f m; error %.4f m, "
      "%.3f deg\n",
      to_string(scan.reason).data(), scan.iterations, scan.fitness, scan.rmse, scan_m, scan_deg);

  // ---- 2. Which residual: point-to-point, point-to-plane, GICP ------------------------------
  // Two independent noisy samples of a room, 0.25 m and 8.6 degrees apart. Point-to-point pulls
  // each source point to a target sample; point-to-plane lets it slide along the target's
  // surface; GICP (plane-to-plane) uses the surfaces of both clouds.
  const auto target3 = room(rng, 0.01);
  Transform3d motion3 = Transform3d::Identity();
  motion3.linear() = Eigen::AngleAxisd(0.15, Eigen::Vector3d(0.1, 0.2, 1).normalized()).matrix();
  motion3.translation() = Eigen::Vector3d(0.2, -0.1, 0.05);
  std::vector<Eigen::Vector3d> source3;
  for (const auto& p : room(rng, 0.01))
    source3.push_back(motion3.inverse(Eigen::Isometry) * p);
  double gicp_room_m = 0;
  for (const auto method : {RegistrationMethod::point_to_point, RegistrationMethod::point_to_plane,
                            RegistrationMethod::gicp}) {
    settings.method = method;
    const auto r = align(target3, source3, Transform3d::Identity(), settings);
    const auto [m, deg] = pose_error<3>(r.transform, motion3);
    std::printf("2. room, %-14s %2d iterations, error %.4f m, %.3f deg\n", to_string(method).data(),
                r.iterations, m, deg);
    if (method == RegistrationMethod::gicp) gicp_room_m = m;
  }

  // ---- 3. How sure is a match, and a prior where the scene says nothing ---------------------
  // result.information is the inverse covariance of the estimate (translation, rotation in the
  // source frame: g2o's edge convention), so its inverse gives standard deviations. A corridor
  // constrains nothing along its axis: the information is zero there, and ICP leaves that
  // direction where it started. A prior (odometry and its uncertainty) carries it instead.
  const auto& info = *scan.information;
  const Eigen::Vector3d sigma = info.inverse().diagonal().cwiseSqrt();
  std::printf("3. two scans: sigma x %.4f m, y %.4f m, theta %.4f deg\n", sigma(0), sigma(1),
              sigma(2) * 180 / std::numbers::pi);
  std::vector<Eigen::Vector2d> corridor, corridor_moved;
  std::uniform_real_distribution<double> along(-10, 10);
  const Transform2d step = make_transform2(0.5, 0.05, 0.02);  // the truth: 0.5 m along the axis
  for (int i = 0; i < 2000; ++i) {
    corridor.emplace_back(along(rng), i % 2 == 0 ? -1.0 : 1.0);
    corridor_moved.push_back(step.inverse(Eigen::Isometry) *
                             Eigen::Vector2d(along(rng), i % 2 ? -1.0 : 1.0));
  }
  settings.method = RegistrationMethod::point_to_plane;
  const auto blind = align(corridor, corridor_moved, Transform2d::Identity(), settings);
  // Odometry measured 0.45 m along the axis with 5 cm and 2 degrees of uncertainty.
  PosePrior<2, double> prior;
  prior.mean = make_transform2(0.45, 0.0, 0.0);
  prior.information = Eigen::Vector3d(1 / 0.0025, 1 / 0.0025, 1 / 0.0012).asDiagonal();
  const auto guided = align(corridor, corridor_moved, Transform2d::Identity(), settings, prior);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> weakest(*blind.information);
  std::printf(
      "3. corridor: along the axis the scans moved %.2f m, no prior %.2f m, with the "
      "prior %.2f m; unobserved direction (x, y, theta) = (%.2f, %.2f, %.2f)\n",
      step.translation().x(), blind.transform.translation().x(), guided.transform.translation().x(),
      weakest.eigenvectors()(0, 0), weakest.eigenvectors()(1, 0), weakest.eigenvectors()(2, 0));

  // ---- 4. Outliers and a robust kernel -------------------------------------------------------
  // A third of the scan is a moving object: a copy of part of the scene 0.3 m away. Least
  // squares averages it in; a Cauchy kernel (residuals beyond ~delta lose their weight) does not.
  auto cluttered = source3;
  for (std::size_t i = 0; i < source3.size() / 2; ++i)
    cluttered.push_back(source3[i] + Eigen::Vector3d(0.3, 0.0, 0.0));
  settings.method = RegistrationMethod::gicp;
  const auto plain = align(target3, cluttered, Transform3d::Identity(), settings);
  settings.kernel = RobustKernel<double>::cauchy(0.03);
  const auto robust = align(target3, cluttered, Transform3d::Identity(), settings);
  std::printf("4. 33%% outliers: least squares error %.4f m, Cauchy kernel %.4f m\n",
              pose_error<3>(plain.transform, motion3).first,
              pose_error<3>(robust.transform, motion3).first);

  // ---- 5. Threads ------------------------------------------------------------------------------
  // num_threads runs every stage in parallel (OpenMP); the sums are blocked the same way for any
  // thread count, so the answer is the same to the last bit.
  settings.num_threads = 2;
  const auto parallel = align(target3, cluttered, Transform3d::Identity(), settings);
  const bool same_bits = parallel.transform.matrix() == robust.transform.matrix();
  std::printf("5. two threads give the same bits: %s\n", same_bits ? "yes" : "no");
  settings = {};

  // ---- 6. Real lidar: the KITTI pair of small_gicp ---------------------------------------------
  // 0.25 m voxels, identity guess, 1 m correspondence distance, against its ground truth.
  const std::filesystem::path data(RANGENAV_EXAMPLE_DATA_DIR);
  double kitti_m = -1;
  if (std::filesystem::exists(data / "small_gicp/source.ply")) {
    settings.voxel_size = 0.25;
    const auto r = align(io::read_ply<double>(data / "small_gicp/target.ply"),
                         io::read_ply<double>(data / "small_gicp/source.ply"),
                         Transform3d::Identity(), settings);
    const auto [em, edeg] = pose_error<3>(
        r.transform, io::read_transform_matrix(data / "small_gicp/T_target_source.txt"));
    kitti_m = em;
    std::printf("6. KITTI pair, GICP: %d iterations, error %.4f m, %.3f deg\n", r.iterations, em,
                edeg);
  } else {
    std::printf("6. (KITTI pair not found under %s: skipped)\n", data.string().c_str());
  }

  std::printf(
      "{\"scan_converged\":%s,\"scan_error_m\":%.5f,\"room_gicp_error_m\":%.5f,"
      "\"corridor_prior_error_m\":%.4f,\"robust_error_m\":%.5f,\"same_bits\":%s,"
      "\"kitti_error_m\":%.4f}\n",
      scan.converged ? "true" : "false", scan_m, gicp_room_m,
      std::abs(guided.transform.translation().x() - prior.mean.translation().x()),
      pose_error<3>(robust.transform, motion3).first, same_bits ? "true" : "false", kitti_m);
  return 0;
}
