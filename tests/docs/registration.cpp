// The snippets of docs/registration.md, compiled and run against the simulated room of
// docs_support.hpp (its motion is the ground truth).

#include <catch2/catch.hpp>
#include "docs_support.hpp"
#include "rangenav/rangenav.hpp"

namespace docs = rangenav::docs_test;

TEST_CASE("docs/registration: align() with settings and with a pose prior", "[docs]") {
  const docs::ScratchDir dir("registration_align");
  const rangenav::Transform3d motion = docs::room_motion();
  docs::write_room_pair(dir.path() / "target.ply", dir.path() / "source.ply", motion);
  const auto target = rangenav::io::read_ply<double>(dir.path() / "target.ply");
  const auto source = rangenav::io::read_ply<double>(dir.path() / "source.ply");
  const rangenav::Transform3d guess = rangenav::Transform3d::Identity();
  const auto error_of = [&](const rangenav::Transform3d& t) {
    return (t.translation() - motion.translation()).norm();
  };
  {
    // [snippet:align-settings]
    rangenav::AlignSettings<double> settings;  // GICP, 1 m correspondence distance
    settings.voxel_size = 0.1;                 // downsample both clouds first
    settings.num_threads = 2;                  // same result as 1 thread, bit for bit
    const auto result = rangenav::align(target, source, guess, settings);
    // result.transform maps source points into the target frame; result.reason says why it
    // stopped; result.information is the inverse covariance of the estimate.
    // [snippet-end]
    REQUIRE(result.converged);
    CHECK(error_of(result.transform) < 0.01);
    REQUIRE(result.information);
  }
  {
    // Odometry: the truth 5 cm off, known to within 10 cm and 0.05 rad.
    rangenav::Transform3d odometry_guess = motion;
    odometry_guess.translation().x() += 0.05;
    rangenav::PoseMatrix<3, double> odometry_information =
        rangenav::PoseMatrix<3, double>::Identity();
    odometry_information.topLeftCorner<3, 3>() /= 0.1 * 0.1;
    odometry_information.bottomRightCorner<3, 3>() /= 0.05 * 0.05;
    rangenav::AlignSettings<double> settings;
    // [snippet:align-prior]
    rangenav::PosePrior<3, double> prior{odometry_guess, odometry_information};
    const auto result = rangenav::align(target, source, odometry_guess, settings, prior);
    // [snippet-end]
    // The room constrains every direction: the data win over the prior.
    REQUIRE(result.converged);
    CHECK(error_of(result.transform) < 0.01);
  }
}
