#pragma once
// Points, rigid transforms and planar poses: Eigen is the vocabulary at every boundary.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <concepts>
#include <type_traits>

#include "rangenav/core/angles.hpp"

namespace rangenav {

/// A point (or vector) in D dimensions.
template <int D, class Scalar = double>
using Point = Eigen::Matrix<Scalar, D, 1>;

/// A rigid transform (rotation + translation) in D dimensions.
template <int D, class Scalar = double>
using Transform = Eigen::Transform<Scalar, D, Eigen::Isometry>;

/// A 2D point in double precision.
using Point2d = Point<2, double>;
/// A 3D point in double precision.
using Point3d = Point<3, double>;
/// A 2D point in single precision.
using Point2f = Point<2, float>;
/// A 3D point in single precision.
using Point3f = Point<3, float>;
/// A planar rigid transform in double precision (Eigen::Isometry2d).
using Transform2d = Transform<2, double>;
/// A 3D rigid transform in double precision (Eigen::Isometry3d).
using Transform3d = Transform<3, double>;
/// A planar rigid transform in single precision.
using Transform2f = Transform<2, float>;
/// A 3D rigid transform in single precision.
using Transform3f = Transform<3, float>;

/// A planar pose (x, y, theta) with theta in radians. Compose with `*`, invert with inverse().
template <std::floating_point Scalar = double>
struct Pose2 {
  /// m, along the parent frame's x axis.
  Scalar x{0};
  /// m, along the parent frame's y axis.
  Scalar y{0};
  /// rad, heading from the parent's x axis, counter-clockwise.
  Scalar theta{0};

  /// The pose as a rigid transform that maps points from the pose's frame into the parent frame.
  [[nodiscard]] Transform<2, Scalar> to_isometry() const {
    Transform<2, Scalar> t = Transform<2, Scalar>::Identity();
    t.linear() = Eigen::Rotation2D<Scalar>(theta).toRotationMatrix();
    t.translation() = Point<2, Scalar>(x, y);
    return t;
  }

  /// The pose of a planar rigid transform; theta normalised to (-pi, pi].
  [[nodiscard]] static Pose2 from_isometry(const Transform<2, Scalar>& t) {
    const auto& r = t.linear();
    return {t.translation().x(), t.translation().y(), std::atan2(r(1, 0), r(0, 0))};
  }

  /// The position (x, y).
  [[nodiscard]] Point<2, Scalar> position() const { return {x, y}; }

  /// Maps a point given in this pose's frame into the parent frame.
  [[nodiscard]] Point<2, Scalar> transform_point(const Point<2, Scalar>& p) const {
    const Scalar c = std::cos(theta), s = std::sin(theta);
    return {x + c * p.x() - s * p.y(), y + s * p.x() + c * p.y()};
  }

  friend bool operator==(const Pose2&, const Pose2&) = default;
};

/// A planar pose in double precision.
using Pose2d = Pose2<double>;
/// A planar pose in single precision.
using Pose2f = Pose2<float>;

/// SE(2) composition a ⊕ b: the pose b (given in a's frame) expressed in a's parent frame.
template <std::floating_point Scalar>
[[nodiscard]] Pose2<Scalar> compose(const Pose2<Scalar>& a, const Pose2<Scalar>& b) {
  const Scalar c = std::cos(a.theta), s = std::sin(a.theta);
  return {a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, normalize_angle(a.theta + b.theta)};
}

template <std::floating_point Scalar>
/// compose(a, b).
[[nodiscard]] Pose2<Scalar> operator*(const Pose2<Scalar>& a, const Pose2<Scalar>& b) {
  return compose(a, b);
}

/// SE(2) inverse ⊖a: compose(a, inverse(a)) is the identity.
template <std::floating_point Scalar>
[[nodiscard]] Pose2<Scalar> inverse(const Pose2<Scalar>& a) {
  const Scalar c = std::cos(a.theta), s = std::sin(a.theta);
  return {-c * a.x - s * a.y, s * a.x - c * a.y, normalize_angle(-a.theta)};
}

/// The pose of b in the frame of a: (⊖a) ⊕ b, e.g. the odometry increment between two readings.
template <std::floating_point Scalar>
[[nodiscard]] Pose2<Scalar> relative(const Pose2<Scalar>& a, const Pose2<Scalar>& b) {
  return compose(inverse(a), b);
}

/// A planar transform from (x, y, theta).
template <std::floating_point Scalar>
[[nodiscard]] Transform<2, Scalar> make_transform2(Scalar x, Scalar y, Scalar theta) {
  return Pose2<Scalar>{x, y, theta}.to_isometry();
}

/// The rotation angle of a planar transform, in (-pi, pi].
template <std::floating_point Scalar>
[[nodiscard]] Scalar rotation_angle(const Transform<2, Scalar>& t) {
  return std::atan2(t.linear()(1, 0), t.linear()(0, 0));
}

/// The rotation angle of a 3D transform (the angle of its axis-angle form), in [0, pi].
template <std::floating_point Scalar>
[[nodiscard]] Scalar rotation_angle(const Transform<3, Scalar>& t) {
  const Scalar c = (t.linear().trace() - Scalar(1)) / Scalar(2);
  return std::acos(std::clamp(c, Scalar(-1), Scalar(1)));
}

/// The tolerance of is_rigid for a transform an API receives: what composing and inverting a few
/// rigid transforms leaves of orthonormality in Scalar's precision (1e-6 in double, 1e-3 in
/// float).
template <class Scalar>
inline constexpr Scalar rigid_tolerance = std::is_same_v<Scalar, float> ? Scalar(1e-3)
                                                                        : Scalar(1e-6);

/// True when every coefficient is finite and the linear part is a rotation (orthonormal,
/// determinant +1) within `tolerance`.
template <int D, class Scalar>
[[nodiscard]] bool is_rigid(const Transform<D, Scalar>& t,
                            Scalar tolerance = rigid_tolerance<Scalar>) {
  if (!t.matrix().allFinite()) return false;
  const auto& r = t.linear();
  const auto should_be_identity = (r.transpose() * r).eval();
  if (!should_be_identity.isIdentity(tolerance)) return false;
  return std::abs(r.determinant() - Scalar(1)) <= tolerance;
}

}  // namespace rangenav
