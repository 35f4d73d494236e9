#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "rangenav/egocentric/tof_obstacles.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/scan/pitching.hpp"
#include "rangenav/scan/tof_filters.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/world.hpp"

using namespace rangenav;

namespace {

// Floor at z = 0 (dropping to -0.3 m beyond stair_x) and one axis-aligned box.
struct Scene {
  double stair_x = 100.0;
  Point3d box_min{1.2, -0.2, 0.0}, box_max{1.5, 0.2, 0.2};

  double cast(const Point3d& o, const Point3d& d) const {
    double best = std::numeric_limits<double>::infinity();
    if (d.z() < 0) {
      const double t0 = -o.z() / d.z();
      best = (o + t0 * d).x() <= stair_x ? t0 : (-0.3 - o.z()) / d.z();
    }
    double tmin = 0, tmax = best;
    for (int k = 0; k < 3; ++k) {
      double t1 = (box_min[k] - o[k]) / d[k], t2 = (box_max[k] - o[k]) / d[k];
      if (t1 > t2) std::swap(t1, t2);
      tmin = std::max(tmin, t1);
      tmax = std::min(tmax, t2);
    }
    if (tmin <= tmax && tmin > 0) best = std::min(best, tmin);
    return best;
  }
};

// An SR4000-like camera (176 x 144, 43 x 34 deg) at 0.8 m, tilted 30 deg down.
Transform3d camera_extrinsics() {
  Transform3d t = Transform3d::Identity();
  t.linear() = pitch_rotation(deg_to_rad(30.0));
  t.translation() = Point3d(0.0, 0.0, 0.8);
  return t;
}

DepthImage<double> render(const Scene& scene, double noise, unsigned seed = 3) {
  DepthImage<double> img;
  img.intrinsics =
      PinholeIntrinsics<double>::from_fov(176, 144, deg_to_rad(43.0), deg_to_rad(34.0));
  img.kind = DepthKind::radial;
  img.depth.resize(176 * 144);
  const Transform3d extr = camera_extrinsics();
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, noise);
  for (std::size_t r = 0; r < 144; ++r)
    for (std::size_t c = 0; c < 176; ++c) {
      const Point3d dir = extr.linear() * img.pixel_point(r, c, 1.0);
      const double t = scene.cast(extr.translation(), dir);
      img.depth[r * 176 + c] = std::isfinite(t) && t < 5.0 ? t + n(rng) : 0.0;
    }
  return img;
}

}  // namespace

TEST_CASE("height-image obstacles (Eq. 15) lie on the box, none on the floor",
          "[egocentric][tof]") {
  HeightImageObstacleDetector<double> detector;
  auto floor_only = render(Scene{100.0, {0, 0, 0}, {0, 0, 0}}, 0.005);
  apply_median_filter(floor_only);
  CHECK(detector.detect(floor_only, camera_extrinsics()) == 0);
  CHECK(detector.virtual_scan().valid_count() == 0);

  auto img = render(Scene{}, 0.005);
  apply_median_filter(img);
  const std::size_t n = detector.detect(img, camera_extrinsics());
  CHECK(n > 100);
  for (const auto& p : detector.obstacle_points()) {
    REQUIRE(p.x() >= 1.15);
    REQUIRE(p.x() <= 1.55);
    REQUIRE(std::abs(p.y()) <= 0.25);
  }
  // The virtual scan: 176 beams over the camera's 43 deg; straight ahead the box front at 1.2 m.
  const auto scan = detector.virtual_scan();
  REQUIRE(scan.size() == 176);
  CHECK(scan.angle_max() - scan.angle_min() == Approx(deg_to_rad(43.0) * 175.0 / 176.0));
  const std::size_t mid = 88;
  REQUIRE(scan.is_valid(mid));
  CHECK(scan.range(mid) == Approx(1.2).margin(0.05));
  CHECK_FALSE(scan.is_valid(5));  // beside the box: max range
  CHECK(scan.range(5) == 5.0);
}

TEST_CASE("ToF: tables above the corridor are ignored, stairs become obstacles",
          "[egocentric][tof]") {
  HeightImageObstacleDetector<double> detector;  // corridor [0, 1] m
  Scene high{100.0, {1.2, -0.2, 1.2}, {1.5, 0.2, 1.25}};
  // The camera looks down: a box above 0.8 m is not even in view, so lower the camera's view to
  // a box whose top is above the corridor but in the image.
  high.box_min.z() = 1.05;
  high.box_max.z() = 1.1;
  high.box_min.x() = 3.0;
  high.box_max.x() = 3.4;
  auto img = render(high, 0.0);
  detector.detect(img, camera_extrinsics());
  for (const auto& p : detector.obstacle_points())
    CHECK(p.z() <= 1.0);

  auto stair = render(Scene{1.6, {0, 0, 0}, {0, 0, 0}}, 0.0);
  REQUIRE(detector.detect(stair, camera_extrinsics()) > 0);
  const auto scan = detector.virtual_scan();
  REQUIRE(scan.is_valid(88));
  CHECK(scan.range(88) == Approx(1.6).margin(0.05));
  for (const auto& p : detector.obstacle_points())
    CHECK(p.z() == 0.0);
}

TEST_CASE("jump-edge filtering removes the simulator's mixed pixels and keeps real edges",
          "[egocentric][tof]") {
  // The simulated SR4000 (sim::TofCamera, default noise) 1.1 m high, tilted 25 deg down, at a
  // 0.5 m box 1.6 m ahead in front of a wall 3.5 m away: mixed pixels along the box's top and
  // sides (the camera reports the power-weighted mean depth of both surfaces, paper 002 §7.1).
  sim::World world;
  world.add_wall({{3.5, -3.0}, {3.5, 3.0}});
  world.add_box({{1.8, 0.0}, {0.4, 0.6}, 0.0, 0.0, 0.5});
  world.build_index();
  sim::TofCamera camera;
  camera.set_pan_tilt(0.0, deg_to_rad(25.0));
  std::mt19937 rng(5);
  const Pose2d robot{};
  const DepthImage<double> raw = camera.capture(world, robot, rng);
  const std::vector<double> truth = camera.true_depth(world, robot);
  DepthImage<double> before = raw;
  apply_median_filter(before);  // the pipeline of §7.1: median, then Eq. (13)-(14)
  DepthImage<double> after = before;
  JumpEdgeFilter<double> filter(raw.intrinsics, raw.kind);
  CHECK(filter.filter(after) > 0);
  // Truth (sim::TofCamera::score_jump_edges): a mixed pixel reads far (> max(10 cm, 5 sigma))
  // from the true depth of its centre; a real edge pixel reads its true depth and has a
  // neighbour at least 0.3 m deeper.
  const auto [mixed, mixed_removed, edges, edges_kept] =
      camera.score_jump_edges(truth, before, after);
  INFO("mixed " << mixed_removed << " / " << mixed << " removed, edges " << edges_kept << " / "
                << edges << " kept");
  REQUIRE(mixed > 50);
  REQUIRE(edges > 50);
  CHECK(mixed_removed == mixed);
  CHECK(static_cast<double>(edges_kept) >= 0.9 * static_cast<double>(edges));
  // Eq. (14) alone (min_jump = 0) removes more of the real edges.
  JumpEdgeParams<double> angle_only;
  angle_only.min_jump = 0.0;
  DepthImage<double> strict = before;
  JumpEdgeFilter<double>(raw.intrinsics, raw.kind, angle_only).filter(strict);
  std::size_t strict_removed = 0, removed = 0;
  for (std::size_t i = 0; i < raw.depth.size(); ++i) {
    strict_removed += DepthImage<double>::is_valid_depth(strict.depth[i]) ? 0 : 1;
    removed += DepthImage<double>::is_valid_depth(after.depth[i]) ? 0 : 1;
  }
  CHECK(strict_removed > removed);
  // Without the filter the mixed pixels would be there.
  std::size_t left = 0;
  for (std::size_t i = 0; i < raw.depth.size(); ++i)
    left += DepthImage<double>::is_valid_depth(before.depth[i]) && std::isfinite(truth[i]) &&
                    std::abs(before.depth[i] - truth[i]) > 0.1
                ? 1
                : 0;
  CHECK(left > 50);
}

TEST_CASE("fusion: laser scan and ToF virtual scan in one obstacle map", "[egocentric][tof]") {
  HeightImageObstacleDetector<double> detector;
  auto img = render(Scene{}, 0.005);
  apply_median_filter(img);
  detector.detect(img, camera_extrinsics());
  // A 2D laser 0.3 m above the floor sees only the wall at 3 m: the 0.2 m box is below its plane.
  std::vector<double> ranges(181, 3.0);
  const LaserScand laser(-std::numbers::pi / 2, std::numbers::pi / 180, 0.05, 30.0, ranges);
  ObstacleMap<double> map;
  map.insert(laser, PlanarMount<double>{Pose2d{}, 0.3});
  map.insert(detector.obstacle_points());
  CHECK(map.bin(map.bin_index(0.0)).range == Approx(1.2).margin(0.05));
  CHECK(map.bin(map.bin_index(laser.angle(150))).range == Approx(3.0));  // 60 deg
  // Inserting the virtual scan itself gives the same nearest obstacle ahead.
  ObstacleMap<double> map2;
  map2.insert(laser, PlanarMount<double>{Pose2d{}, 0.3});
  map2.insert(detector.virtual_scan(), PlanarMount<double>{Pose2d{}, 0.1});
  CHECK(map2.bin(map2.bin_index(0.0)).range == Approx(1.2).margin(0.05));
}

TEST_CASE("organised clouds (RGB-D frames) go through the same detection", "[egocentric][tof]") {
  auto img = render(Scene{}, 0.005);
  apply_median_filter(img);
  HeightImageObstacleDetector<double> from_image, from_cloud;
  const std::size_t n = from_image.detect(img, camera_extrinsics());
  CHECK(from_cloud.detect(to_organized_cloud(img), camera_extrinsics()) == n);
  CHECK(from_cloud.obstacle_mask() == from_image.obstacle_mask());
  const auto scan = from_cloud.virtual_scan();
  REQUIRE(scan.size() == 176);
  CHECK(scan.range(88) == Approx(1.2).margin(0.05));
  CHECK_THROWS_WITH(from_cloud.detect(Cloud3d{}, camera_extrinsics()),
                    "rangenav: HeightImageObstacleDetector::detect: the cloud is empty");
}

TEST_CASE("the height-image test equals a brute-force Eq. (15) over W, pixel by pixel",
          "[egocentric][tof]") {
  // The detector skips the column walk where a block-wise column minimum proves the point flat;
  // the mask must still be exactly the definition: z in the corridor and z - min(W) > ε_H, W the
  // Moore neighbourhood plus the column while within window_radius (up to window_steps rows).
  Scene scene;
  scene.stair_x = 2.2;  // a stair edge, a box, a noisy floor: every case of the window
  const DepthImage<double> img = render(scene, 0.01, 17);
  for (const std::size_t steps : {std::size_t(8), std::size_t(3), std::size_t(200)}) {
    HeightImageParams<double> params;
    params.window_steps = steps;
    HeightImageObstacleDetector<double> detector(params);
    detector.detect(img, camera_extrinsics());
    const auto& pts = detector.points();
    const std::size_t w = 176, h = 144;
    const auto height = [&](std::size_t i) {  // heights that count in W
      const Point3d& q = pts[i];
      return q.allFinite() && q.z() >= -params.below_floor
                 ? q.z()
                 : std::numeric_limits<double>::infinity();
    };
    std::size_t mismatches = 0, obstacles = 0;
    for (std::size_t r = 0; r < h; ++r)
      for (std::size_t c = 0; c < w; ++c) {
        const std::size_t i = r * w + c;
        const Point3d& p = pts[i];
        bool expected = false;
        if (p.allFinite() && p.z() < -params.below_floor) {
          expected = true;  // an artificial obstacle (the ray meets the floor)
        } else if (p.allFinite() && p.z() >= params.z_min && p.z() <= params.z_max) {
          double lo = p.z();
          for (std::size_t rr = r == 0 ? 0 : r - 1; rr <= std::min(r + 1, h - 1); ++rr)
            for (std::size_t cc = c == 0 ? 0 : c - 1; cc <= std::min(c + 1, w - 1); ++cc)
              lo = std::min(lo, height(rr * w + cc));
          for (const int dir : {-1, 1})
            for (std::size_t k = 2; k <= steps; ++k) {
              const auto rr = static_cast<std::ptrdiff_t>(r) + dir * static_cast<std::ptrdiff_t>(k);
              if (rr < 0 || rr >= static_cast<std::ptrdiff_t>(h)) break;
              const std::size_t j = static_cast<std::size_t>(rr) * w + c;
              const double dx = pts[j].x() - p.x(), dy = pts[j].y() - p.y();
              if (dx * dx + dy * dy > params.window_radius * params.window_radius) break;
              lo = std::min(lo, height(j));
            }
          expected = p.z() - lo > params.epsilon_h;
        }
        obstacles += expected ? 1 : 0;
        mismatches += (detector.obstacle_mask()[i] != 0) != expected ? 1 : 0;
      }
    INFO("window_steps " << steps);
    CHECK(obstacles > 500);
    CHECK(mismatches == 0);
  }
}
