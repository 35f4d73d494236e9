#pragma once
// Synthetic scenes with known geometry for the registration and mapping tests.

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "rangenav/core/types.hpp"

namespace rangenav::test {

/// Points at random positions along the segment a-b, `step` metres apart on average (random,
/// not regular, so that a shifted copy has no aliased local minimum in point-to-point ICP).
inline void sample_segment(std::vector<Eigen::Vector2d>& out, Eigen::Vector2d a, Eigen::Vector2d b,
                           double step) {
  const double len = (b - a).norm();
  const int n = std::max(1, static_cast<int>(len / step));
  // Through a signed integer: a negative double converted to unsigned is undefined behaviour.
  const auto seed = static_cast<std::int64_t>(1000 * (a.x() + 3 * a.y() + 7 * b.x() + 11 * b.y()));
  std::mt19937 rng(static_cast<std::uint32_t>(seed + n));
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i <= n; ++i)
    out.push_back(a + (b - a) * u(rng));
}

/// A 2D room of 8 x 5 m with an L-shaped nook and a box inside: well constrained.
inline std::vector<Eigen::Vector2d> room_2d(double step = 0.05) {
  std::vector<Eigen::Vector2d> pts;
  const std::vector<Eigen::Vector2d> outline = {{-3, -2}, {5, -2}, {5, 1},  {4, 1},
                                                {4, 3},   {-3, 3}, {-3, -2}};
  for (std::size_t i = 0; i + 1 < outline.size(); ++i)
    sample_segment(pts, outline[i], outline[i + 1], step);
  sample_segment(pts, {1, 0}, {2, 0}, step);
  sample_segment(pts, {2, 0}, {2, 0.6}, step);
  sample_segment(pts, {2, 0.6}, {1, 0.6}, step);
  sample_segment(pts, {1, 0.6}, {1, 0}, step);
  return pts;
}

/// Two parallel walls 2 m apart and 40 m long: translation along x is unobservable.
inline std::vector<Eigen::Vector2d> corridor_2d(double step = 0.05) {
  std::vector<Eigen::Vector2d> pts;
  sample_segment(pts, {-20, -1}, {20, -1}, step);
  sample_segment(pts, {-20, 1}, {20, 1}, step);
  return pts;
}

/// Points on the faces of a 6 x 4 x 3 m room with two boxes on the floor (3D, well constrained).
inline std::vector<Eigen::Vector3d> room_3d(std::mt19937& rng, std::size_t per_face = 400) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3d> pts;
  const auto box = [&](Eigen::Vector3d lo, Eigen::Vector3d hi, bool skip_top_bottom) {
    for (int axis = 0; axis < 3; ++axis) {
      if (skip_top_bottom && axis == 2) continue;
      for (int side = 0; side < 2; ++side) {
        const double area = (hi - lo).prod() / (hi - lo)[axis];
        const auto n = static_cast<std::size_t>(static_cast<double>(per_face) * area / 12.0) + 20;
        for (std::size_t i = 0; i < n; ++i) {
          Eigen::Vector3d p;
          for (int k = 0; k < 3; ++k)
            p[k] = lo[k] + (hi[k] - lo[k]) * u(rng);
          p[axis] = side == 0 ? lo[axis] : hi[axis];
          pts.push_back(p);
        }
      }
    }
  };
  box({-3, -2, 0}, {3, 2, 3}, false);
  box({0.5, 0.3, 0}, {1.5, 1.0, 0.8}, true);
  box({-2.0, -1.5, 0}, {-1.2, -0.5, 1.2}, true);
  return pts;
}

template <int D>
std::vector<Point<D, double>> transformed(const std::vector<Point<D, double>>& pts,
                                          const Transform<D, double>& t) {
  std::vector<Point<D, double>> out;
  out.reserve(pts.size());
  for (const auto& p : pts)
    out.push_back(t * p);
  return out;
}

template <int D>
void add_noise(std::vector<Point<D, double>>& pts, double sigma, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, sigma);
  for (auto& p : pts)
    for (int d = 0; d < D; ++d)
      p[d] += n(rng);
}

inline Transform3d make_transform3(double x, double y, double z, double roll, double pitch,
                                   double yaw) {
  Transform3d t = Transform3d::Identity();
  t.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  t.translation() = Eigen::Vector3d(x, y, z);
  return t;
}

/// Translation and rotation error between two transforms.
template <int D>
std::pair<double, double> transform_error(const Transform<D, double>& a,
                                          const Transform<D, double>& b) {
  const Transform<D, double> e = a.inverse(Eigen::Isometry) * b;
  return {e.translation().norm(), std::abs(rotation_angle(e))};
}

}  // namespace rangenav::test
