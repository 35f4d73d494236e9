#pragma once
// DepthImage: an organised range image from a time-of-flight or RGB-D camera, with pinhole
// intrinsics and an optional amplitude channel (3D-perception paper 002 §7), and its conversion
// into an organised 3D Cloud in which invalid pixels stay in place as NaN points.
//
// Points are expressed in the camera's body frame with the robot convention (x forward along the
// optical axis, y left, z up), so a camera mounted level looking ahead gives points like a laser
// scanner would. Pass CameraFrame::optical for the computer-vision frame (x right, y down, z
// ahead).

#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "rangenav/core/cloud.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav {

/// Pinhole intrinsics: pixel (u, v) = (column, row) sees the optical ray ((u-cx)/fx, (v-cy)/fy, 1).
template <std::floating_point Scalar = double>
struct PinholeIntrinsics {
  std::size_t width{0};   ///< pixels per row
  std::size_t height{0};  ///< rows
  Scalar fx{0};           ///< focal length in pixels, along a row
  Scalar fy{0};           ///< focal length in pixels, along a column
  Scalar cx{0};           ///< principal point, column (pixels)
  Scalar cy{0};           ///< principal point, row (pixels)

  /// Intrinsics of a camera with the given resolution and full horizontal / vertical apertures,
  /// e.g. from_fov(176, 144, deg_to_rad(43.0), deg_to_rad(34.0)) for the SR4000.
  [[nodiscard]] static PinholeIntrinsics from_fov(std::size_t width, std::size_t height,
                                                  Scalar fov_x, Scalar fov_y) {
    detail::require_positive("PinholeIntrinsics::from_fov", "fov_x", fov_x);
    detail::require_positive("PinholeIntrinsics::from_fov", "fov_y", fov_y);
    if (width == 0 || height == 0)
      detail::throw_invalid("PinholeIntrinsics::from_fov", "width and height must be > 0");
    const auto w = static_cast<Scalar>(width), h = static_cast<Scalar>(height);
    return {width,       height,     (w / 2) / std::tan(fov_x / 2), (h / 2) / std::tan(fov_y / 2),
            (w - 1) / 2, (h - 1) / 2};
  }

  /// Throws invalid_argument unless width, height, fx and fy are positive and every value is
  /// finite.
  void validate(std::string_view where = "PinholeIntrinsics") const {
    if (width == 0) detail::throw_invalid_argument(where, "width", width, "must be > 0");
    if (height == 0) detail::throw_invalid_argument(where, "height", height, "must be > 0");
    detail::require_positive(where, "fx", fx);
    detail::require_positive(where, "fy", fy);
    detail::require_finite(where, "cx", cx);
    detail::require_finite(where, "cy", cy);
  }

  /// Unit-free optical ray of pixel (row, col): ((u-cx)/fx, (v-cy)/fy, 1).
  [[nodiscard]] Point<3, Scalar> optical_ray(std::size_t row, std::size_t col) const {
    return {(static_cast<Scalar>(col) - cx) / fx, (static_cast<Scalar>(row) - cy) / fy, Scalar(1)};
  }
};

/// What a depth pixel measures.
enum class DepthKind {
  z_depth,  ///< distance along the optical axis (RGB-D cameras)
  radial,   ///< distance along the pixel's ray (time-of-flight cameras such as the SR4000)
};

/// The frame in which converted points are expressed.
enum class CameraFrame {
  body,     ///< robot convention: x along the optical axis, y left, z up
  optical,  ///< computer-vision convention: x right, y down, z along the optical axis
};

/// An organised range image: one depth per pixel (row-major), its camera's intrinsics, and an
/// optional amplitude channel (ToF cameras).
template <std::floating_point Scalar = double>
struct DepthImage {
  PinholeIntrinsics<Scalar> intrinsics{};  ///< the camera's pinhole model
  DepthKind kind{DepthKind::radial};       ///< what the depth is measured along
  std::vector<Scalar> depth;               ///< row-major, width*height; NaN, inf or <= 0 is invalid
  std::vector<Scalar> amplitude;           ///< empty, or row-major width*height
  double timestamp{0.0};                   ///< s, when the frame was taken

  /// Pixels per row.
  [[nodiscard]] std::size_t width() const { return intrinsics.width; }
  /// Rows.
  [[nodiscard]] std::size_t height() const { return intrinsics.height; }
  /// The depth at (row, col).
  [[nodiscard]] Scalar at(std::size_t row, std::size_t col) const {
    return depth[row * intrinsics.width + col];
  }
  /// True for a finite, positive depth.
  [[nodiscard]] static bool is_valid_depth(Scalar d) { return std::isfinite(d) && d > Scalar(0); }

  /// Throws invalid_argument when the intrinsics are invalid or the channel sizes disagree with
  /// width x height; `where` names the caller in the message.
  void validate(std::string_view where = "DepthImage") const {
    intrinsics.validate(where);
    const std::size_t n = intrinsics.width * intrinsics.height;
    if (depth.size() != n)
      detail::throw_invalid_argument(where, "depth.size()", depth.size(),
                                     "must equal width*height = " + std::to_string(n));
    if (!amplitude.empty() && amplitude.size() != n)
      detail::throw_invalid_argument(where, "amplitude.size()", amplitude.size(),
                                     "must be 0 or width*height = " + std::to_string(n));
  }

  /// The point seen by pixel (row, col) at distance d (any d, valid or not), in `frame`.
  [[nodiscard]] Point<3, Scalar> pixel_point(std::size_t row, std::size_t col, Scalar d,
                                             CameraFrame frame = CameraFrame::body) const {
    Point<3, Scalar> ray = intrinsics.optical_ray(row, col);
    Point<3, Scalar> p = kind == DepthKind::z_depth ? Point<3, Scalar>(ray * d)
                                                    : Point<3, Scalar>(ray.normalized() * d);
    if (frame == CameraFrame::optical) return p;
    return {p.z(), -p.x(), -p.y()};
  }
};

/// Converts a depth image into an organised cloud (width x height, row-major). Invalid pixels
/// become NaN points; the amplitude channel, when present, becomes the intensities.
template <std::floating_point Scalar>
[[nodiscard]] Cloud<3, Scalar> to_organized_cloud(const DepthImage<Scalar>& image,
                                                  CameraFrame frame = CameraFrame::body) {
  image.validate("to_organized_cloud");
  Cloud<3, Scalar> cloud;
  cloud.width = image.width();
  cloud.height = image.height();
  cloud.points.resize(image.depth.size());
  constexpr Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
  for (std::size_t r = 0; r < image.height(); ++r)
    for (std::size_t c = 0; c < image.width(); ++c) {
      const Scalar d = image.at(r, c);
      cloud.points[r * cloud.width + c] = DepthImage<Scalar>::is_valid_depth(d)
                                              ? image.pixel_point(r, c, d, frame)
                                              : Point<3, Scalar>::Constant(nan);
    }
  if (!image.amplitude.empty())
    cloud.intensities.assign(image.amplitude.begin(), image.amplitude.end());
  return cloud;
}

}  // namespace rangenav
