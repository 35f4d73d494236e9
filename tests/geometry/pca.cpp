#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <vector>

#include "rangenav/geometry/pca.hpp"

using namespace rangenav;

TEST_CASE("PCA of points on a tilted plane: mean, covariance and normal in closed form",
          "[geometry]") {
  // A 5 x 5 grid of spacing 1 on the plane spanned by u and v through c: mean c, covariance
  // 2 (u u^T + v v^T) (the variance of {-2, ..., 2} is 2), eigenvalues (0, 2, 2), normal u x v.
  const Eigen::Vector3d u = Eigen::Vector3d(1, 1, 0).normalized();
  const Eigen::Vector3d v = Eigen::Vector3d(-1, 1, 1).normalized();
  const Eigen::Vector3d c(3, -2, 7);
  std::vector<Eigen::Vector3d> pts;
  for (int i = -2; i <= 2; ++i)
    for (int j = -2; j <= 2; ++j)
      pts.push_back(c + i * u + j * v);
  const auto fit = fit_pca<3, double>(pts);
  CHECK(fit.count == 25);
  CHECK((fit.mean - c).norm() < 1e-12);
  CHECK((fit.covariance - 2 * (u * u.transpose() + v * v.transpose())).norm() < 1e-12);
  CHECK(fit.eigenvalues(0) == Approx(0).margin(1e-12));
  CHECK(fit.eigenvalues(1) == Approx(2));
  CHECK(fit.eigenvalues(2) == Approx(2));
  CHECK(std::abs(fit.normal().dot(u.cross(v))) == Approx(1));
  CHECK(fit.normal_rms() == Approx(0).margin(1e-6));
}

TEST_CASE("PCA of a noisy 2D line: direction, normal and RMS distance", "[geometry]") {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> along(-5, 5);
  std::normal_distribution<double> noise(0, 0.01);
  const Eigen::Vector2d dir = Eigen::Vector2d(3, 4).normalized(), n(-dir.y(), dir.x());
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < 20000; ++i)
    pts.push_back(along(rng) * dir + noise(rng) * n);
  const auto fit = fit_pca<2, double>(pts);
  CHECK(std::abs(fit.principal_direction().dot(dir)) == Approx(1).margin(1e-6));
  CHECK(std::abs(fit.normal().dot(n)) == Approx(1).margin(1e-6));
  CHECK(fit.normal_rms() == Approx(0.01).epsilon(0.03));
  // Uniform on [-5, 5]: variance 100 / 12.
  CHECK(fit.eigenvalues(1) == Approx(100.0 / 12).epsilon(0.03));
  // The same fit through an index map (the neighbour lists of normal estimation).
  const auto by_index = fit_pca<2, double>(
      pts.size(), [&](std::size_t i) -> const Eigen::Vector2d& { return pts[i]; });
  CHECK(by_index.covariance == fit.covariance);
}

TEST_CASE("PCA of a given covariance is its eigen decomposition", "[geometry]") {
  Eigen::Matrix3d cov = Eigen::Vector3d(4, 1, 9).asDiagonal();
  const auto fit = pca_of_covariance<3, double>(Eigen::Vector3d(1, 2, 3), cov, 7);
  CHECK(fit.count == 7);
  CHECK(fit.eigenvalues.isApprox(Eigen::Vector3d(1, 4, 9)));
  CHECK(std::abs(fit.normal().y()) == Approx(1));
  CHECK(std::abs(fit.principal_direction().z()) == Approx(1));
  CHECK((fit.eigenvectors * fit.eigenvalues.asDiagonal() * fit.eigenvectors.transpose())
            .isApprox(cov));
}
