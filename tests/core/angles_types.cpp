#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <random>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/types.hpp"

using namespace rangenav;
constexpr double pi = std::numbers::pi;

TEST_CASE("normalize_angle wraps into (-pi, pi]", "[core][angles]") {
  CHECK(normalize_angle(0.0) == 0.0);
  CHECK(normalize_angle(pi) == Approx(pi));
  CHECK(normalize_angle(-pi) == Approx(pi));  // -pi is outside the half-open interval
  CHECK(normalize_angle(3 * pi) == Approx(pi));
  CHECK(normalize_angle(2 * pi + 0.25) == Approx(0.25));
  CHECK(normalize_angle(-2 * pi - 0.25) == Approx(-0.25));
  CHECK(normalize_angle(1e6) == Approx(std::remainder(1e6, 2 * pi)).margin(1e-9));
  CHECK(std::isnan(normalize_angle(std::nan(""))));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> any(-100, 100);
  for (int i = 0; i < 1000; ++i) {
    const double a = any(rng);
    const double w = normalize_angle(a);
    REQUIRE(w > -pi);
    REQUIRE(w <= pi);
    REQUIRE(std::cos(w) == Approx(std::cos(a)).margin(1e-9));
    REQUIRE(std::sin(w) == Approx(std::sin(a)).margin(1e-9));
  }
  CHECK(normalize_angle(7.0f) == Approx(7.0 - 2 * pi).margin(1e-5));
}

TEST_CASE("angle_difference and degree conversion", "[core][angles]") {
  CHECK(angle_difference(deg_to_rad(170.0), deg_to_rad(-170.0)) == Approx(deg_to_rad(-20.0)));
  CHECK(angle_difference(deg_to_rad(-170.0), deg_to_rad(170.0)) == Approx(deg_to_rad(20.0)));
  CHECK(rad_to_deg(pi / 2) == Approx(90.0));
  static_assert(deg_to_rad(180.0) == std::numbers::pi);
}

TEST_CASE("Pose2 <-> Isometry2 round trip", "[core][types]") {
  const Pose2d p{1.5, -2.0, 2.5};
  const Transform2d t = p.to_isometry();
  const Pose2d back = Pose2d::from_isometry(t);
  CHECK(back.x == Approx(1.5));
  CHECK(back.y == Approx(-2.0));
  CHECK(back.theta == Approx(2.5));
  const Point2d q(0.3, 0.7);
  CHECK((t * q - p.transform_point(q)).norm() == Approx(0.0).margin(1e-12));
  CHECK(is_rigid(t));
  CHECK(rotation_angle(t) == Approx(2.5));
}

TEST_CASE("SE(2) compose, inverse and relative agree with matrix products", "[core][types]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> xy(-10, 10), th(-pi, pi);
  for (int i = 0; i < 200; ++i) {
    const Pose2d a{xy(rng), xy(rng), th(rng)}, b{xy(rng), xy(rng), th(rng)};
    const Transform2d ab = a.to_isometry() * b.to_isometry();
    const Pose2d c = a * b;
    REQUIRE((c.to_isometry().matrix() - ab.matrix()).norm() == Approx(0).margin(1e-9));
    const Pose2d id = compose(a, inverse(a));
    REQUIRE(std::hypot(id.x, id.y) == Approx(0).margin(1e-9));
    REQUIRE(id.theta == Approx(0).margin(1e-12));
    const Pose2d r = relative(a, b);
    const Pose2d b2 = a * r;
    REQUIRE(b2.x == Approx(b.x));
    REQUIRE(b2.y == Approx(b.y));
    REQUIRE(angle_difference(b2.theta, b.theta) == Approx(0).margin(1e-9));
  }
}

TEST_CASE("is_rigid rejects non-rigid and non-finite transforms", "[core][types]") {
  Transform3d t = Transform3d::Identity();
  CHECK(is_rigid(t));
  t.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  CHECK(is_rigid(t));
  CHECK(rotation_angle(t) == Approx(0.3));
  Transform3d scaled = t;
  scaled.linear() *= 1.1;
  CHECK_FALSE(is_rigid(scaled));
  Transform3d reflected = Transform3d::Identity();
  reflected.linear()(2, 2) = -1;
  CHECK_FALSE(is_rigid(reflected));
  Transform3d bad = t;
  bad.translation().x() = std::nan("");
  CHECK_FALSE(is_rigid(bad));
}
