#pragma once
// The set-up and the scoring of lesson 08 (and of tools/geometric_map_study, which varies it):
// the simulated kitchen with optional non-planar objects, a Kinect-like camera moving back and
// forth in front of it, and paper 004's Table 1 measures of a geometric map against the kitchen's
// true planes. Not library code: the lesson is what 08_geometric_map.cpp does with them.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <numbers>
#include <vector>

#include "rangenav/mapping/geometric_map.hpp"
#include "rangenav/scan/depth_image.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

namespace kitchen {

using namespace rangenav;

/// The kitchen of paper 004; with `objects`, non-planar objects too (a bin and a vase on the
/// floor, jars on the counter top, a pot on the table).
inline sim::Scene scene(bool objects) {
  sim::Scene s = sim::kitchen();
  if (objects) {
    s.world.add_cylinder({{1.2, 1.0}, 0.18, 0.0, 0.6});
    s.world.add_cylinder({{1.0, 3.0}, 0.12, 0.0, 0.45});
    s.world.add_cylinder({{0.3, 1.2}, 0.06, 0.94, 1.15});
    s.world.add_cylinder({{0.35, 2.6}, 0.1, 0.94, 1.1});
    s.world.add_cylinder({{2.3, 2.2}, 0.12, 0.75, 0.9});
    s.world.build_index();
  }
  return s;
}

/// A Kinect-like depth camera (57 x 43 deg, 640 x 480 or 160 x 120) 1.1 m high, tilted 20 deg
/// down, with range noise `sigma` and no mixed pixels.
inline sim::TofCamera camera(bool full, double sigma) {
  sim::TofCameraParams cp;
  cp.intrinsics = PinholeIntrinsics<double>::from_fov(full ? 640 : 160, full ? 480 : 120,
                                                      57.0 * std::numbers::pi / 180.0,
                                                      43.0 * std::numbers::pi / 180.0);
  cp.tilt = 0.35;
  cp.range_max = 6.0;
  cp.noise_sigma_0 = sigma;
  cp.noise_sigma_2 = 0.0;
  cp.jump_edges = false;
  return sim::TofCamera(cp);
}

/// The robot's pose at frame k of `frames`: back and forth along the kitchen `cycles` times,
/// turning the camera from side to side.
inline Pose2d path(int k, int frames, int cycles) {
  const double phase = 2 * std::numbers::pi * cycles * k / frames;
  return {3.9 + 0.2 * std::sin(2 * phase), 2.0 + 1.0 * std::sin(phase),
          std::numbers::pi + 0.4 * std::sin(3 * phase)};
}

/// Whether `p` projected onto the true plane lies in its labelled region (a convex outline).
inline bool in_region(const sim::ScenePlane& tp, const Point3d& p) {
  const std::size_t n = tp.outline.size();
  int sign = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Point3d& a = tp.outline[i];
    const Point3d& b = tp.outline[(i + 1) % n];
    const double side = (b - a).cross(p - a).dot(tp.normal);
    const int s = side > 0 ? 1 : (side < 0 ? -1 : 0);
    if (s == 0) continue;
    if (sign != 0 && s != sign) return false;
    sign = s;
  }
  return true;
}

/// Table 1 of paper 004, averaged over the map planes associated with a true plane.
struct Accuracy {
  double d_coeff = 0;  ///< |(a, b, c, d)_map - (a, b, c, d)_true|, normalised, signs aligned
  double d_angle = 0;  ///< angle between the normals (rad)
  double d_dist = 0;   ///< |d_map - d_true| (m)
  double rms_p = 0;    ///< RMS distance of the hull vertices to the true plane (m)
  std::size_t associated = 0;
  std::vector<std::size_t> shapes_per_plane;  ///< map shapes associated with each true plane
};

/// Table 1's measures of the map against the scene's true planes. A map plane is associated with
/// a true plane when its normal is within acos(0.95) (Eq. 6a, t1 = 0.95), its hull vertices lie
/// within t2 = 0.1 m of it on average, and the hull's vertex centroid lies in the true plane's
/// labelled region (the paper labels regions of a reference map; without it the counter top's
/// 4 cm front edge, a real surface 5 cm before the kitchen front, counted as its error).
inline Accuracy accuracy(const GeometricMap<double>& map, const sim::Scene& scene) {
  Accuracy acc;
  acc.shapes_per_plane.assign(scene.planes.size(), 0);
  double sum_sq = 0;
  std::size_t vertices = 0;
  for (const auto& shape : map.shapes()) {
    const PlanarPolygon<double>& p = shape.surface;
    const auto outline = p.outer_world();
    Point3d centroid = Point3d::Zero();
    for (const Point3d& v : outline)
      centroid += v;
    centroid /= static_cast<double>(outline.size());
    const sim::ScenePlane* best = nullptr;
    double best_mean = 0.1;  // t2
    for (const auto& tp : scene.planes) {
      if (std::abs(tp.normal.dot(p.plane.normal)) <= 0.95 || !in_region(tp, centroid)) continue;
      double mean = 0;
      for (const Point3d& v : outline)
        mean += std::abs(tp.signed_distance(v));
      mean /= static_cast<double>(outline.size());
      if (mean < best_mean) {
        best_mean = mean;
        best = &tp;
      }
    }
    if (best == nullptr) continue;
    Plane3<double> pl = p.plane;
    if (pl.normal.dot(best->normal) < 0) pl = pl.flipped();
    const Eigen::Vector4d a(pl.normal.x(), pl.normal.y(), pl.normal.z(), pl.d);
    const Eigen::Vector4d b(best->normal.x(), best->normal.y(), best->normal.z(), best->d);
    acc.d_coeff += (a - b).norm();
    acc.d_angle += std::acos(std::min(1.0, pl.normal.dot(best->normal)));
    acc.d_dist += std::abs(pl.d - best->d);
    for (const Point3d& v : outline) {
      sum_sq += best->signed_distance(v) * best->signed_distance(v);
      ++vertices;
    }
    ++acc.associated;
    ++acc.shapes_per_plane[static_cast<std::size_t>(best - scene.planes.data())];
  }
  if (acc.associated > 0) {
    const double n = static_cast<double>(acc.associated);
    acc.d_coeff /= n;
    acc.d_angle /= n;
    acc.d_dist /= n;
    acc.rms_p = std::sqrt(sum_sq / static_cast<double>(vertices));
  }
  return acc;
}

}  // namespace kitchen
