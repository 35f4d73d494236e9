#include <array>
#include <catch2/catch.hpp>
#include <deque>
#include <list>
#include <span>
#include <string>
#include <vector>

#include "rangenav/core/cloud.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"

namespace user {
struct Pixel2 {
  float x, y;
};
struct Lidar3 {
  double x, y, z;
  float intensity;
};
struct NotRegistered {
  double x, y;
};
}  // namespace user

RANGENAV_REGISTER_POINT_2D(user::Pixel2, float, x, y);
RANGENAV_REGISTER_POINT_3D(user::Lidar3, double, x, y, z);

using namespace rangenav;

// ---- static conformance table (see mp-units' test/static) ----------------------------------
static_assert(PointCloud<std::vector<Eigen::Vector2d>>);
static_assert(PointCloud<std::vector<Eigen::Vector3f>>);
static_assert(PointCloud<std::vector<Eigen::Vector2d, Eigen::aligned_allocator<Eigen::Vector2d>>>);
static_assert(PointCloud<std::array<Eigen::Vector3d, 4>>);
static_assert(PointCloud<std::span<const Eigen::Vector3d>>);
static_assert(PointCloud<std::deque<Eigen::Vector2f>>);
static_assert(PointCloud<Eigen::Matrix<double, 2, Eigen::Dynamic>>);
static_assert(PointCloud<Eigen::Matrix3Xf>);
static_assert(PointCloud<std::vector<user::Pixel2>>);
static_assert(PointCloud<std::vector<user::Lidar3>>);
static_assert(PointCloud<Cloud3d>);
static_assert(PointCloudOf<std::vector<Eigen::Vector2d>, 2>);
static_assert(PointCloudOf<Eigen::Matrix3Xd, 3>);
static_assert(!PointCloudOf<Eigen::Matrix3Xd, 2>);
static_assert(traits::dimension_v<std::vector<user::Lidar3>> == 3);
static_assert(std::is_same_v<traits::scalar_t<std::vector<user::Pixel2>>, float>);

static_assert(!PointCloud<std::vector<Eigen::Vector4d>>);              // wrong dimension
static_assert(!PointCloud<std::vector<Eigen::VectorXd>>);              // dynamic size
static_assert(!PointCloud<Eigen::Matrix<double, 4, Eigen::Dynamic>>);  // 4 rows
static_assert(!PointCloud<Eigen::MatrixXd>);                           // dynamic rows
static_assert(!PointCloud<std::vector<double>>);                       // scalars
static_assert(!PointCloud<std::vector<user::NotRegistered>>);          // not registered
static_assert(!PointCloud<std::list<Eigen::Vector2d>>);                // not random access
static_assert(!PointCloud<Eigen::Vector3d>);                           // a point, not a cloud
static_assert(!PointCloud<int>);

template <PointCloud C>
auto centroid(const C& c) {
  cloud_point_t<C> sum = cloud_point_t<C>::Zero();
  for (std::size_t i = 0; i < traits::size(c); ++i)
    sum += traits::point(c, i);
  return (sum / static_cast<traits::scalar_t<C>>(traits::size(c))).eval();
}

TEST_CASE("adaptors expose the same points", "[core][point_cloud]") {
  const std::vector<Eigen::Vector2d> v{{0, 0}, {2, 0}, {2, 4}, {0, 4}};
  Eigen::Matrix2Xd m(2, 4);
  for (int i = 0; i < 4; ++i)
    m.col(i) = v[static_cast<std::size_t>(i)];
  const std::vector<user::Pixel2> px{{0, 0}, {2, 0}, {2, 4}, {0, 4}};
  CHECK(traits::size(v) == 4);
  CHECK(traits::size(m) == 4);
  CHECK(traits::size(px) == 4);
  CHECK(centroid(v).isApprox(Eigen::Vector2d(1, 2)));
  CHECK(centroid(m).isApprox(Eigen::Vector2d(1, 2)));
  CHECK(centroid(px).isApprox(Eigen::Vector2f(1, 2)));
  CHECK(traits::point(m, 2) == Eigen::Vector2d(2, 4));
  const std::span<const Eigen::Vector2d> s(v);
  CHECK(traits::point(s, 3) == Eigen::Vector2d(0, 4));
}

TEST_CASE("finite_points drops NaN and inf", "[core][point_cloud]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<user::Lidar3> c{{1, 2, 3, 0}, {nan, 0, 0, 0}, {0, inf, 0, 0}, {4, 5, 6, 0}};
  const auto f = finite_points(c);
  REQUIRE(f.size() == 2);
  CHECK(f[1] == Eigen::Vector3d(4, 5, 6));
}

TEST_CASE("Cloud validates attribute sizes", "[core][cloud]") {
  Cloud3d c;
  c.points = {{0, 0, 0}, {1, 1, 1}};
  c.width = 2;
  CHECK_NOTHROW(c.validate());
  c.intensities = {1.0f};
  CHECK_THROWS_WITH(c.validate("test"),
                    "rangenav: test: argument 'intensities' = 1 (attribute count) must be 0 or "
                    "the point count 2");
  c.intensities.clear();
  c.height = 2;
  CHECK_THROWS_AS(c.validate(), invalid_argument);
}

TEST_CASE("errors name the argument and the value", "[core][error]") {
  CHECK_THROWS_WITH(detail::require_positive("VoxelGrid", "leaf_size", -0.5),
                    "rangenav: VoxelGrid: argument 'leaf_size' = -0.5 must be finite and > 0");
  CHECK_THROWS_AS(detail::require_finite("f", "x", std::nan("")), invalid_argument);
  try {
    detail::throw_invalid("Icp::align", "model cloud is empty");
  } catch (const error& e) {
    CHECK(std::string(e.what()) == "rangenav: Icp::align: model cloud is empty");
  }
  static_assert(std::is_base_of_v<std::runtime_error, error>);
  static_assert(std::is_base_of_v<error, invalid_argument>);
  static_assert(std::is_base_of_v<error, io_error>);
}
