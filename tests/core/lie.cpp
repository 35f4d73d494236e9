#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <random>

#include "rangenav/core/lie.hpp"

using namespace rangenav;

namespace {

template <int D>
lie::PoseTangent<D> random_tangent(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  lie::PoseTangent<D> xi;
  for (int k = 0; k < lie::pose_dof<D>; ++k)
    xi(k) = u(rng);
  return xi;
}

// ξ^ = [[φ^, ρ], [0, 0]], the matrix whose exponential Exp(ξ) is.
template <int D>
Eigen::Matrix<double, D + 1, D + 1> hat(const lie::PoseTangent<D>& xi) {
  Eigen::Matrix<double, D + 1, D + 1> m = Eigen::Matrix<double, D + 1, D + 1>::Zero();
  if constexpr (D == 2) {
    m(0, 1) = -xi(2);
    m(1, 0) = xi(2);
  } else {
    m.template topLeftCorner<3, 3>() = lie::skew(xi.template tail<3>());
  }
  m.template topRightCorner<D, 1>() = xi.template head<D>();
  return m;
}

// exp of a matrix by its Taylor series (exact to rounding for the small norms used here).
template <int N>
Eigen::Matrix<double, N, N> matrix_exp(const Eigen::Matrix<double, N, N>& a) {
  Eigen::Matrix<double, N, N> sum = Eigen::Matrix<double, N, N>::Identity(), term = sum;
  for (int k = 1; k < 40; ++k) {
    term = term * a / double(k);
    sum += term;
  }
  return sum;
}

template <int D>
void check_group() {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 200; ++trial) {
    const lie::PoseTangent<D> xi = random_tangent<D>(rng, trial < 100 ? 1.5 : 1e-7);
    const Transform<D> t = lie::se_exp<D>(xi);
    // Exp is the matrix exponential of the hat.
    CHECK((t.matrix() - matrix_exp<D + 1>(hat<D>(xi))).norm() < 1e-12);
    // Log inverts Exp (angles below π).
    CHECK((lie::se_log<D>(t) - xi).norm() < 1e-10);
    // The adjoint: T·Exp(ξ)·T⁻¹ = Exp(Ad(T)·ξ).
    const Transform<D> u = lie::se_exp<D>(random_tangent<D>(rng, 2.0));
    const lie::PoseTangent<D> small = random_tangent<D>(rng, 0.3);
    const Transform<D> lhs = u * lie::se_exp<D>(small) * u.inverse();
    CHECK((lhs.matrix() - lie::se_exp<D>(lie::se_adjoint<D>(u) * small).matrix()).norm() < 1e-12);
    // The right retraction agrees with T·Exp(ξ) to first order: their difference is O(|ξ|²).
    const double h = 1e-4;
    const Transform<D> a = lie::retract_right<D>(u, (h * small).eval());
    const Transform<D> b = u * lie::se_exp<D>((h * small).eval());
    CHECK((a.matrix() - b.matrix()).norm() < 10 * h * h);
    CHECK(is_rigid<D, double>(a, 1e-12));
  }
}

}  // namespace

TEST_CASE("lie: Exp is the matrix exponential, Log its inverse, Ad conjugates", "[core][lie]") {
  check_group<2>();
  check_group<3>();
}

TEST_CASE("lie: SO(3) Log near pi and the rotation of a rotation vector", "[core][lie]") {
  const double pi = std::numbers::pi;
  const Eigen::Vector3d axis = Eigen::Vector3d(1, -2, 0.5).normalized();
  for (const double angle : {pi - 1e-9, pi - 1e-4, 3.0, 1e-12}) {
    const Eigen::Matrix3d r = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
    CHECK((lie::so_log<3>(r) - angle * axis).norm() < 1e-7);
    CHECK((lie::so_exp<3>(Eigen::Vector3d(angle * axis)) - r).norm() < 1e-12);
  }
  CHECK(lie::so_log<2>(Eigen::Matrix2d(Eigen::Rotation2Dd(-3.0).toRotationMatrix()))(0) ==
        Approx(-3.0));
}

TEST_CASE("lie: the left Jacobian is the derivative of Exp's rotation", "[core][lie]") {
  // d/dε Exp(φ + ε)·Exp(φ)ᵀ = (V(φ)·ε)^ to first order, V the left Jacobian (Barfoot Eq. 7.86).
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.2, 1.2);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Vector3d phi(u(rng), u(rng), u(rng));
    const Eigen::Matrix3d v = lie::so_left_jacobian<3>(phi);
    const Eigen::Matrix3d r = lie::so_exp<3>(phi);
    for (int k = 0; k < 3; ++k) {
      const double h = 1e-6;
      const Eigen::Vector3d e = h * Eigen::Vector3d::Unit(k);
      const Eigen::Matrix3d d =
          (lie::so_exp<3>(Eigen::Vector3d(phi + e)) - lie::so_exp<3>(Eigen::Vector3d(phi - e))) /
          (2 * h) * r.transpose();
      CHECK((d - lie::skew(v.col(k))).norm() < 1e-8);
    }
  }
}

TEST_CASE("lie: nearest_rotation projects onto SO(D)", "[core][lie]") {
  std::mt19937 rng(9);
  std::normal_distribution<double> n(0.0, 0.05);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Matrix3d r =
        lie::so_exp<3>(Eigen::Vector3d(n(rng) * 40, n(rng) * 40, n(rng) * 40));
    Eigen::Matrix3d noisy = r;
    for (int i = 0; i < 9; ++i)
      noisy(i / 3, i % 3) += n(rng);
    const Eigen::Matrix3d p = lie::nearest_rotation<3>(noisy);
    CHECK((p.transpose() * p - Eigen::Matrix3d::Identity()).norm() < 1e-12);
    CHECK(p.determinant() == Approx(1.0));
    // No rotation is nearer: perturbing p along any generator increases the distance.
    for (int k = 0; k < 3; ++k) {
      const Eigen::Matrix3d q =
          p * lie::so_exp<3>(Eigen::Vector3d(1e-3 * Eigen::Vector3d::Unit(k)));
      CHECK((q - noisy).norm() >= (p - noisy).norm());
    }
    // A scaled rotation projects onto itself.
    CHECK((lie::nearest_rotation<3>(Eigen::Matrix3d(2.5 * r)) - r).norm() < 1e-12);
  }
  const Eigen::Matrix2d r2 = Eigen::Rotation2Dd(2.0).toRotationMatrix();
  CHECK((lie::nearest_rotation<2>(Eigen::Matrix2d(3 * r2)) - r2).norm() < 1e-12);
}
