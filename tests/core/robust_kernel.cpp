#include <catch2/catch.hpp>
#include <cmath>

#include "rangenav/core/error.hpp"
#include "rangenav/core/robust_kernel.hpp"

using namespace rangenav;

TEST_CASE("robust kernels: closed-form values and the IRLS weight is dρ/ds", "[core][robust]") {
  const RobustKernel<double> kernels[] = {{},
                                          RobustKernel<double>::huber(0.5),
                                          RobustKernel<double>::cauchy(0.5),
                                          RobustKernel<double>::geman_mcclure(0.5)};
  for (const auto& k : kernels) {
    INFO(to_string(k.type));
    CHECK(k.rho(0.0) == 0.0);
    CHECK(k.weight(0.0) == Approx(1.0));
    double previous_rho = -1, previous_weight = 2;
    for (double s = 1e-4; s < 100; s *= 1.7) {
      const double h = 1e-6 * s;
      const double derivative = (k.rho(s + h) - k.rho(s - h)) / (2 * h);
      CHECK(k.weight(s) == Approx(derivative).epsilon(1e-5));
      CHECK(k.rho(s) > previous_rho);         // the cost grows with the residual ...
      CHECK(k.weight(s) <= previous_weight);  // ... and the weight never grows
      CHECK(k.rho(s) <= s * (1 + 1e-12));     // never costlier than least squares
      previous_rho = k.rho(s);
      previous_weight = k.weight(s);
    }
  }
  // Closed form at s = 4 (residual 2) with δ = 0.5.
  CHECK(RobustKernel<double>::huber(0.5).rho(4.0) == Approx(2 * 0.5 * 2 - 0.25));
  CHECK(RobustKernel<double>::huber(0.5).weight(4.0) == Approx(0.25));
  CHECK(RobustKernel<double>::huber(0.5).rho(0.2) == Approx(0.2));  // inside δ: least squares
  CHECK(RobustKernel<double>::cauchy(0.5).rho(4.0) == Approx(0.25 * std::log(17.0)));
  CHECK(RobustKernel<double>::cauchy(0.5).weight(4.0) == Approx(1.0 / 17.0));
  CHECK(RobustKernel<double>::geman_mcclure(0.5).rho(4.0) == Approx(0.25 * 4 / 4.25));
  CHECK(RobustKernel<double>::geman_mcclure(0.5).weight(4.0) == Approx(1.0 / (17.0 * 17.0)));
}

TEST_CASE("robust kernels: a bad scale is a clear error", "[core][robust]") {
  CHECK_NOTHROW(RobustKernel<double>{}.validate());
  CHECK_THROWS_AS(RobustKernel<double>::huber(0.0).validate(), invalid_argument);
  CHECK_THROWS_WITH(RobustKernel<double>::cauchy(std::nan("")).validate("Icp"),
                    Catch::Contains("'delta'") && Catch::Contains("Icp"));
}
