#pragma once
// The one check every reader of a written-out rigid transform makes (MRPT pose files, KITTI pose
// lines, 4x4 text matrices): a finite matrix whose rotation block is orthonormal with determinant
// +1 to the precision files print, re-orthonormalised through a unit quaternion so that what the
// reader returns is rigid to machine precision.

#include <Eigen/Geometry>

#include "rangenav/core/types.hpp"

namespace rangenav::io::detail {

/// Orthonormality tolerance of a read rotation: RᵀR = I to 1e-3 (relative, Eigen's isApprox).
/// Files print six or more significant digits; a wider deviation is not a rotation.
inline constexpr double rigid_rotation_tolerance = 1e-3;

/// The rigid transform [R | t] of a 3x4 matrix, or fail(message) (which must throw) when an
/// element is not finite or R is not a rotation.
template <class Fail>
[[nodiscard]] Transform3d rigid_transform_or_fail(const Eigen::Matrix<double, 3, 4>& m,
                                                  const Fail& fail) {
  if (!m.allFinite()) fail("non-finite matrix element");
  const Eigen::Matrix3d r = m.leftCols<3>();
  if (!(r.transpose() * r).isApprox(Eigen::Matrix3d::Identity(), rigid_rotation_tolerance) ||
      !(r.determinant() > 0))
    fail("rotation is not orthonormal: not a rigid transform");
  Transform3d t = Transform3d::Identity();
  t.linear() = Eigen::Quaterniond(r).normalized().toRotationMatrix();
  t.translation() = m.col(3);
  return t;
}

}  // namespace rangenav::io::detail
