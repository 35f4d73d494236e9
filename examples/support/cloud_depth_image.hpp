#pragma once
// Depth images from the organised RGB-D clouds lesson 05 runs its obstacle detection on: a PCD
// file stores points, the detection wants a depth image and its camera intrinsics. Not library
// code: the lesson is what 05_tof_obstacles.cpp does with the image.

#include <cstddef>
#include <limits>

#include "rangenav/core/cloud.hpp"
#include "rangenav/scan/depth_image.hpp"

namespace examples {

/// A depth image from an organised RGB-D cloud in the optical frame (x right, y down, z ahead):
/// z-depth per pixel (NaN where the point is not finite), and pinhole intrinsics fitted to the
/// points by least squares (column = fx x/z + cx, row = fy y/z + cy).
inline rangenav::DepthImage<double> depth_image_from_cloud(const rangenav::Cloud3d& cloud) {
  using namespace rangenav;
  double sx = 0, sxx = 0, su = 0, sxu = 0, sy = 0, syy = 0, sv = 0, syv = 0, n = 0;
  for (std::size_t r = 0; r < cloud.height; ++r)
    for (std::size_t c = 0; c < cloud.width; ++c) {
      const Point3d& p = cloud.at(r, c);
      if (!p.allFinite() || p.z() <= 0) continue;
      const double a = p.x() / p.z(), b = p.y() / p.z();
      const auto u = static_cast<double>(c), v = static_cast<double>(r);
      sx += a, sxx += a * a, su += u, sxu += a * u;
      sy += b, syy += b * b, sv += v, syv += b * v;
      n += 1;
    }
  DepthImage<double> img;
  img.kind = DepthKind::z_depth;
  img.intrinsics.width = cloud.width;
  img.intrinsics.height = cloud.height;
  img.intrinsics.fx = (n * sxu - sx * su) / (n * sxx - sx * sx);
  img.intrinsics.cx = (su - img.intrinsics.fx * sx) / n;
  img.intrinsics.fy = (n * syv - sy * sv) / (n * syy - sy * sy);
  img.intrinsics.cy = (sv - img.intrinsics.fy * sy) / n;
  img.depth.resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    img.depth[i] = cloud.points[i].allFinite() ? cloud.points[i].z()
                                               : std::numeric_limits<double>::quiet_NaN();
  return img;
}

}  // namespace examples
