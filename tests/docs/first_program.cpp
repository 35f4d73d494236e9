// The program of docs/getting_started.md ("Your first program"), compiled into test_docs as the
// page shows it; its main() is renamed so that the test case below can run it.
#define main first_program_main
// [snippet:first-program]
#include <cstdio>
#include <random>
#include <string>

#include <rangenav/rangenav.hpp>

int main() {
  // A simulated apartment and a SICK S300-like 2D laser: no data files needed.
  const rangenav::sim::Scene scene = rangenav::sim::apartment();
  const rangenav::sim::LaserScanner2D laser;
  std::mt19937 rng(42);  // every reading is reproducible for a seed

  // Two scans, the second taken 0.2 m further on and turned by 5 degrees.
  const rangenav::Pose2d motion{0.2, 0.0, rangenav::deg_to_rad(5.0)};
  const auto first = laser.scan(scene.world, scene.start, rng);
  const auto second = laser.scan(scene.world, rangenav::compose(scene.start, motion), rng);

  // Where was the second scan taken, seen from the first? ICP from the identity.
  rangenav::PaperIcp<2> icp;  // decaying distance threshold + unique pairs (paper 000 §3.1)
  const auto result = icp.align(rangenav::KdTree<2, double>(first), second);
  const auto found = rangenav::Pose2d::from_isometry(result.transform);
  std::printf("%s after %d iterations: x = %.3f m, y = %.3f m, theta = %.2f deg\n",
              std::string(rangenav::to_string(result.reason)).c_str(), result.iterations, found.x,
              found.y, rangenav::rad_to_deg(found.theta));
  const bool within_1cm = (found.position() - motion.position()).norm() < 0.01;
  return result.converged && within_1cm ? 0 : 1;
}
// [snippet-end]
#undef main

#include <catch2/catch.hpp>

TEST_CASE("getting started: the first program finds the motion within 1 cm", "[docs]") {
  CHECK(first_program_main() == 0);
}
