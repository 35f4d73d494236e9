#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "rangenav/egocentric/virtual_map.hpp"

using namespace rangenav;

namespace {
constexpr double pi = std::numbers::pi;

std::vector<Point3d> one(double x, double y, double z = 0.3) {
  return {Point3d(x, y, z)};
}

// The non-dummy points of a map as world points, given the robot's world pose.
std::vector<Point2d> world_points(const ObstacleMap<double>& map, const Pose2d& pose) {
  std::vector<Point2d> out;
  for (const auto& p : map.valid_points())
    out.push_back(pose.transform_point(p));
  return out;
}
}  // namespace

TEST_CASE("fast_atan2 agrees with std::atan2 to 1e-10 in every octant",
          "[egocentric][virtual_map]") {
  double worst = 0;
  for (int i = 0; i < 20000; ++i) {
    const double a = -pi + 2 * pi * (i + 0.5) / 20000;
    for (const double r : {1e-3, 1.0, 37.0}) {
      const double y = r * std::sin(a), x = r * std::cos(a);
      worst = std::max(worst, std::abs(detail::fast_atan2(y, x) - std::atan2(y, x)));
    }
  }
  CHECK(worst < 1e-10);
  CHECK(detail::fast_atan2(0.0, -1.0) == Approx(pi));
  CHECK(detail::fast_atan2(-1.0, 0.0) == Approx(-pi / 2));
  CHECK(detail::fast_atan2(1.0, 1.0) == Approx(pi / 4));
  CHECK(detail::fast_atan2(0.0, 0.0) == 0.0);
  CHECK(std::abs(detail::fast_atan2(0.3f, -2.0f) - std::atan2(0.3f, -2.0f)) < 1e-6f);
}

TEST_CASE("the shifted bearing of q + t agrees with atan2 for small, medium and large shifts",
          "[egocentric][virtual_map]") {
  // |t| / |q| from 1e-4 (a robot's motion between scans) over 0.05 (a scanner mounted off the
  // rotation centre) to 2 (past the series' range), in every direction of q and t, across the
  // wrap at pi.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-pi, pi);
  double worst = 0, worst_small = 0, worst_series = 0;
  for (const double ratio : {1e-4, 3e-3, 0.0099, 0.05, 0.099, 0.5, 2.0})
    for (int i = 0; i < 2000; ++i) {
      const double qa = angle(rng), ta = angle(rng), q_range = 0.5 + 0.001 * i;
      const double qx = q_range * std::cos(qa), qy = q_range * std::sin(qa);
      const double tx = ratio * q_range * std::cos(ta), ty = ratio * q_range * std::sin(ta);
      const double truth = std::atan2(qy + ty, qx + tx);
      const auto error = [&](double b) { return std::abs(std::remainder(b - truth, 2 * pi)); };
      worst = std::max(worst, error(detail::shifted_bearing(qx, qy, q_range, qa, tx, ty)));
      worst_small = std::max(
          worst_small, error(detail::shifted_bearing_small_shift(qx, qy, q_range, qa, tx, ty)));
      if (ratio <= 0.05)  // |r| < 0.06: the series of either function, not fast_atan2
        worst_series =
            std::max({worst_series, error(detail::shifted_bearing(qx, qy, q_range, qa, tx, ty)),
                      error(detail::shifted_bearing_small_shift(qx, qy, q_range, qa, tx, ty))});
      const double b = detail::shifted_bearing_small_shift(qx, qy, q_range, qa, tx, ty);
      REQUIRE(b > -pi);
      REQUIRE(b <= pi);
    }
  CHECK(worst < 1e-10);  // the series (1e-12) or fast_atan2 (1e-10)
  CHECK(worst_small < 1e-10);
  CHECK(worst_series < 1e-13);
}

TEST_CASE("virtual map layout: N = aperture / resolution bins, dummies everywhere",
          "[egocentric][virtual_map]") {
  ObstacleMap<double> obstacle;  // 360 deg at 0.5 deg
  CHECK(obstacle.size() == 720);
  CHECK(obstacle.valid_count() == 0);
  CHECK(traits::size(obstacle) == 0);
  static_assert(PointCloudOf<ObstacleMap<double>, 2>);
  static_assert(PointCloudOf<StructureMap<float>, 2>);
  for (const auto& b : obstacle.bins()) {
    REQUIRE(b.dummy);
    REQUIRE(b.range == obstacle.max_range());
  }
  StructureMap<double> structure(VirtualMapParams<double>{deg_to_rad(90.0), deg_to_rad(1.0)});
  CHECK(structure.size() == 90);
  CHECK(structure.bin(0).range == 0.0);
  CHECK(structure.bin_bearing(0) == Approx(deg_to_rad(-44.5)));
  CHECK(structure.bin_index(deg_to_rad(44.9)) == 89);
  CHECK(structure.bin_index(deg_to_rad(45.1)) == structure.size());  // outside the aperture
  // Both dummy kinds are invalid readings of the converted scan.
  CHECK(obstacle.to_laser_scan().valid_count() == 0);
  CHECK(structure.to_laser_scan().valid_count() == 0);
  CHECK(obstacle.bin_index(pi) == 0);  // -pi and pi share the first bin of a full circle
  CHECK(obstacle.bin_index(-pi + 1e-9) == 0);
  CHECK(obstacle.bin_index(pi - 1e-9) == 719);
}

TEST_CASE("virtual map parameters are checked with exact messages", "[egocentric][virtual_map]") {
  using P = VirtualMapParams<double>;
  CHECK_THROWS_WITH(ObstacleMap<double>(P{0.0}),
                    "rangenav: VirtualMap: argument 'aperture' = 0 must be finite and > 0");
  CHECK_THROWS_WITH(ObstacleMap<double>(P{7.0}),
                    "rangenav: VirtualMap: argument 'aperture' = 7 must be <= 2 pi");
  CHECK_THROWS_WITH(ObstacleMap<double>(P{1.0, std::numeric_limits<double>::quiet_NaN()}),
                    "rangenav: VirtualMap: argument 'resolution' = nan must be finite and > 0");
  CHECK_THROWS_WITH(
      ObstacleMap<double>(P{1.0, 2.0}),
      "rangenav: VirtualMap: argument 'resolution' = 2 must not exceed the aperture 1");
  CHECK_THROWS_WITH(ObstacleMap<double>(P{1.0, 0.1, -3.0}),
                    "rangenav: VirtualMap: argument 'max_range' = -3 must be finite and > 0");
}

TEST_CASE("obstacle policy: nearest reading in the virtual corridor wins",
          "[egocentric][virtual_map]") {
  ObstacleMap<double> map(VirtualMapParams<double>{}, ObstacleMapPolicy{0.0, 1.0});
  CHECK(map.insert(one(3.0, 0.0)) == 1);
  CHECK(map.insert(one(4.0, 0.0)) == 0);  // farther: kept the nearer
  CHECK(map.insert(one(2.0, 0.001)) == 1);
  CHECK(map.insert(one(1.0, 0.0, 1.5)) == 0);   // above the corridor
  CHECK(map.insert(one(1.0, 0.0, -0.1)) == 0);  // below it
  CHECK(map.insert(one(31.0, 0.0)) == 0);       // beyond max range
  const double nan = std::numeric_limits<double>::quiet_NaN();
  CHECK(map.insert(std::vector<Point3d>{Point3d(nan, 0, 0.3), Point3d(0, 0, 0.3)}) == 0);
  REQUIRE(map.valid_count() == 1);
  const auto& b = map.bin(map.valid_indices()[0]);
  CHECK(b.x == 2.0);
  CHECK(b.range == Approx(std::hypot(2.0, 0.001)));
  CHECK(b.bearing == Approx(std::atan2(0.001, 2.0)));
  CHECK(b.z == 0.3);
  CHECK(map.valid_indices()[0] == map.bin_index(0.0005));
  CHECK(traits::point(map, 0) == Point2d(2.0, 0.001));
  // The converted scan reads the stored range at the bin's centre bearing.
  const auto scan = map.to_laser_scan();
  REQUIRE(scan.size() == 720);
  REQUIRE(scan.valid_count() == 1);
  CHECK(scan.range(scan.valid_indices()[0]) == Approx(b.range));
  CHECK(std::abs(scan.angle(scan.valid_indices()[0]) - b.bearing) <= map.resolution() / 2);
}

TEST_CASE("structure policy: farthest reading wins, max-range readings ignored",
          "[egocentric][virtual_map]") {
  StructureMap<double> map;
  CHECK(map.insert(one(2.0, 0.0, 0.05)) == 1);  // floor points are fine: replaced later
  CHECK(map.insert(one(5.0, 0.0, 1.8)) == 1);
  CHECK(map.insert(one(3.0, 0.0, 0.5)) == 0);
  CHECK(map.insert(one(30.0, 0.0)) == 0);  // max-range reading
  REQUIRE(map.valid_count() == 1);
  CHECK(map.valid_points()[0].x() == 5.0);
}

TEST_CASE("transformation keeps Cartesian and polar coordinates in step (Eq. 4)",
          "[egocentric][virtual_map]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-6.0, 6.0);
  ObstacleMap<double> map;
  std::vector<Point3d> pts;
  for (int i = 0; i < 300; ++i)
    pts.emplace_back(u(rng), u(rng), 0.5);
  map.insert(pts);
  const std::size_t before = map.valid_count();
  Pose2d pose{1.0, -2.0, 0.3};  // the robot's world pose
  const auto world_before = world_points(map, pose);
  std::uniform_real_distribution<double> step(-0.05, 0.05);
  std::size_t merged = 0;
  for (int k = 0; k < 20; ++k) {
    const Pose2d motion{step(rng), step(rng), 4 * step(rng)};
    const auto st = map.transform(motion);
    CHECK(st.aged_out == 0);
    CHECK(st.moved == map.valid_count());
    merged += st.merged;
    pose = compose(pose, motion);
  }
  // The world positions of the surviving points are unchanged (within rounding) ...
  const auto world_after = world_points(map, pose);
  std::size_t matched = 0;
  for (const auto& w : world_after)
    for (const auto& v : world_before)
      if ((w - v).norm() < 1e-9) {
        ++matched;
        break;
      }
  CHECK(matched == world_after.size());
  CHECK(map.valid_count() + merged == before);  // only bin collisions removed points
  // ... and every bin's polar coordinates describe its Cartesian point, inside that bin.
  for (const std::uint32_t i : map.valid_indices()) {
    const auto& b = map.bin(i);
    REQUIRE(b.range == Approx(std::hypot(b.x, b.y)).epsilon(1e-12));
    REQUIRE(std::abs(b.bearing - std::atan2(b.y, b.x)) < 1e-9);
    REQUIRE(map.bin_index(b.bearing) == i);
    REQUIRE(b.age == 20);
  }
}

TEST_CASE("transformation closed form: drive forward, then turn left",
          "[egocentric][virtual_map]") {
  ObstacleMap<double> map;
  map.insert(one(2.0, 0.0));
  map.transform(Pose2d{0.5, 0.0, 0.0});
  REQUIRE(map.valid_count() == 1);
  CHECK(map.valid_points()[0].isApprox(Point2d(1.5, 0.0)));
  CHECK(map.bin(map.valid_indices()[0]).range == Approx(1.5));
  map.transform(Pose2d{0.0, 0.0, pi / 2});  // pure rotation: the object is now on the right
  REQUIRE(map.valid_count() == 1);
  const auto& b = map.bin(map.valid_indices()[0]);
  CHECK(b.x == Approx(0.0).margin(1e-12));
  CHECK(b.y == Approx(-1.5));
  CHECK(b.bearing == Approx(-pi / 2));
  CHECK(b.range == Approx(1.5));
  CHECK(map.valid_indices()[0] == map.bin_index(-pi / 2 + 1e-6));
}

TEST_CASE("bin collisions after a transformation are resolved by the policy",
          "[egocentric][virtual_map]") {
  // A far point at 3 m and a near point in another bin; the robot moves 0.2 m to its left, after
  // which the near point lies 1 m away along the far point's new bearing: one bin, two points.
  const double a = deg_to_rad(10.25);
  const Point2d far_before(3 * std::cos(a), 3 * std::sin(a));
  const Point2d far_after = far_before - Point2d(0.0, 0.2);
  const double b = std::atan2(far_after.y(), far_after.x());
  const Point2d near_after(std::cos(b), std::sin(b));
  const Point2d near_before = near_after + Point2d(0.0, 0.2);
  const std::vector<Point3d> pts{Point3d(far_before.x(), far_before.y(), 0.3),
                                 Point3d(near_before.x(), near_before.y(), 0.3)};
  ObstacleMap<double> obstacle;
  StructureMap<double> structure;
  obstacle.insert(pts);
  structure.insert(pts);
  REQUIRE(obstacle.valid_count() == 2);
  REQUIRE(structure.valid_count() == 2);
  const auto so = obstacle.transform(Pose2d{0.0, 0.2, 0.0});
  const auto ss = structure.transform(Pose2d{0.0, 0.2, 0.0});
  CHECK(so.merged == 1);
  CHECK(ss.merged == 1);
  REQUIRE(obstacle.valid_count() == 1);
  CHECK(obstacle.valid_points()[0].isApprox(near_after));
  REQUIRE(structure.valid_count() == 1);
  CHECK(structure.valid_points()[0].isApprox(far_after));
}

TEST_CASE("age-out: a point transformed more than max_age times becomes a dummy",
          "[egocentric][virtual_map]") {
  VirtualMapParams<double> params;
  params.max_age = 5;
  ObstacleMap<double> map(params);
  map.insert(one(2.0, 1.0));
  for (int i = 0; i < 5; ++i) {
    const auto st = map.transform(Pose2d{0.001, 0.0, 0.0});
    REQUIRE(st.aged_out == 0);
  }
  REQUIRE(map.valid_count() == 1);
  CHECK(map.bin(map.valid_indices()[0]).age == 5);
  // Standing still neither ages nor moves anything (steps 1 and 2 skipped).
  const auto idle = map.transform(Pose2d{});
  CHECK(idle.moved == 0);
  CHECK(map.bin(map.valid_indices()[0]).age == 5);
  const auto st = map.transform(Pose2d{0.001, 0.0, 0.0});
  CHECK(st.aged_out == 1);
  CHECK(map.valid_count() == 0);
  // The freed bin is a dummy at max range again.
  CHECK(map.bin(map.bin_index(std::atan2(1.0, 2.0 - 0.006))).range == map.max_range());
  // A re-measured point starts at age 0.
  map.update(Pose2d{0.001, 0.0, 0.0}, one(2.0, 1.0));
  REQUIRE(map.valid_count() == 1);
  CHECK(map.bin(map.valid_indices()[0]).age == 0);
}

TEST_CASE("re-observing a surface refreshes its bin: points still seen never age out",
          "[egocentric][virtual_map]") {
  // A wall 3 m ahead, seen by a noisy scanner (sigma 5 mm, the SICK LMS 2xx) at every update while
  // the robot creeps towards it. Keeping the nearer old point over a slightly farther new reading
  // of the same surface would let the noise minimum of each bin survive, age up to max_age and be
  // removed although the wall is still in view (§4.4.2 removes only points not seen again).
  VirtualMapParams<double> params;
  params.max_age = 20;
  ObstacleMap<double> map(params);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.005);
  double travelled = 0.0;
  std::uint32_t oldest = 0;
  for (int k = 0; k < 200; ++k) {
    std::vector<Point3d> readings;
    for (int j = -30; j <= 30; ++j) {
      const double b = map.bin_bearing(map.bin_index(deg_to_rad(0.5 * j)));
      const double d = (3.0 - travelled) / std::cos(b) + noise(rng);
      readings.emplace_back(d * std::cos(b), d * std::sin(b), 0.5);
    }
    map.update(Pose2d{0.001, 0.0, 0.0}, readings);
    travelled += 0.001;
    for (int j = -30; j <= 30; ++j) {
      const auto& b = map.bin(map.bin_index(deg_to_rad(0.5 * j)));
      REQUIRE_FALSE(b.dummy);
      oldest = std::max(oldest, b.age);
    }
  }
  CHECK(oldest <= 3);
  // A re-observation restarts the age but keeps the nearer point: the obstacle never creeps
  // away from the robot, and a farther surface or a nearer obstacle are told apart.
  ObstacleMap<double> obstacle;
  CHECK(obstacle.insert(one(3.0, 0.0)) == 1);
  obstacle.transform(Pose2d{0.001, 0.0, 0.0});
  REQUIRE(obstacle.bin(obstacle.valid_indices()[0]).age == 1);
  CHECK(obstacle.insert(one(3.02, 0.0)) == 0);  // the same surface, 2 cm farther: seen again
  CHECK(obstacle.bin(obstacle.valid_indices()[0]).age == 0);
  CHECK(obstacle.valid_points()[0].x() == Approx(2.999));
  obstacle.transform(Pose2d{0.001, 0.0, 0.0});
  CHECK(obstacle.insert(one(3.05, 0.0)) == 0);  // 5 cm behind it: another surface
  CHECK(obstacle.bin(obstacle.valid_indices()[0]).age == 1);
  CHECK(obstacle.insert(one(2.5, 0.0)) == 1);  // nearer: replaces
  CHECK(obstacle.valid_points()[0].x() == 2.5);
  StructureMap<double> structure;
  CHECK(structure.insert(one(5.0, 0.0)) == 1);
  structure.transform(Pose2d{-0.001, 0.0, 0.0});
  CHECK(structure.insert(one(4.98, 0.0)) == 0);  // the same wall: seen again
  CHECK(structure.bin(structure.valid_indices()[0]).age == 0);
  structure.transform(Pose2d{-0.001, 0.0, 0.0});
  CHECK(structure.insert(one(4.9, 0.0)) == 0);  // 10 cm nearer: an object in front of it
  CHECK(structure.bin(structure.valid_indices()[0]).age == 1);
  CHECK(structure.valid_points()[0].x() == Approx(5.002));
  // With a zero tolerance nothing is refreshed.
  ObstacleMap<double> strict(VirtualMapParams<double>{}, ObstacleMapPolicy{0.0, 1.0, 0.0});
  strict.insert(one(3.0, 0.0));
  strict.transform(Pose2d{0.001, 0.0, 0.0});
  strict.insert(one(3.001, 0.0));
  CHECK(strict.bin(strict.valid_indices()[0]).age == 1);
}

TEST_CASE("age-out spares the sensor's blind zone", "[egocentric][virtual_map]") {
  VirtualMapParams<double> params;
  params.max_age = 5;
  params.blind_range = 0.8;
  ObstacleMap<double> map(params);
  map.insert(one(0.5, 0.3));   // in the blind zone: never re-measured, kept
  map.insert(one(2.0, -1.0));  // seen by the sensor: aged out as in the paper
  // Turning on the spot: many transformations, the near point stays where it is.
  for (int i = 0; i < 40; ++i)
    map.transform(Pose2d{0.0, 0.0, i % 2 == 0 ? 0.01 : -0.01});
  REQUIRE(map.valid_count() == 1);
  const auto& kept = map.bin(map.valid_indices()[0]);
  CHECK(kept.x == Approx(0.5));
  CHECK(kept.y == Approx(0.3));
  CHECK(kept.age == 5);  // saturates at max_age
  // Backing away takes it out of the blind zone: it goes at the next transformation.
  map.transform(Pose2d{-0.3, 0.0, 0.0});
  CHECK(map.valid_count() == 1);  // range 0.86 now, but the range checked is the stored 0.58
  map.transform(Pose2d{-0.01, 0.0, 0.0});
  CHECK(map.valid_count() == 0);
  params.blind_range = -0.1;
  CHECK_THROWS_WITH(ObstacleMap<double>(params),
                    "rangenav: VirtualMap: argument 'blind_range' = -0.10000000000000001 must be "
                    "finite and >= 0");
}

TEST_CASE("restricted aperture drops points that leave it", "[egocentric][virtual_map]") {
  ObstacleMap<double> map(VirtualMapParams<double>{deg_to_rad(60.0), deg_to_rad(1.0)});
  CHECK(map.insert(one(2.0, 0.5)) == 1);
  CHECK(map.insert(one(-2.0, 0.0)) == 0);  // behind: outside the aperture
  const auto st = map.transform(Pose2d{0.0, 0.0, deg_to_rad(-40.0)});  // turn right
  CHECK(st.merged == 1);
  CHECK(map.valid_count() == 0);
  // A full-turn scan from -180 deg at 1 deg, beams between the bin borders: only the 60 beams at
  // -29.5 .. 29.5 deg fall into the aperture, beam 150 + j into bin j, whatever lies before or
  // after them in the scan.
  std::vector<double> ranges(360);
  for (std::size_t i = 0; i < ranges.size(); ++i)
    ranges[i] = 1.0 + 0.01 * static_cast<double>(i);
  const LaserScand full_turn(-pi + deg_to_rad(0.5), deg_to_rad(1.0), 0.05, 30.0, ranges);
  ObstacleMap<double> front(VirtualMapParams<double>{deg_to_rad(60.0), deg_to_rad(1.0)});
  CHECK(front.insert(full_turn, PlanarMount<double>{Pose2d{}, 0.3}) == 60);
  REQUIRE(front.valid_count() == 60);
  for (std::size_t j = 0; j < 60; ++j) {
    CHECK(front.bin(j).range == Approx(ranges[150 + j]).margin(1e-12));
    CHECK(front.bin(j).bearing == Approx(deg_to_rad(-29.5 + static_cast<double>(j))));
  }
}

TEST_CASE("2D scans insert through a planar mount", "[egocentric][virtual_map]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const LaserScand scan(-pi / 2, pi / 4, 0.05, 10.0, {1.0, 2.0, nan, 12.0, 3.0});
  // Centred mount: bearings come from the scan, readings are at the mount's height.
  ObstacleMap<double> centred;
  CHECK(centred.insert(scan, PlanarMount<double>{Pose2d{0, 0, 0.1}, 0.3}) == 3);
  for (const std::uint32_t i : centred.valid_indices()) {
    const auto& b = centred.bin(i);
    CHECK(b.z == 0.3);
    CHECK(std::abs(b.bearing - std::atan2(b.y, b.x)) < 1e-12);
  }
  // Offset mount: same as inserting the transformed points by hand.
  const PlanarMount<double> mount{Pose2d{0.2, -0.1, 0.3}, 0.25};
  ObstacleMap<double> a, b;
  a.insert(scan, mount);
  std::vector<Point3d> by_hand;
  for (const auto& p : scan.valid_points()) {
    const Point2d q = mount.pose.transform_point(p);
    by_hand.emplace_back(q.x(), q.y(), 0.25);
  }
  b.insert(by_hand);
  REQUIRE(a.valid_count() == 3);
  REQUIRE(a.valid_indices() == b.valid_indices());
  for (std::size_t i = 0; i < a.valid_count(); ++i)
    CHECK(a.valid_points()[i].isApprox(b.valid_points()[i]));
  // A scan above the corridor is not admitted into an obstacle map.
  ObstacleMap<double> high;
  CHECK(high.insert(scan, PlanarMount<double>{Pose2d{}, 1.5}) == 0);
}

TEST_CASE("beams on bin borders fill every bin exactly once (half-open bins, wrap at pi)",
          "[egocentric][virtual_map]") {
  // A full turn of 720 beams starting at -pi with increment 2 pi / 720: every beam lies on the
  // lower border of one bin of the 720-bin map, so beam k belongs to bin k.
  const double inc = 2 * pi / 720;
  std::vector<double> ranges(720);
  for (std::size_t k = 0; k < ranges.size(); ++k)
    ranges[k] = 1.0 + 0.001 * static_cast<double>(k);  // tells the beams apart
  const LaserScand scan(-pi, inc, 0.05, 30.0, ranges);
  const auto every_bin_once = [&](const auto& map, std::size_t shift) {
    REQUIRE(map.valid_count() == 720);
    for (std::size_t k = 0; k < 720; ++k)
      REQUIRE(map.bin((k + 720 - shift) % 720).range == Approx(ranges[k]).margin(1e-9));
  };
  ObstacleMap<double> obstacle;
  CHECK(obstacle.insert(scan, PlanarMount<double>{Pose2d{}, 0.3}) == 720);
  every_bin_once(obstacle, 0);
  StructureMap<double> structure;
  CHECK(structure.insert(scan) == 720);
  every_bin_once(structure, 0);
  // The same bearings as 3D points (bearings from the coordinates, not from the scan).
  std::vector<Point3d> points;
  for (std::size_t k = 0; k < 720; ++k) {
    const double a = -pi + inc * static_cast<double>(k);
    points.emplace_back(ranges[k] * std::cos(a), ranges[k] * std::sin(a), 0.3);
  }
  ObstacleMap<double> from_points;
  CHECK(from_points.insert(points) == 720);
  every_bin_once(from_points, 0);
  // Turning on the spot by whole bins moves every point by whole bins: none lost, none doubled.
  for (int turn = 1; turn <= 25; ++turn) {
    const auto st = obstacle.transform(Pose2d{0.0, 0.0, 3 * inc});
    REQUIRE(st.moved == 720);
    REQUIRE(st.merged == 0);
  }
  every_bin_once(obstacle, 75);
  // Turning back by a multiple of the bin width, across the wrap at pi, as well.
  obstacle.transform(Pose2d{0.0, 0.0, -75 * inc});
  every_bin_once(obstacle, 0);
  // A scan starting at 0 crosses pi in the middle.
  const LaserScand from_zero(0.0, inc, 0.05, 30.0, ranges);
  ObstacleMap<double> wrapped;
  CHECK(wrapped.insert(from_zero) == 720);
  every_bin_once(wrapped, 360);
  // Single precision: the same scan in float.
  std::vector<float> ranges_f(ranges.begin(), ranges.end());
  const LaserScanf scan_f(-std::numbers::pi_v<float>, 2 * std::numbers::pi_v<float> / 720, 0.05f,
                          30.0f, ranges_f);
  ObstacleMap<float> obstacle_f;
  CHECK(obstacle_f.insert(scan_f, PlanarMount<float>{Pose2f{}, 0.3f}) == 720);
  // A restricted aperture: 90 deg at 1 deg, beams on the borders from -45 deg; the beam at
  // +45 deg is the upper end of the aperture and stays outside (half-open).
  StructureMap<double> quarter(VirtualMapParams<double>{pi / 2, pi / 180});
  const LaserScand border_scan(-pi / 4, pi / 180, 0.05, 30.0, std::vector<double>(91, 2.0));
  CHECK(quarter.insert(border_scan) == 90);
  CHECK(quarter.valid_count() == 90);
}

TEST_CASE("float maps behave like double maps", "[egocentric][virtual_map]") {
  ObstacleMap<float> map;
  map.insert(std::vector<Point3f>{Point3f(2.0f, 0.5f, 0.3f)});
  map.transform(Pose2f{0.5f, 0.0f, 0.1f});
  REQUIRE(map.valid_count() == 1);
  const Point2f expected = inverse(Pose2f{0.5f, 0.0f, 0.1f}).transform_point(Point2f(2.0f, 0.5f));
  CHECK(map.valid_points()[0].isApprox(expected, 1e-5f));
  CHECK(map.to_laser_scan().valid_count() == 1);
}

namespace {
// A user policy: the newest reading always wins, at any height (a "last seen" map).
struct NewestPolicy {
  template <class S>
  bool admits(S range, S, S max_range) const {
    return range < max_range;
  }
  template <class S>
  bool prefers(S, S) const {
    return true;
  }
  template <class S>
  S dummy_range(S max_range) const {
    return max_range;
  }
};
struct NotAPolicy {
  bool admits(double) const { return true; }
};
}  // namespace

TEST_CASE("users plug in their own policy; the concept rejects incomplete ones",
          "[egocentric][virtual_map]") {
  static_assert(VirtualMapPolicy<NewestPolicy, double>);
  static_assert(!VirtualMapPolicy<NotAPolicy, double>);
  static_assert(!VirtualMapPolicy<int, double>);
  VirtualMap<NewestPolicy, double> map;
  map.insert(one(2.0, 0.0));
  map.insert(one(5.0, 0.0, 3.0));  // farther and higher: still replaces
  REQUIRE(map.valid_count() == 1);
  CHECK(map.valid_points()[0].x() == 5.0);
  // Any representation of the motion's rotation works: 2 pi + 0.1 is a turn by 0.1.
  ObstacleMap<double> a, b;
  a.insert(one(2.0, 1.0));
  b.insert(one(2.0, 1.0));
  a.transform(Pose2d{0.1, 0.0, 2 * pi + 0.1});
  b.transform(Pose2d{0.1, 0.0, 0.1});
  REQUIRE(a.valid_count() == 1);
  CHECK(a.valid_points()[0].isApprox(b.valid_points()[0]));
  CHECK(a.valid_indices() == b.valid_indices());
}
