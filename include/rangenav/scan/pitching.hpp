#pragma once
// Continuously pitching 2D scanner (3D-perception paper 002 §3.3): a 2D scan taken at pitch
// angle theta_pitch becomes 3D points by rotating the measurement plane about the scanner's y axis
// and adding the scanner's offset t_s from the robot's centre of rotation, Eq. (3):
//   p_i = R_y(theta_pitch) (d_i cos theta_yaw_i, d_i sin theta_yaw_i, 0)^T + t_s,
//   R_y(a) = [[cos a, 0, sin a], [0, 1, 0], [-sin a, 0, cos a]].
// With this R_y a positive pitch tilts the beams downwards (a point ahead gets z < 0).

#include <cmath>
#include <concepts>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/scan/laser_scan.hpp"

namespace rangenav {

/// R_y(pitch) of Eq. (3).
template <std::floating_point Scalar>
[[nodiscard]] Eigen::Matrix<Scalar, 3, 3> pitch_rotation(Scalar pitch) {
  const Scalar c = std::cos(pitch), s = std::sin(pitch);
  Eigen::Matrix<Scalar, 3, 3> r;
  r << c, 0, s, 0, 1, 0, -s, 0, c;
  return r;
}

/// One reading (d, theta_yaw) at pitch theta_pitch as a 3D point, Eq. (3).
template <std::floating_point Scalar>
[[nodiscard]] Point<3, Scalar> pitched_point(Scalar range, Scalar yaw, Scalar pitch,
                                             const Point<3, Scalar>& sensor_offset) {
  const Scalar c = std::cos(pitch), s = std::sin(pitch);
  const Scalar px = range * std::cos(yaw), py = range * std::sin(yaw);
  // R_y(pitch) * (px, py, 0)^T + t_s, written out.
  return {c * px + sensor_offset.x(), py + sensor_offset.y(), -s * px + sensor_offset.z()};
}

/// A 2D scan tagged with the pitch angle at which it was taken.
template <std::floating_point Scalar = double>
struct PitchedScan {
  LaserScan<Scalar> scan;  ///< the 2D scan, in the scanner's frame
  Scalar pitch{0};         ///< rad; positive tilts the measurement plane downwards (Eq. 3)
};

/// The valid readings of a scan taken at `pitch`, as 3D points in the robot frame (Eq. 3).
/// The points are appended to `out` in beam order; returns the number appended.
template <std::floating_point Scalar>
std::size_t append_pitched_points(const LaserScan<Scalar>& scan, Scalar pitch,
                                  const Point<3, Scalar>& sensor_offset,
                                  std::vector<Point<3, Scalar>>& out) {
  detail::require_finite("append_pitched_points", "pitch", pitch);
  const Scalar c = std::cos(pitch), s = std::sin(pitch);
  out.reserve(out.size() + scan.valid_count());
  for (const auto& p : scan.valid_points())
    out.emplace_back(c * p.x() + sensor_offset.x(), p.y() + sensor_offset.y(),
                     -s * p.x() + sensor_offset.z());
  return scan.valid_count();
}

/// The valid readings of a scan taken at `pitch`, as 3D points in the robot frame (Eq. 3).
template <std::floating_point Scalar>
[[nodiscard]] std::vector<Point<3, Scalar>> pitched_points(const LaserScan<Scalar>& scan,
                                                           Scalar pitch,
                                                           const Point<3, Scalar>& sensor_offset) {
  std::vector<Point<3, Scalar>> out;
  append_pitched_points(scan, pitch, sensor_offset, out);
  return out;
}

/// The same with a full mounting transform (scanner rotated on the robot): p = M R_y(pitch) p_2d.
template <std::floating_point Scalar>
[[nodiscard]] std::vector<Point<3, Scalar>> pitched_points(const LaserScan<Scalar>& scan,
                                                           Scalar pitch,
                                                           const Transform<3, Scalar>& mount) {
  detail::require_finite("pitched_points", "pitch", pitch);
  const Eigen::Matrix<Scalar, 3, 3> r = mount.linear() * pitch_rotation(pitch);
  std::vector<Point<3, Scalar>> out;
  out.reserve(scan.valid_count());
  for (const auto& p : scan.valid_points())
    out.push_back(r.template leftCols<2>() * p + mount.translation());
  return out;
}

}  // namespace rangenav
