#pragma once
// The viewing frustum of a range sensor and the frustum-culling rejector of ICP
// (paper 002 §7.3, after May et al. 2009; paper 004 §3.2).
//
// In 2D the frustum is a wedge: bearings in [angle_min, angle_max] and ranges in [near, far].
// In 3D it is a pyramid looking along the sensor's +x axis (x forward, y left, z up) with
// horizontal and vertical opening angles and near / far planes x = near, x = far.

#include <cmath>
#include <concepts>
#include <cstddef>
#include <numbers>
#include <string_view>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/registration/correspondence.hpp"

namespace rangenav {

/// A sensor's field of view in its own frame, placed in a parent frame by `pose`.
template <int D, std::floating_point Scalar = double>
struct Frustum {
  static_assert(D == 2 || D == 3, "Frustum: dimension must be 2 or 3");

  /// Sensor frame -> parent frame.
  Transform<D, Scalar> pose = Transform<D, Scalar>::Identity();
  Scalar near = Scalar(0);  ///< 2D: minimum range; 3D: near plane distance along +x (m)
  Scalar far = Scalar(30);  ///< 2D: maximum range; 3D: far plane distance along +x (m)
  /// 2D only: the wedge's first bearing (rad), e.g. a 180° scanner: -pi/2 .. pi/2. A bearing is
  /// atan2(y, x) in (-pi, pi], counter-clockwise from +x.
  Scalar angle_min = -std::numbers::pi_v<Scalar> / 2;
  /// 2D only: the wedge's last bearing (rad).
  Scalar angle_max = std::numbers::pi_v<Scalar> / 2;
  /// 3D only: full horizontal opening angle (rad), e.g. a SwissRanger SR-3000: 47.5° x 39.6°.
  Scalar horizontal_fov = Scalar(47.5) * std::numbers::pi_v<Scalar> / 180;
  /// 3D only: full vertical opening angle (rad).
  Scalar vertical_fov = Scalar(39.6) * std::numbers::pi_v<Scalar> / 180;

  /// Throws invalid_argument unless pose is a finite rigid transform and 0 <= near < far
  /// (finite); in 2D angle_min < angle_max (finite), in 3D both opening angles in (0, pi).
  void validate() const {
    constexpr std::string_view where = "Frustum";
    if (!is_rigid(pose, Scalar(1e-4)))
      detail::throw_invalid(where, "argument 'pose' must be a finite rigid transform");
    detail::require_non_negative(where, "near", near);
    detail::require_positive(where, "far", far);
    if (far <= near) detail::throw_invalid_argument(where, "far", far, "must be > near");
    if constexpr (D == 2) {
      detail::require_finite(where, "angle_min", angle_min);
      detail::require_finite(where, "angle_max", angle_max);
      if (angle_max <= angle_min)
        detail::throw_invalid_argument(where, "angle_max", angle_max, "must be > angle_min");
    } else {
      if (!(horizontal_fov > 0 && horizontal_fov < std::numbers::pi_v<Scalar>))
        detail::throw_invalid_argument(where, "horizontal_fov", horizontal_fov,
                                       "must be in (0, pi)");
      if (!(vertical_fov > 0 && vertical_fov < std::numbers::pi_v<Scalar>))
        detail::throw_invalid_argument(where, "vertical_fov", vertical_fov, "must be in (0, pi)");
    }
  }

  /// True when a point given in the sensor's own frame lies inside the frustum.
  [[nodiscard]] bool contains_local(const Point<D, Scalar>& p) const {
    if constexpr (D == 2) {
      const Scalar r_sq = p.squaredNorm();
      if (r_sq < near * near || r_sq > far * far) return false;
      const Scalar bearing = std::atan2(p.y(), p.x());
      return bearing >= angle_min && bearing <= angle_max;
    } else {
      return contains_local(p, std::tan(horizontal_fov / 2), std::tan(vertical_fov / 2));
    }
  }

  /// contains_local in 3D with the tangents of the half opening angles given, tan(h/2) and
  /// tan(v/2) (callers testing many points compute them once).
  [[nodiscard]] bool contains_local(const Point<D, Scalar>& p, Scalar tan_half_h,
                                    Scalar tan_half_v) const requires(D == 3) {
    // Pyramid side planes: |y| <= x tan(h/2), |z| <= x tan(v/2) (inside-outside test with the
    // planes' normals, paper 004 §3.2).
    if (p.x() < near || p.x() > far) return false;
    return std::abs(p.y()) <= p.x() * tan_half_h && std::abs(p.z()) <= p.x() * tan_half_v;
  }

  /// True when a point given in the parent frame lies inside the frustum.
  [[nodiscard]] bool contains(const Point<D, Scalar>& p) const {
    return contains_local(pose.inverse(Eigen::Isometry) * p);
  }
};

/// Frustum culling inside ICP, re-evaluated every iteration with the current transform
/// (paper 002 §7.3): the data points that the current estimate moves outside the model's
/// frustum are not searched for (they cannot form a valid pair). In the other mode (paper 004
/// §3.2), pairs whose model point lies outside the data sensor's current frustum are dropped.
template <int D, std::floating_point Scalar = double>
struct FrustumRejector {
  /// Which frustum is tested, against which points.
  enum class Mode {
    data_in_model_frustum,  ///< `frustum.pose` is the model sensor's pose in the model frame
    model_in_data_frustum,  ///< `frustum.pose` is the data sensor's pose in the data frame
  };
  Frustum<D, Scalar> frustum{};             ///< the sensor's frustum; `mode` says whose
  Mode mode = Mode::data_in_model_frustum;  ///< which test runs

  FrustumRejector() = default;
  /// A rejector testing frustum `f` in mode `m` (the frustum is not validated here).
  explicit FrustumRejector(const Frustum<D, Scalar>& f, Mode m = Mode::data_in_model_frustum)
      : frustum(f), mode(m) {}

  /// Caches the frustum's inverse pose and, in 3D, the tangents of its half opening angles;
  /// ICP calls it at the start of every alignment.
  void begin(std::size_t, std::size_t) {
    model_to_sensor_ = frustum.pose.inverse(Eigen::Isometry);
    if constexpr (D == 3) {
      tan_half_h_ = std::tan(frustum.horizontal_fov / 2);
      tan_half_v_ = std::tan(frustum.vertical_fov / 2);
    }
  }

  /// Mode data_in_model_frustum: true when data point `p`, already moved into the model frame
  /// by the current estimate, lies inside the frustum (needs begin(), which ICP calls). Always
  /// true in the other mode.
  [[nodiscard]] bool admits(const IcpContext<D, Scalar>&, const Point<D, Scalar>& p) const {
    return mode != Mode::data_in_model_frustum ||
           contains_local(model_to_sensor_ * p, tan_half_h_, tan_half_v_);
  }

  /// Mode model_in_data_frustum: drops the pairs whose model point lies outside the data
  /// sensor's frustum, placed in the model frame by ctx.transform. Does nothing in the other
  /// mode.
  void reject(const IcpContext<D, Scalar>& ctx,
              std::vector<Correspondence<D, Scalar>>& pairs) const {
    if (mode != Mode::model_in_data_frustum) return;
    // The data sensor's frustum placed in the model frame by the current estimate.
    const detail::AffineApply<D, Scalar> to_sensor(
        (ctx.transform * frustum.pose).inverse(Eigen::Isometry));
    Scalar tan_h = 0, tan_v = 0;
    if constexpr (D == 3) {
      tan_h = std::tan(frustum.horizontal_fov / 2);
      tan_v = std::tan(frustum.vertical_fov / 2);
    }
    std::erase_if(pairs, [&](const Correspondence<D, Scalar>& c) {
      return !contains_local(to_sensor(c.model), tan_h, tan_v);
    });
  }

 private:
  // Frustum::contains_local, in 3D with the tangents computed once per alignment or iteration
  // (not two tan() calls per point).
  [[nodiscard]] bool contains_local(const Point<D, Scalar>& p, Scalar tan_h, Scalar tan_v) const {
    if constexpr (D == 2)
      return frustum.contains_local(p);
    else
      return frustum.contains_local(p, tan_h, tan_v);
  }

  Transform<D, Scalar> model_to_sensor_ = Transform<D, Scalar>::Identity();
  Scalar tan_half_h_ = 0, tan_half_v_ = 0;
};

}  // namespace rangenav
