#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "pose_graph_support.hpp"
#include "rangenav/core/lie.hpp"
#include "rangenav/pose_graph/relative_pose_error.hpp"

using namespace rangenav;

namespace {

// The analytic Jacobians of g2o's error against central differences, through the optimiser's
// own chain (∂e/∂δb = J_E, ∂e/∂δa = −J_E·Ad(A⁻¹)) with the right retraction.
template <int D>
void check_jacobians() {
  constexpr int k = lie::pose_dof<D>;
  std::mt19937 rng(21);
  for (int trial = 0; trial < 100; ++trial) {
    const Transform<D> xa = lie::se_exp<D>(test::random_tangent<D>(3.0, 1.0, rng));
    const Transform<D> xb = lie::se_exp<D>(test::random_tangent<D>(3.0, 1.0, rng));
    // A measurement near the truth, as during optimisation, and a far one.
    const Transform<D> z = (xa.inverse() * xb) * lie::se_exp<D>(test::random_tangent<D>(
                                                     0.3, trial < 50 ? 0.2 : 1.2, rng));
    const Transform<D> z_inv = z.inverse();
    const auto error = [&](const Transform<D>& a, const Transform<D>& b) {
      return relative_pose_error<D, double>(z_inv * (a.inverse() * b));
    };
    lie::PoseTangent<D> e;
    lie::PoseMatrix<D> je;
    const Transform<D> a_to_b = xa.inverse() * xb;
    relative_pose_error<D, double>(z_inv * a_to_b, e, je);
    CHECK((e - error(xa, xb)).norm() < 1e-14);
    const lie::PoseMatrix<D> jb = je;
    const lie::PoseMatrix<D> ja = -je * lie::se_adjoint<D>(Transform<D>(a_to_b.inverse()));
    const double h = 1e-6;
    for (int c = 0; c < k; ++c) {
      const lie::PoseTangent<D> d = h * lie::PoseTangent<D>::Unit(c);
      const lie::PoseTangent<D> numeric_b = (error(xa, lie::retract_right<D>(xb, d)) -
                                             error(xa, lie::retract_right<D>(xb, (-d).eval()))) /
                                            (2 * h);
      const lie::PoseTangent<D> numeric_a = (error(lie::retract_right<D>(xa, d), xb) -
                                             error(lie::retract_right<D>(xa, (-d).eval()), xb)) /
                                            (2 * h);
      CHECK((numeric_b - jb.col(c)).norm() < 1e-7);
      CHECK((numeric_a - ja.col(c)).norm() < 1e-7);
    }
  }
}

// The information from a covariance over (translation, rotation vector) makes χ² of errors drawn
// from that covariance average the number of degrees of freedom (E[χ²] = K for a correct
// information), which checks the ½ between rotation vector and quaternion vector part in 3D.
template <int D>
void check_covariance_conversion() {
  constexpr int k = lie::pose_dof<D>;
  std::mt19937 rng(4);
  std::normal_distribution<double> normal(0.0, 1.0);
  // A correlated covariance: A·Aᵀ with small entries.
  lie::PoseMatrix<D> a;
  for (int i = 0; i < k * k; ++i)
    a(i / k, i % k) = 0.02 * normal(rng);
  const lie::PoseMatrix<D> covariance = a * a.transpose() + 1e-4 * lie::PoseMatrix<D>::Identity();
  const lie::PoseMatrix<D> information = information_from_covariance<D, double>(covariance);
  CHECK((covariance_from_information<D, double>(information) - covariance).norm() <
        1e-9 * covariance.norm());
  const Eigen::LLT<lie::PoseMatrix<D>> llt(covariance);
  double sum = 0;
  const int samples = 20000;
  for (int s = 0; s < samples; ++s) {
    lie::PoseTangent<D> w;
    for (int i = 0; i < k; ++i)
      w(i) = normal(rng);
    const lie::PoseTangent<D> xi = llt.matrixL() * w;  // ~ N(0, covariance)
    const lie::PoseTangent<D> e = relative_pose_error<D, double>(lie::se_exp<D>(xi));
    sum += e.dot(information * e);
  }
  // The mean of χ²_k over n samples has standard deviation √(2k/n).
  CHECK(std::abs(sum / samples - k) < 4 * std::sqrt(2.0 * k / samples));
}

}  // namespace

TEST_CASE("relative pose error: analytic Jacobians match central differences",
          "[pose_graph][jacobian]") {
  check_jacobians<2>();
  check_jacobians<3>();
}

TEST_CASE("relative pose error: g2o's 3D error uses the quaternion with w >= 0", "[pose_graph]") {
  // A rotation by 350° about z is a rotation by −10°: error vector part −sin(5°) along z.
  Transform3d e = Transform3d::Identity();
  e.linear() = Eigen::AngleAxisd(350.0 * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const auto r = relative_pose_error<3, double>(e);
  CHECK(r(5) == Approx(-std::sin(5.0 * M_PI / 180)));
  const auto r2 = relative_pose_error<2, double>(make_transform2(1.0, 2.0, 3.5));
  CHECK(r2(2) == Approx(3.5 - 2 * M_PI));
}

TEST_CASE("relative pose error: information from a covariance is consistent with it",
          "[pose_graph]") {
  check_covariance_conversion<2>();
  check_covariance_conversion<3>();
  lie::PoseMatrix<3> bad = lie::PoseMatrix<3>::Identity();
  bad(0, 0) = -1;
  CHECK_THROWS_AS((information_from_covariance<3, double>(bad)), invalid_argument);
  bad(0, 0) = 1;
  bad(0, 1) = 0.5;
  CHECK_THROWS_AS((information_from_covariance<3, double>(bad)), invalid_argument);
}
