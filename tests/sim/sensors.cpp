#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "rangenav/scan/pitching.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

#include "test_support.hpp"

using namespace rangenav;
using namespace rangenav::sim;

namespace {
const double pi = std::numbers::pi;

World square_room(double half = 2.0) {
  World w;
  const std::vector<Point2d> v{{-half, -half}, {half, -half}, {half, half}, {-half, half}};
  w.add_polygon(v, 3.0);
  w.build_index();
  return w;
}

using rangenav::test::mean;
using rangenav::test::stddev;
}  // namespace

TEST_CASE("2D laser: S300 layout and ranges computed by hand", "[sim][sensors]") {
  const World w = square_room();
  LaserScannerParams p;
  p.noise.sigma = 0;
  p.mount = mounting(0.2, 0, 0.3);
  const LaserScanner2D laser(p);
  CHECK(p.geometry.beam_count == 541);
  std::mt19937 rng(1);
  // Robot at (0.5, 0) facing +y: the scanner sits at (0.5, 0.2).
  const LaserScan<double> scan = laser.scan(w, {0.5, 0.0, pi / 2}, rng, 3.5);
  REQUIRE(scan.size() == 541);
  CHECK(scan.timestamp() == 3.5);
  CHECK(scan.range(270) == Approx(1.8));                           // straight ahead (+y)
  CHECK(scan.range(450) == Approx(2.5));                           // 90 deg left (-x)
  CHECK(scan.range(90) == Approx(1.5));                            // 90 deg right (+x)
  CHECK(scan.range(360) == Approx(std::min(2.5, 1.8) * sqrt(2)));  // 45 deg left: corner at 1.8
  // A mount tilted 30 deg down at 0.5 m sees the floor 1 m ahead.
  p.mount = mounting(0, 0, 0.5, 0, pi / 6);
  const LaserScanner2D tilted(p);
  const auto hits = tilted.cast(w, {0, 0, 0});
  CHECK(hits[270].kind == SurfaceKind::floor);
  CHECK(hits[270].range == Approx(1.0));
  // Out of range: max-range readings, which the scan flags invalid.
  p.mount = mounting(0, 0, 0.3);
  p.geometry.range_max = 1.0;
  const LaserScan<double> short_scan = LaserScanner2D(p).scan(w, {0, 0, 0}, rng);
  CHECK(short_scan.range(270) == 1.0);
  CHECK_FALSE(short_scan.is_valid(270));
}

TEST_CASE("2D laser: noise, dropouts and determinism", "[sim][sensors]") {
  const World w = square_room();
  LaserScannerParams p;
  p.noise.sigma = 0.02;
  p.noise.dropout_probability = 0.1;
  const LaserScanner2D laser(p);
  std::mt19937 rng(42);
  p.noise = {};
  p.noise.sigma = 0;
  const auto truth = laser.cast(w, {0.3, -0.2, 0.4});
  std::vector<double> errors;
  std::size_t dropouts = 0, total = 0;
  for (int k = 0; k < 40; ++k) {
    const LaserScan<double> s = laser.scan(w, {0.3, -0.2, 0.4}, rng);
    for (std::size_t i = 0; i < s.size(); ++i) {
      ++total;
      if (s.range(i) == p.geometry.range_max)
        ++dropouts;
      else
        errors.push_back(s.range(i) - truth[i].range);
    }
  }
  CHECK(mean(errors) == Approx(0.0).margin(0.001));
  CHECK(stddev(errors) == Approx(0.02).epsilon(0.03));
  CHECK(static_cast<double>(dropouts) / static_cast<double>(total) == Approx(0.1).epsilon(0.05));
  std::mt19937 a(5), b(5), c(6);
  const auto sa = laser.scan(w, {0, 0, 0}, a), sb = laser.scan(w, {0, 0, 0}, b),
             sc = laser.scan(w, {0, 0, 0}, c);
  CHECK(sa.ranges() == sb.ranges());
  CHECK(sa.ranges() != sc.ranges());
  LaserScannerParams bad;
  bad.noise.dropout_probability = 1.5;
  CHECK_THROWS_WITH(LaserScanner2D(bad),
                    "rangenav: LaserScanner2D: argument 'noise.dropout_probability' = 1.5 must be "
                    "in [0, 1]");
}

TEST_CASE("pitching scanner: nodding motion and Eq. (3) geometry", "[sim][sensors]") {
  PitchingScannerParams p;
  p.noise.sigma = 0;
  const PitchingScanner scanner(p);
  CHECK(p.geometry.beam_count == 181);
  CHECK(scanner.pitch_at(0) == Approx(p.pitch_min));
  CHECK(scanner.pitch_at(scanner.nod_period() / 2) == Approx(p.pitch_max));
  CHECK(scanner.pitch_at(scanner.nod_period()) == Approx(p.pitch_min).margin(1e-12));
  CHECK(scanner.pitch_at(scanner.nod_period() / 4) == Approx((p.pitch_min + p.pitch_max) / 2));
  // One degree per 2D scan by default.
  CHECK(scanner.pitch_at(scanner.scan_time(7)) - scanner.pitch_at(scanner.scan_time(6)) ==
        Approx(deg_to_rad(1.0)));
  CHECK(scanner.scan_time(3) == Approx(3 * 0.01332));
  const World w = square_room();
  std::mt19937 rng(3);
  // Every reading, turned into 3D by Eq. (3), lies on a wall (|x| or |y| = 2) or the floor.
  std::size_t floor_points = 0, n = 0;
  for (std::size_t k = 0; k < 60; ++k) {
    const double t = scanner.scan_time(k);
    const PitchedScan<double> s = scanner.scan(w, {0, 0, 0}, t, rng);
    CHECK(s.pitch == Approx(scanner.pitch_at(t)));
    CHECK(s.scan.timestamp() == t);
    for (const Point3d& q : pitched_points(s.scan, s.pitch, p.sensor_offset)) {
      ++n;
      const bool on_wall =
          std::abs(std::abs(q.x()) - 2) < 1e-9 || std::abs(std::abs(q.y()) - 2) < 1e-9;
      const bool on_floor = std::abs(q.z()) < 1e-9;
      CHECK((on_wall || on_floor));
      floor_points += on_floor;
    }
  }
  CHECK(n > 60 * 170);
  CHECK(floor_points > 100);
  // Straight ahead at pitch p from 0.55 m: the floor at 0.55 / tan(p) + 0.15 when that is
  // before the wall at x = 2.
  const auto hits = scanner.cast(w, {0, 0, 0}, deg_to_rad(30.0));
  CHECK(hits[90].kind == SurfaceKind::floor);
  CHECK(hits[90].range == Approx(0.55 / std::sin(deg_to_rad(30.0))));
  // Deterministic for a seed.
  const PitchingScanner noisy;
  std::mt19937 a(21), b(21);
  CHECK(noisy.scan(w, {0.1, 0.2, 0.3}, 0.5, a).scan.ranges() ==
        noisy.scan(w, {0.1, 0.2, 0.3}, 0.5, b).scan.ranges());
  PitchingScannerParams bad;
  bad.pitch_max = bad.pitch_min;
  CHECK_THROWS_AS(PitchingScanner(bad), invalid_argument);
}

TEST_CASE("apartment: the table top is seen by the pitching scanner, missed in 2D",
          "[sim][sensors]") {
  const Scene s = apartment();
  const Pose2d robot{3.0, 3.3, -pi / 2};  // looking at the couch table (y in [1.5, 2.1])
  const SceneObject& table = s.object("couch_table");
  const auto in_table = [&](const Point3d& q) {
    return q.x() > table.min.x() && q.x() < table.max.x() && q.y() > table.min.y() &&
           q.y() < table.max.y();
  };
  // 2D laser at 0.30 m: straight ahead passes under the top and between the legs to the couch.
  LaserScannerParams lp;
  lp.noise.sigma = 0;
  const LaserScanner2D laser(lp);
  std::mt19937 rng(11);
  const LaserScan<double> scan = laser.scan(s.world, robot, rng);
  CHECK(scan.range(270) == Approx(3.3 - 0.95));
  for (const auto& q2 : scan.valid_points()) {
    const Point2d q = robot.transform_point(q2);
    if (!in_table({q.x(), q.y(), 0})) continue;
    // The only 2D readings inside the table's footprint are on its thin legs.
    double nearest_leg = 1e9;
    for (const auto& part : table.parts)
      if (part.kind == SurfaceKind::cylinder)
        nearest_leg = std::min(nearest_leg, (q - s.world.cylinders()[part.index].center).norm());
    CHECK(nearest_leg == Approx(0.02).margin(1e-6));
  }
  // Pitching scanner over one nod: points on the top at exactly 0.44 m, nothing above it.
  PitchingScannerParams pp;
  pp.noise.sigma = 0;
  const PitchingScanner pitching(pp);
  const Transform3d to_world = robot_transform(robot);
  std::size_t on_top = 0;
  for (std::size_t k = 0; pitching.scan_time(k) < pitching.nod_period(); ++k) {
    const PitchedScan<double> ps = pitching.scan(s.world, robot, pitching.scan_time(k), rng);
    for (const Point3d& q : pitched_points(ps.scan, ps.pitch, pp.sensor_offset)) {
      const Point3d g = to_world * q;
      if (!in_table(g)) continue;
      CHECK(g.z() < 0.44 + 1e-9);
      on_top += std::abs(g.z() - 0.44) < 1e-9;
    }
  }
  CHECK(on_top > 50);
}

TEST_CASE("apartment: the descending stair gives readings below the floor", "[sim][sensors]") {
  const Scene s = apartment();
  const Pose2d robot{8.8, 6.7, pi / 2};  // the tour's end, facing the stair
  PitchingScannerParams pp;
  pp.noise.sigma = 0;
  const PitchingScanner pitching(pp);
  std::mt19937 rng(2);
  const Transform3d to_world = robot_transform(robot);
  std::size_t below = 0;
  for (std::size_t k = 0; pitching.scan_time(k) < pitching.nod_period(); ++k) {
    const PitchedScan<double> ps = pitching.scan(s.world, robot, pitching.scan_time(k), rng);
    for (const Point3d& q : pitched_points(ps.scan, ps.pitch, pp.sensor_offset)) {
      const Point3d g = to_world * q;
      if (g.z() > -1e-9) continue;
      ++below;
      // Below the floor only on the stair: on a tread (z = -0.18 k), a riser (y = 7.2 + 0.28 k)
      // or the stairwell's sides (x = 8.2 or 9.4), or the far wall beyond the last step.
      CHECK(g.x() > 8.2 - 1e-9);
      CHECK(g.x() < 9.4 + 1e-9);
      CHECK(g.y() > 7.2 - 1e-9);
      const double k_tread = -g.z() / 0.18, k_riser = (g.y() - 7.2) / 0.28;
      const bool tread = std::abs(k_tread - std::round(k_tread)) < 1e-6;
      const bool riser = std::abs(k_riser - std::round(k_riser)) < 1e-6;
      const bool side = std::abs(g.x() - 8.2) < 1e-9 || std::abs(g.x() - 9.4) < 1e-9 ||
                        std::abs(g.y() - 10.0) < 1e-9;
      CHECK((tread || riser || side));
      CHECK(g.z() > -6 * 0.18 - 1e-9);
    }
  }
  CHECK(below > 100);
  // The 2D laser looks over the stair to the far wall.
  LaserScannerParams lp;
  lp.noise.sigma = 0;
  const auto hits = LaserScanner2D(lp).cast(s.world, robot);
  CHECK(hits[270].kind == SurfaceKind::wall);
  CHECK(hits[270].range == Approx(10 - 6.7));
}

TEST_CASE("ToF camera: jump edges exactly at the depth discontinuity", "[sim][sensors]") {
  World w;
  w.add_wall({4, -10}, {4, 10}, 3.0);
  TofCameraParams p;
  p.mount = mounting(0, 0, 1.0);
  p.noise_sigma_0 = p.noise_sigma_2 = 0;
  const auto& k = p.intrinsics;
  // Box front face at x = 2 whose edge at y = y_e projects to column u_e = 60.25: pixel 60
  // (spanning u in [59.5, 60.5]) straddles it; the box covers the columns right of it.
  const double u_e = 60.25, y_e = 2 * (k.cx - u_e) / k.fx;
  w.add_box({{2.25, (y_e - 5) / 2}, {0.5, y_e + 5}, 0, 0, 3});
  w.build_index();
  const TofCamera cam(p);
  std::mt19937 rng(9);
  const DepthImage<double> img = cam.capture(w, {0, 0, 0}, rng);
  REQUIRE(img.width() == 176);
  REQUIRE(img.height() == 144);
  CHECK(img.kind == DepthKind::radial);
  // Distance to the plane x = X along the unit ray through (u, v): X / ray.x.
  const auto plane_distance = [&](double X, double u, double v) {
    return X * Point3d(1, -(u - k.cx) / k.fx, -(v - k.cy) / k.fy).norm();
  };
  for (std::size_t r : {20u, 72u, 120u}) {
    const double v = static_cast<double>(r);
    for (std::size_t c = 30; c < 90; ++c) {
      const double u = static_cast<double>(c);
      INFO("row " << r << " column " << c);
      if (c < 60) {
        CHECK(img.at(r, c) == Approx(plane_distance(4, u, v)).epsilon(1e-12));
      } else if (c > 60) {
        CHECK(img.at(r, c) == Approx(plane_distance(2, u, v)).epsilon(1e-12));
      } else {
        // Mixed pixel: the power-weighted mean over its 4 x 4 sub-rays, 3 of 4 columns on the
        // wall and 1 on the box.
        double sw = 0, swd = 0;
        for (double dv : {-0.375, -0.125, 0.125, 0.375})
          for (double du : {-0.375, -0.125, 0.125, 0.375}) {
            const double d = plane_distance(u + du < u_e ? 4 : 2, u + du, v + dv);
            sw += 1 / (d * d);
            swd += 1 / d;
          }
        CHECK(img.at(r, c) == Approx(swd / sw).epsilon(1e-12));
        CHECK(img.at(r, c) > plane_distance(2, u, v) + 0.5);
        CHECK(img.at(r, c) < plane_distance(4, u, v) - 0.5);
      }
    }
  }
  // Without jump edges the edge pixel is pure.
  p.jump_edges = false;
  const DepthImage<double> clean = TofCamera(p).capture(w, {0, 0, 0}, rng);
  CHECK(clean.at(72, 60) == Approx(plane_distance(4, 60, 72)));
  // Amplitude falls with the squared distance.
  CHECK(img.amplitude[72 * 176 + 100] * std::pow(img.at(72, 100), 2) == Approx(p.amplitude_at_1m));
  CHECK(img.amplitude[72 * 176 + 40] * std::pow(img.at(72, 40), 2) == Approx(p.amplitude_at_1m));
}

TEST_CASE("ToF camera: noise grows with distance; no return is NaN; pan and tilt",
          "[sim][sensors]") {
  TofCameraParams p;
  p.mount = mounting(0, 0, 1.0);
  p.jump_edges = false;
  const TofCamera cam(p);
  for (double distance : {1.0, 4.0}) {
    World w;
    w.add_wall({distance, -10}, {distance, 10}, 5.0);
    w.build_index();
    std::mt19937 rng(17);
    const DepthImage<double> img = cam.capture(w, {0, 0, 0}, rng);
    const std::vector<double> truth = cam.true_depth(w, {0, 0, 0});
    std::vector<double> z;
    for (std::size_t i = 0; i < truth.size(); ++i)
      if (std::isfinite(truth[i]) && std::abs(truth[i] - distance) < 0.05 * distance)
        z.push_back((img.depth[i] - truth[i]) /
                    (p.noise_sigma_0 + p.noise_sigma_2 * truth[i] * truth[i]));
    REQUIRE(z.size() > 1000);
    CHECK(mean(z) == Approx(0.0).margin(0.05));
    CHECK(stddev(z) == Approx(1.0).epsilon(0.05));
  }
  // Nothing within range: every pixel NaN with zero amplitude.
  World empty_world;
  empty_world.build_index();
  std::mt19937 rng(1);
  TofCameraParams up = p;
  up.tilt = -pi / 2 + 0.4;  // looking up, no ceiling, above the 17 deg half aperture
  const DepthImage<double> sky = TofCamera(up).capture(empty_world, {0, 0, 0}, rng);
  for (std::size_t i = 0; i < sky.depth.size(); ++i) {
    CHECK(std::isnan(sky.depth[i]));
    CHECK(sky.amplitude[i] == 0.0);
  }
  // Tilted down 45 deg at 1 m: the centre ray meets the floor sqrt(2) m away; panned left 90
  // deg it sees the same floor.
  TofCameraParams down = p;
  down.noise_sigma_0 = down.noise_sigma_2 = 0;
  down.tilt = pi / 4;
  TofCamera tilted(down);
  const auto d0 = tilted.true_depth(empty_world, {0, 0, 0});
  CHECK(tilted.camera_to_robot().linear().col(0).isApprox(Point3d(1, 0, -1).normalized()));
  tilted.set_pan_tilt(pi / 2, pi / 4);
  CHECK(tilted.camera_to_robot().linear().col(0).isApprox(Point3d(0, 1, -1).normalized()));
  // Pixel (71.5, 87.5) is between pixels; pixels 71/72 x 87/88 surround the axis.
  CHECK(d0[72 * 176 + 88] == Approx(std::sqrt(2.0)).epsilon(0.02));
  // Determinism.
  World wall;
  wall.add_wall({2, -5}, {2, 5});
  wall.build_index();
  std::mt19937 a(4), b(4);
  CHECK(cam.capture(wall, {0, 0, 0}, a).depth == cam.capture(wall, {0, 0, 0}, b).depth);
}
