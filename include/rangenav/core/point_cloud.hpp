#pragma once
// The PointCloud concept and its adaptors.
//
// A type C models PointCloud when rangenav::traits::size(c) and rangenav::traits::point(c, i)
// work and point() yields an Eigen vector of the fixed dimension traits::dimension_v<C> (2 or 3).
// Adaptors ship for
//   - any random-access range of registered point types: std::vector<Eigen::Vector2d> (any
//     allocator), std::array, std::span, std::deque, ... of Eigen vectors, or of a user's struct
//     registered with RANGENAV_REGISTER_POINT_2D / _3D;
//   - Eigen::Matrix<Scalar, D, Eigen::Dynamic> (one point per column);
// and LaserScan adapts itself in rangenav/scan/laser_scan.hpp. For another container, specialise
// rangenav::traits::cloud_access<C> with `dimension`, `Scalar`, `size(c)` and `point(c, i)`.

#include <Eigen/Core>
#include <concepts>
#include <cstddef>
#include <iterator>
#include <ranges>
#include <type_traits>
#include <vector>

#include "rangenav/core/types.hpp"

namespace rangenav::traits {

// ---- points ----------------------------------------------------------------------------------

/// Describes a point type: `dimension`, `Scalar` and `get(p)` returning an Eigen vector.
/// Specialised for fixed-size Eigen column vectors; users register their own structs with
/// RANGENAV_REGISTER_POINT_2D / RANGENAV_REGISTER_POINT_3D.
template <class P>
struct point_access;

template <class S, int D, int Options, int MaxRows, int MaxCols>
/// Fixed-size Eigen column vectors of dimension 2 or 3 are points.
requires(D == 2 || D == 3) struct point_access<Eigen::Matrix<S, D, 1, Options, MaxRows, MaxCols>> {
  /// The point's dimension D.
  static constexpr int dimension = D;
  /// The point's scalar type.
  using Scalar = S;
  /// The point itself.
  static const Eigen::Matrix<S, D, 1, Options, MaxRows, MaxCols>& get(
      const Eigen::Matrix<S, D, 1, Options, MaxRows, MaxCols>& p) {
    return p;
  }
};

template <class P>
concept RegisteredPoint = requires(const P& p) {
  { point_access<P>::dimension } -> std::convertible_to<int>;
  typename point_access<P>::Scalar;
  {
    point_access<P>::get(p)
    } -> std::convertible_to<Point<point_access<P>::dimension, typename point_access<P>::Scalar>>;
};

// ---- clouds ----------------------------------------------------------------------------------

/// Describes a cloud type: `dimension`, `Scalar`, `size(c)` and `point(c, i)`.
template <class C>
struct cloud_access;

template <class T>
struct is_eigen_dense : std::is_base_of<Eigen::DenseBase<T>, T> {};

/// Random-access ranges of registered points (std::vector with any allocator, std::array, ...).
template <class C>
requires(!is_eigen_dense<C>::value && std::ranges::random_access_range<const C> &&
         std::ranges::sized_range<const C> &&
         RegisteredPoint<
             std::remove_cvref_t<std::ranges::range_value_t<const C>>>) struct cloud_access<C> {
  /// The element type of the range.
  using point_type = std::remove_cvref_t<std::ranges::range_value_t<const C>>;
  /// The dimension of the registered point type.
  static constexpr int dimension = point_access<point_type>::dimension;
  /// The scalar type of the registered point type.
  using Scalar = typename point_access<point_type>::Scalar;
  /// Number of points (the range's size).
  static std::size_t size(const C& c) { return static_cast<std::size_t>(std::ranges::size(c)); }
  /// The i-th point as an Eigen vector (or a reference to one).
  static decltype(auto) point(const C& c, std::size_t i) {
    return point_access<point_type>::get(
        std::ranges::begin(c)[static_cast<std::ranges::range_difference_t<const C>>(i)]);
  }
};

/// Eigen matrices with D rows: one point per column.
template <class S, int D, int Options, int MaxRows, int MaxCols>
requires(
    D == 2 ||
    D == 3) struct cloud_access<Eigen::Matrix<S, D, Eigen::Dynamic, Options, MaxRows, MaxCols>> {
  /// The matrix type: D rows, one point per column.
  using matrix_type = Eigen::Matrix<S, D, Eigen::Dynamic, Options, MaxRows, MaxCols>;
  /// The matrix's row count D.
  static constexpr int dimension = D;
  /// The matrix's scalar type.
  using Scalar = S;
  /// Number of points (columns).
  static std::size_t size(const matrix_type& c) { return static_cast<std::size_t>(c.cols()); }
  /// The i-th column.
  static Point<D, S> point(const matrix_type& c, std::size_t i) {
    return c.col(static_cast<Eigen::Index>(i));
  }
};

/// The dimension (2 or 3) of the points of cloud type C.
template <class C>
inline constexpr int dimension_v = cloud_access<std::remove_cvref_t<C>>::dimension;

/// The scalar type of the points of cloud type C.
template <class C>
using scalar_t = typename cloud_access<std::remove_cvref_t<C>>::Scalar;

/// Number of points in the cloud.
template <class C>
[[nodiscard]] std::size_t size(const C& cloud) {
  return cloud_access<std::remove_cvref_t<C>>::size(cloud);
}

/// The i-th point of the cloud as an Eigen vector (or a reference to one).
template <class C>
[[nodiscard]] decltype(auto) point(const C& cloud, std::size_t i) {
  return cloud_access<std::remove_cvref_t<C>>::point(cloud, i);
}

}  // namespace rangenav::traits

namespace rangenav {

/// Anything that yields a number of points of fixed dimension 2 or 3 (see the file comment).
template <class C>
concept PointCloud = requires(const C& c, std::size_t i) {
  { traits::cloud_access<std::remove_cvref_t<C>>::dimension } -> std::convertible_to<int>;
  typename traits::cloud_access<std::remove_cvref_t<C>>::Scalar;
  { traits::size(c) } -> std::convertible_to<std::size_t>;
  {
    traits::point(c, i)
    } -> std::convertible_to<Point<traits::dimension_v<C>, traits::scalar_t<C>>>;
}
&&(traits::dimension_v<C> == 2 || traits::dimension_v<C> == 3);

/// A PointCloud of a given dimension.
template <class C, int D>
concept PointCloudOf = PointCloud<C> && traits::dimension_v<C>
== D;

/// The point type of a cloud: Point<dimension_v<C>, scalar_t<C>>.
template <PointCloud C>
using cloud_point_t = Point<traits::dimension_v<C>, traits::scalar_t<C>>;

/// Copies any PointCloud into a std::vector of Eigen points, skipping non-finite points.
template <PointCloud C>
[[nodiscard]] std::vector<cloud_point_t<C>> finite_points(const C& cloud) {
  std::vector<cloud_point_t<C>> out;
  const std::size_t n = traits::size(cloud);
  out.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    cloud_point_t<C> p = traits::point(cloud, i);
    if (p.allFinite()) out.push_back(p);
  }
  return out;
}

}  // namespace rangenav

/// Registers a user's 2D point struct, e.g. `struct P { float x, y; };`
/// `RANGENAV_REGISTER_POINT_2D(P, float, x, y)` at global scope. Afterwards any random-access
/// range of P (std::vector<P>, std::array<P, N>, ...) is a rangenav::PointCloud.
#define RANGENAV_REGISTER_POINT_2D(Type, ScalarType, field_x, field_y)                 \
  template <>                                                                          \
  struct rangenav::traits::point_access<Type> {                                        \
    static constexpr int dimension = 2;                                                \
    using Scalar = ScalarType;                                                         \
    static ::rangenav::Point<2, ScalarType> get(const Type& p) {                       \
      return {static_cast<ScalarType>(p.field_x), static_cast<ScalarType>(p.field_y)}; \
    }                                                                                  \
  }

/// Registers a user's 3D point struct; see RANGENAV_REGISTER_POINT_2D.
#define RANGENAV_REGISTER_POINT_3D(Type, ScalarType, field_x, field_y, field_z)       \
  template <>                                                                         \
  struct rangenav::traits::point_access<Type> {                                       \
    static constexpr int dimension = 3;                                               \
    using Scalar = ScalarType;                                                        \
    static ::rangenav::Point<3, ScalarType> get(const Type& p) {                      \
      return {static_cast<ScalarType>(p.field_x), static_cast<ScalarType>(p.field_y), \
              static_cast<ScalarType>(p.field_z)};                                    \
    }                                                                                 \
  }
