#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <numbers>

#include "rangenav/core/angles.hpp"
#include "rangenav/scan/depth_image.hpp"
#include "rangenav/scan/pitching.hpp"

using namespace rangenav;

TEST_CASE("pitched points follow Eq. (3) of paper 002", "[scan][pitching]") {
  const Point3d t_s(0.2, 0.0, 0.5);
  const double pitch = deg_to_rad(30.0);
  // A beam straight ahead at 2 m, pitched down by 30 degrees from 0.5 m height.
  const Point3d p = pitched_point(2.0, 0.0, pitch, t_s);
  CHECK(p.x() == Approx(0.2 + 2 * std::cos(pitch)));
  CHECK(p.y() == Approx(0.0).margin(1e-15));
  CHECK(p.z() == Approx(0.5 - 2 * std::sin(pitch)));  // positive pitch looks down
  // A beam to the side (yaw 90 degrees) is on the rotation axis: unaffected by the pitch.
  const Point3d side = pitched_point(1.0, std::numbers::pi / 2, pitch, t_s);
  CHECK(side.isApprox(Point3d(0.2, 1.0, 0.5), 1e-12));
  // Matrix form agrees.
  const Point3d m = pitch_rotation(pitch) * Point3d(2.0, 0.0, 0.0) + t_s;
  CHECK(m.isApprox(p));
}

TEST_CASE("pitched_points keeps valid beams only, any mounting", "[scan][pitching]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const LaserScand scan(-0.5, 0.5, 0.0, 10.0, {1.0, nan, 3.0});
  const auto pts = pitched_points(scan, 0.2, Point3d(0, 0, 0.4));
  REQUIRE(pts.size() == 2);
  CHECK(pts[1].isApprox(pitched_point(3.0, 0.5, 0.2, Point3d(0, 0, 0.4))));
  // Full mounting transform: a scanner turned 90 degrees to the left.
  Transform3d mount = Transform3d::Identity();
  mount.linear() = Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitZ()).matrix();
  mount.translation() = Point3d(0, 0, 0.4);
  const auto turned = pitched_points(scan, 0.0, mount);
  CHECK(turned[0].isApprox(Point3d(-std::sin(-0.5), std::cos(-0.5), 0.4)));
  CHECK_THROWS_AS(pitched_points(scan, nan, Point3d(0, 0, 0)), invalid_argument);
}

TEST_CASE("depth images convert to organised clouds with invalid pixels kept", "[scan][depth]") {
  DepthImage<double> img;
  img.intrinsics = PinholeIntrinsics<double>::from_fov(3, 3, deg_to_rad(90.0), deg_to_rad(90.0));
  img.kind = DepthKind::z_depth;
  img.depth = {1, 1, 1, 1, 2, std::numeric_limits<double>::quiet_NaN(), 1, 0, 1};
  img.amplitude = {9, 9, 9, 9, 9, 9, 9, 9, 9};
  const Cloud3d cloud = to_organized_cloud(img);
  REQUIRE(cloud.is_organized());
  REQUIRE(cloud.size() == 9);
  CHECK(cloud.width == 3);
  CHECK(cloud.intensities.size() == 9);
  // The centre pixel looks along the optical axis = body x.
  CHECK(cloud.at(1, 1).isApprox(Point3d(2, 0, 0)));
  // Top-left pixel: left (+y) and up (+z) in the body frame; fx = 1.5 / tan(45 deg).
  const double off = 1.0 / 1.5;
  CHECK(cloud.at(0, 0).isApprox(Point3d(1, off, off)));
  CHECK_FALSE(cloud.at(1, 2).allFinite());  // NaN
  CHECK_FALSE(cloud.at(2, 1).allFinite());  // zero
  CHECK(finite_points(cloud).size() == 7);
  // Radial depth: the point lies at the measured distance along the ray.
  img.kind = DepthKind::radial;
  const Cloud3d radial = to_organized_cloud(img, CameraFrame::optical);
  CHECK(radial.at(0, 0).norm() == Approx(1.0));
  CHECK(radial.at(0, 0).x() < 0);  // optical frame: x right, y down
  CHECK(radial.at(0, 0).y() < 0);
}

TEST_CASE("depth images reject mismatched sizes", "[scan][depth]") {
  DepthImage<float> img;
  img.intrinsics =
      PinholeIntrinsics<float>::from_fov(176, 144, deg_to_rad(43.0f), deg_to_rad(34.0f));
  img.depth.resize(10);
  CHECK_THROWS_WITH(to_organized_cloud(img),
                    "rangenav: to_organized_cloud: argument "
                    "'depth.size()' = 10 must equal width*height = 25344");
  CHECK_THROWS_AS(PinholeIntrinsics<float>::from_fov(0, 10, 1.0f, 1.0f), invalid_argument);
}
