#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <vector>

#include "rangenav/egocentric/floor.hpp"
#include "rangenav/egocentric/gaze.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/scan/pitching.hpp"

using namespace rangenav;

namespace {

// A closed-form scene: flat floor at z = 0 with a descending stair (the floor drops to -0.2 m
// for x > stair_x) and an axis-aligned box on the floor.
struct Scene {
  double stair_x = 100.0;
  Point3d box_min{1.5, -0.1, 0.0}, box_max{1.7, 0.1, 0.0};

  double cast(const Point3d& o, const Point3d& d) const {
    double best = std::numeric_limits<double>::infinity();
    if (d.z() < 0) {
      const double t0 = -o.z() / d.z();
      if ((o + t0 * d).x() <= stair_x)
        best = t0;
      else
        best = (-0.2 - o.z()) / d.z();  // the lower floor (the riser is ignored)
    }
    if (box_max.z() > 0) {  // slab test
      double tmin = 0, tmax = best;
      for (int k = 0; k < 3; ++k) {
        if (std::abs(d[k]) < 1e-12) {
          if (o[k] < box_min[k] || o[k] > box_max[k]) tmin = tmax + 1;
          continue;
        }
        double t1 = (box_min[k] - o[k]) / d[k], t2 = (box_max[k] - o[k]) / d[k];
        if (t1 > t2) std::swap(t1, t2);
        tmin = std::max(tmin, t1);
        tmax = std::min(tmax, t2);
      }
      if (tmin <= tmax && tmin > 0) best = std::min(best, tmin);
    }
    return best;
  }
};

// One sweep of a pitching scanner at t_s, as an organised grid: rows = scans (pitch angles),
// columns = beams, points in the robot frame (Eq. 3), with Gaussian range noise.
std::vector<Point3d> sweep(const Scene& scene, const Point3d& t_s, double noise, std::size_t& width,
                           unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, noise);
  std::vector<Point3d> out;
  width = 91;
  for (double pitch = deg_to_rad(8.0); pitch <= deg_to_rad(40.0); pitch += deg_to_rad(0.25))
    for (std::size_t b = 0; b < width; ++b) {
      const double yaw = deg_to_rad(-45.0 + static_cast<double>(b));
      const Point3d dir = pitched_point(1.0, yaw, pitch, Point3d::Zero().eval());
      const double r = scene.cast(t_s, dir) + (noise > 0 ? n(rng) : 0.0);
      out.push_back(pitched_point(r, yaw, pitch, t_s));
    }
  return out;
}

std::vector<Point3d> obstacles(const std::vector<Point3d>& pts, std::size_t width,
                               const Point3d& origin,
                               const FloorClassifierParams<double>& params = {}) {
  std::vector<PointClass> classes;
  classify_points(std::span<const Point3d>(pts), width, params, classes, &origin);
  std::vector<Point3d> out;
  append_obstacle_points(std::span<const Point3d>(pts), std::span<const PointClass>(classes),
                         origin, out);
  return out;
}

}  // namespace

TEST_CASE("simple floor threshold", "[egocentric][floor]") {
  CHECK(is_floor_height(0.02));
  CHECK(is_floor_height(-0.025));
  CHECK_FALSE(is_floor_height(0.03));
  CHECK(is_floor_height(0.03, 0.05));
}

TEST_CASE("neighbourhood classes on a hand-made grid", "[egocentric][floor]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // 2 rows x 4 columns: floor with one 3-cm bump, a hole, an invalid point.
  std::vector<Point3d> g = {
      {1, 0, 0.0}, {1, 1, 0.03},  {1, 2, 0.0}, {1, 3, nan},   //
      {2, 0, 0.0}, {2, 1, 0.005}, {2, 2, 0.0}, {2, 3, -0.3},  //
  };
  std::vector<PointClass> c;
  const Point3d origin(0.0, 0.0, 0.5);  // the bump is seen under 18 deg: threshold 1.6 cm
  classify_points(std::span<const Point3d>(g), 4, FloorClassifierParams<double>{}, c, &origin);
  CHECK(c[0] == PointClass::floor);
  CHECK(c[1] == PointClass::obstacle);  // 3 cm above its lowest neighbour
  CHECK(c[5] == PointClass::floor);     // 5 mm: within the step height
  CHECK(c[3] == PointClass::invalid);
  CHECK(c[7] == PointClass::below_floor);
  CHECK(c[6] == PointClass::floor);  // a floor point at the stair's edge stays floor
  // A ceiling row above a row that holds a wall point.
  const std::vector<Point3d> top = {{3, 0, 2.2}, {3, 1, 2.2}, {3, 2, 2.21},  //
                                    {3, 0, 2.2}, {3, 1, 2.2}, {3, 2, 1.5}};
  std::vector<PointClass> t;
  classify_points(std::span<const Point3d>(top), 3, FloorClassifierParams<double>{}, t);
  CHECK(t[0] == PointClass::ceiling);
  CHECK(t[2] == PointClass::wall);  // its neighbourhood is not flat (the 1.5 m point)
  CHECK(t[5] == PointClass::wall);
  g.resize(12, Point3d(0, 0, 0));
  CHECK_THROWS_WITH(
      classify_points(std::span<const Point3d>(g), 5, FloorClassifierParams<double>{}, c),
      "rangenav: classify_points: argument 'width' = 5 must be > 0 and divide the point count 12");
  FloorClassifierParams<double> bad;
  bad.step_height = 0;
  CHECK_THROWS_WITH(classify_points(std::span<const Point3d>(g), 4, bad, c),
                    "rangenav: classify_points: argument 'step_height' = 0 must be finite and > 0");
  std::vector<Point3d> out;
  CHECK_THROWS_WITH(
      append_obstacle_points(std::span<const Point3d>(g), std::span<const PointClass>(c.data(), 3),
                             Point3d(0, 0, 0.4), out),
      "rangenav: append_obstacle_points: argument 'classes.size()' = 3 must equal "
      "points.size() = 12");
}

TEST_CASE("floor thresholds follow from the range noise", "[egocentric][floor]") {
  // A range error moves a reading along its beam: under 30 deg depression, half of it is height.
  CHECK(floor_height_noise(0.01, deg_to_rad(30.0)) == Approx(0.005));
  CHECK(floor_height_noise(0.01, 0.0) == 0.0);
  CHECK_THROWS_WITH(floor_height_noise(-0.01, 0.5),
                    "rangenav: floor_height_noise: argument 'range_noise' = -0.01 must be "
                    "finite and >= 0");
  const FloorClassifierParams<double> p;  // 1 cm, 40 deg, 5 sigma, at least 1.5 cm
  const Point3d origin(0.0, 0.0, 0.5);
  // Seen steeply (45 deg): 5 * 1 cm * sin 45 deg = 3.5 cm.
  const auto steep = p.thresholds(Point3d(0.5, 0.0, 0.0), &origin);
  CHECK(steep.first == Approx(0.05 * std::sqrt(0.5)));
  CHECK(steep.second == steep.first);
  // Seen at a grazing angle (2 m away): 5 * 1 cm * 0.24 = 1.2 cm < the 1.5 cm floor.
  const auto far = p.thresholds(Point3d(2.0, 0.0, 0.0), &origin);
  CHECK(far.first == 0.015);
  CHECK(far.second == 0.015);
  // Origin unknown: the steepest beam (40 deg).
  CHECK(p.thresholds(Point3d(2.0, 0.0, 0.0), nullptr).first ==
        Approx(0.05 * std::sin(deg_to_rad(40.0))));
  FloorClassifierParams<double> bad;
  bad.range_noise = -1;
  std::vector<PointClass> c;
  const std::vector<Point3d> g(4, Point3d(1, 0, 0));
  CHECK_THROWS_WITH(classify_points(std::span<const Point3d>(g), 2, bad, c),
                    "rangenav: classify_points: argument 'range_noise' = -1 must be finite and "
                    ">= 0");
}

TEST_CASE("a flat noisy floor never enters the obstacle map", "[egocentric][floor]") {
  const Scene flat{100.0, {0, 0, 0}, {0, 0, 0}};
  const Point3d t_s(0.1, 0.0, 0.4);
  std::size_t width = 0;
  // The default parameters with the simulator's default noise (1 cm), and the SICK LMS 2xx's
  // 5 mm with the parameters derived from it.
  for (const double noise : {0.01, 0.005}) {
    INFO("range noise " << noise);
    FloorClassifierParams<double> params;
    params.range_noise = noise;
    ObstacleMap<double> map;
    std::size_t points = 0;
    for (unsigned seed = 1; seed <= 5; ++seed) {
      const auto pts = sweep(flat, t_s, noise, width, seed);
      REQUIRE(pts.size() > 10000);
      points += pts.size();
      map.insert(obstacles(pts, width, t_s, params));
    }
    CHECK(points > 50000);
    CHECK(map.valid_count() == 0);
  }
  // Thresholds that ignore the noise (1.5 cm) let 1-cm noise through.
  FloorClassifierParams<double> old;
  old.range_noise = 0.0;
  ObstacleMap<double> map;
  for (unsigned seed = 1; seed <= 5; ++seed)
    map.insert(obstacles(sweep(flat, t_s, 0.01, width, seed), width, t_s, old));
  CHECK(map.valid_count() > 0);
}

TEST_CASE("a 3-cm object survives the default classification with the default noise",
          "[egocentric][floor]") {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    INFO("seed " << seed);
    Scene scene;
    scene.box_max.z() = 0.03;
    const Point3d t_s(0.0, 0.0, 0.4);
    std::size_t width = 0;
    const auto pts = sweep(scene, t_s, 0.01, width, seed);
    ObstacleMap<double> map;
    map.insert(obstacles(pts, width, t_s));
    // The 1-deg beams leave some 0.5-deg bins empty: the nearest reading within one bin.
    for (const double bearing : {-0.03, 0.0, 0.03}) {
      INFO("bearing " << bearing);
      double nearest_x = std::numeric_limits<double>::infinity();
      const std::size_t k = map.bin_index(bearing);
      for (std::size_t j = k - 1; j <= k + 1; ++j)
        if (!map.bin(j).dummy) nearest_x = std::min(nearest_x, map.bin(j).x);
      CHECK(nearest_x == Approx(1.5).margin(0.05));  // the front face at x = 1.5
    }
    for (const auto& p : map.valid_points()) {  // and nothing but the box
      CHECK(p.x() >= 1.45);
      CHECK(p.x() <= 1.75);
      CHECK(std::abs(p.y()) <= 0.15);
    }
  }
}

TEST_CASE("a 2-cm object survives the neighbourhood classification, not the threshold",
          "[egocentric][floor]") {
  Scene scene;
  scene.box_max.z() = 0.02;
  const Point3d t_s(0.0, 0.0, 0.4);
  std::size_t width = 0;
  const auto pts = sweep(scene, t_s, 0.005, width);  // 5 mm: the SICK LMS 2xx
  ObstacleMap<double> map;
  map.insert(obstacles(pts, width, t_s));
  // Straight ahead the nearest obstacle is the box's front face at x = 1.5.
  const auto& ahead = map.bin(map.bin_index(0.001));
  REQUIRE_FALSE(ahead.dummy);
  CHECK(ahead.x == Approx(1.5).margin(0.05));
  // Everything the map holds lies on the box.
  for (const auto& p : map.valid_points()) {
    CHECK(p.x() >= 1.45);
    CHECK(p.x() <= 1.75);
    CHECK(std::abs(p.y()) <= 0.15);
  }
  // The simple threshold with the paper's 2.5 cm loses the object entirely.
  std::vector<Point3d> thr;
  append_obstacle_points_threshold(std::span<const Point3d>(pts), 0.025, t_s, thr);
  ObstacleMap<double> map2;
  map2.insert(thr);
  CHECK(map2.valid_count() == 0);
}

TEST_CASE("a descending stair becomes an artificial obstacle at the floor edge",
          "[egocentric][floor]") {
  Scene scene{2.0, {0, 0, 0}, {0, 0, 0}};
  const Point3d t_s(0.0, 0.0, 0.4);
  std::size_t width = 0;
  const auto pts = sweep(scene, t_s, 0.002, width);
  ObstacleMap<double> map;
  map.insert(obstacles(pts, width, t_s));
  for (const double bearing : {-0.3, 0.0, 0.3}) {
    const auto& b = map.bin(map.bin_index(bearing));
    REQUIRE_FALSE(b.dummy);
    CHECK(b.x == Approx(2.0).margin(0.05));  // the first beam past the edge meets z=0 just beyond
    CHECK(b.z == 0.0);
  }
  // The beam / floor-plane intersection in closed form.
  const auto q = floor_intersection(Point3d(0, 0, 0.4), Point3d(3.0, 0.0, -0.2));
  REQUIRE(q);
  CHECK(q->isApprox(Point3d(2.0, 0.0, 0.0)));
  CHECK_FALSE(floor_intersection(Point3d(0, 0, 0.4), Point3d(3.0, 0.0, 0.1)));
}

TEST_CASE("gaze control follows Eq. (16)", "[egocentric][gaze]") {
  GazeParams<double> p;  // α = β = γ = 1, d_min = 0.5
  const Point3d ahead = gaze_target(1.0, 0.0, 0.0, p);
  CHECK(ahead.isApprox(Point3d(1.5, 0.0, 0.0)));
  const Point3d still = gaze_target(0.0, 0.0, 0.0, p);
  CHECK(still.isApprox(Point3d(0.5, 0.0, 0.0)));
  // Turning left on the spot looks left by β ω.
  const Point3d turn = gaze_target(0.0, 0.0, std::numbers::pi / 2, p);
  CHECK(turn.x() == Approx(0.0).margin(1e-12));
  CHECK(turn.y() == Approx(0.5));
  // Driving sideways (omnidirectional base) looks sideways, farther with speed.
  const Point3d side = gaze_target(0.0, -0.4, 0.0, p);
  CHECK(side.isApprox(Point3d(0.0, -0.9, 0.0)));
  const auto pt = look_at(Point3d(0, 0, 1.0), Point3d(1.0, 1.0, 0.0));
  CHECK(pt.pan == Approx(std::numbers::pi / 4));
  CHECK(pt.tilt == Approx(std::atan2(1.0, std::sqrt(2.0))));
  CHECK_THROWS_WITH(gaze_target(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0, p),
                    "rangenav: gaze_target: argument 'v_x' = nan must be finite");
}
