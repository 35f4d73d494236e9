// Monte-Carlo localization's bad-input table (issue 21): NaN or overflowing initial poses and
// sigmas, NaN odometry, estimates of an empty filter. Each gives an invalid_argument naming the
// argument; a filter that accepted its input keeps finite particles.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "bad_input.hpp"
#include "rangenav/localization/door_mcl.hpp"
#include "rangenav/localization/mcl.hpp"

using namespace rangenav;
using Catch::Matchers::Contains;
using rangenav::test::error_of;

namespace {
constexpr double qnan = std::numeric_limits<double>::quiet_NaN();
constexpr double inf = std::numeric_limits<double>::infinity();

/// A 10 x 10 m room's walls in a grid, as mapped.
OccupancyGrid room() {
  OccupancyGridParams p;
  p.resolution = 0.1;
  OccupancyGrid g({0, 0}, 100, 100, p);
  for (int k = 0; k < 100; ++k)
    for (const OccupancyGrid::Index& c : {OccupancyGrid::Index(k, 0), OccupancyGrid::Index(k, 99),
                                          OccupancyGrid::Index(0, k), OccupancyGrid::Index(99, k)})
      g.set_log_odds(c, 10.0);
  for (int y = 1; y < 99; ++y)
    for (int x = 1; x < 99; ++x)
      g.set_log_odds({x, y}, -10.0);
  return g;
}

bool finite(const Pose2d& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta);
}
}  // namespace

TEST_CASE("squared_distance_transform: a size whose product wraps is an invalid_argument",
          "[localization][bad]") {
  // 2^32 x 2^32 wraps to 0 = mask.size(): the transform then read far out of bounds.
  CHECK_THAT(error_of<invalid_argument>([] {
               (void)squared_distance_transform({}, std::size_t{1} << 32, std::size_t{1} << 32);
             }),
             Contains("argument 'mask.size()' = 0 must equal width * height = 4294967296 * "
                      "4294967296 (overflows)"));
}

TEST_CASE("MCL: bad initial poses, sigmas and odometry are invalid_arguments",
          "[localization][bad]") {
  const OccupancyGrid grid = room();
  MonteCarloLocalization<> mcl(OdometryMotionModel{}, LikelihoodFieldModel(grid),
                               MclParams{.min_particles = 50, .max_particles = 500});
  std::mt19937_64 rng(3);
  const Eigen::Vector3d sigma(0.2, 0.2, 0.1);
  // estimate() of an empty filter returned (0, 0, 0) silently before.
  CHECK_THAT(error_of<invalid_argument>([&] { (void)mcl.estimate(); }),
             Contains("MonteCarloLocalization::estimate: not initialised"));
  CHECK_THAT(error_of<invalid_argument>([&] { (void)mcl.covariance(); }),
             Contains("not initialised"));
  const auto init = [&](Pose2d mean, Eigen::Vector3d s) {
    return error_of<invalid_argument>([&] { mcl.initialize_gaussian(mean, s, 100, rng); });
  };
  CHECK_THAT(init({qnan, 5, 0}, sigma), Contains("argument 'mean.x' = nan must be finite"));
  CHECK_THAT(init({5, inf, 0}, sigma), Contains("argument 'mean.y' = inf must be finite"));
  CHECK_THAT(init({5, 5, qnan}, sigma), Contains("argument 'mean.theta' = nan"));
  CHECK_THAT(init({5, 5, 0}, {0.2, qnan, 0.1}), Contains("sigma must be finite and >= 0"));
  CHECK_THAT(init({5, 5, 0}, {-1, 0.2, 0.1}), Contains("sigma must be finite and >= 0"));
  CHECK_THAT(init({1.7e308, 5, 0}, {1e308, 0.2, 0.1}),
             Contains("a pose drawn from N(mean, sigma^2) is not finite"));
  CHECK_THAT(error_of<invalid_argument>([&] {
               mcl.initialize_gaussian({5, 5, 0}, sigma, 0, rng);
             }),
             Contains("argument 'count' = 0 must be > 0"));
  CHECK_THAT(error_of<invalid_argument>([&] {
               mcl.initialize_gaussian({5, 5, 0}, sigma, std::size_t{1} << 40, rng);
             }),
             Contains("argument 'count' = 1099511627776 must be <= max_particle_count"));
  CHECK_THAT(
      error_of<invalid_argument>([&] { mcl.initialize_uniform(grid, std::size_t{1} << 40, rng); }),
      Contains("argument 'count' = 1099511627776 must be <= max_particle_count"));
  CHECK_THAT(error_of<invalid_argument>([&] {
               MonteCarloLocalization<>(OdometryMotionModel{}, LikelihoodFieldModel(grid),
                                        MclParams{.max_particles = std::size_t{1} << 40});
             }),
             Contains("argument 'max_particles' = 1099511627776"));
  CHECK_THAT(error_of<invalid_argument>([&] { mcl.initialize_uniform(grid, 100, rng, qnan); }),
             Contains("argument 'free_probability' = nan must be in (0, 1]"));

  // A sigma of 1e300 is finite: the particles are spread absurdly, and the filter stays finite
  // (the KLD bins of such poses saturated an overflowing conversion before).
  const LaserScand scan(-1.5, 0.1, 0.05, 30.0, std::vector<double>(31, 3.0));
  CHECK_THAT(error_of<invalid_argument>([&] {
               (void)mcl.sensor_model().prepare(scan, Pose2d{0, qnan, 0});
             }),
             Contains("LikelihoodFieldModel::prepare: argument 'sensor_pose.y' = nan"));
  const auto z = mcl.sensor_model().prepare(scan);
  mcl.initialize_gaussian({5, 5, 0}, {1e300, 1e300, 1e300}, 100, rng);
  (void)mcl.update(OdometryReading{{0, 0, 0}, {0.1, 0, 0}}, z, rng);
  CHECK(finite(mcl.estimate()));

  mcl.initialize_gaussian({5, 5, 0}, sigma, 100, rng);
  const auto update = [&](OdometryReading u) {
    return error_of<invalid_argument>([&] { (void)mcl.update(u, z, rng); });
  };
  // A NaN odometry reading turned every particle NaN before.
  CHECK_THAT(update({{0, 0, 0}, {qnan, 0, 0}}),
             Contains("MonteCarloLocalization::update: argument 'u.current.x' = nan"));
  CHECK_THAT(update({{0, 0, inf}, {0, 0, 0}}), Contains("argument 'u.previous.theta' = inf"));
  CHECK_THAT(update({{-1e308, 0, 0}, {1e308, 0, 0}}),
             Contains("the odometry increment u.current - u.previous overflows"));
  for (const auto& p : mcl.filter().particles())
    REQUIRE(finite(p.state));
  (void)mcl.update(OdometryReading{{0, 0, 0}, {0.1, 0, 0}}, z, rng);
  CHECK(finite(mcl.estimate()));
  CHECK(mcl.covariance().allFinite());
}

TEST_CASE("Door-aware MCL: bad poses, odometry and door indices are invalid_arguments",
          "[localization][bad]") {
  const OccupancyGrid grid = room();
  DoorModel door;
  door.hinge = {5, 0.1};
  door.reference_angle = 0;
  door.leaf_length = 0.9;
  door.opening_min = 0;
  door.opening_max = 1.5;
  const std::vector<DoorModel> doors{door};
  DoorAwareMclParams params;
  params.sampling.min_particles = 50;
  params.sampling.max_particles = 500;
  for (const auto& [what, bad] :
       std::vector<std::pair<const char*, DoorModel>>{{"a NaN hinge",
                                                       [&] {
                                                         DoorModel d = door;
                                                         d.hinge.x() = qnan;
                                                         return d;
                                                       }()},
                                                      {"no leaf",
                                                       [&] {
                                                         DoorModel d = door;
                                                         d.leaf_length = 0;
                                                         return d;
                                                       }()},
                                                      {"an inverted range", [&] {
                                                         DoorModel d = door;
                                                         d.opening_min = 2;
                                                         return d;
                                                       }()}}) {
    INFO(what);
    const std::vector<DoorModel> bad_doors{door, bad};
    CHECK_THAT(error_of<invalid_argument>([&] { DoorAwareMcl(grid, bad_doors, params); }),
               Contains("DoorAwareMcl: argument 'doors[k]' = 1 needs a finite hinge"));
  }
  DoorAwareMcl mcl(grid, doors, params);
  std::mt19937_64 rng(5);
  CHECK_THAT(error_of<invalid_argument>([&] { (void)mcl.estimate(); }),
             Contains("DoorAwareMcl::estimate: not initialised"));
  CHECK_THAT(error_of<invalid_argument>([&] { (void)mcl.door_angle(0); }),
             Contains("not initialised"));
  CHECK_THAT(error_of<invalid_argument>([&] {
               mcl.initialize_gaussian({qnan, 5, 0}, {0.1, 0.1, 0.1}, 100, rng);
             }),
             Contains("DoorAwareMcl::initialize_gaussian: argument 'mean.x' = nan"));
  mcl.initialize_gaussian({5, 5, 0}, {0.1, 0.1, 0.1}, 100, rng);
  CHECK_THAT(error_of<invalid_argument>([&] { (void)mcl.door_angle(1); }),
             Contains("argument 'k' = 1 must be < doors().size() = 1"));
  CHECK_THAT(error_of<invalid_argument>([&] { (void)mcl.door_estimate(16); }),
             Contains("argument 'k' = 16"));
  const LaserScand scan(-1.5, 0.1, 0.05, 30.0, std::vector<double>(31, 3.0));
  DoorAwareObservation z;
  mcl.prepare(scan, {}, z);
  CHECK_THAT(error_of<invalid_argument>([&] {
               mcl.update(OdometryReading{{0, 0, 0}, {0, qnan, 0}}, z, rng);
             }),
             Contains("DoorAwareMcl::update: argument 'u.current.y' = nan"));
  mcl.update(OdometryReading{{0, 0, 0}, {0.1, 0, 0}}, z, rng);
  CHECK(finite(mcl.estimate()));
  CHECK(std::isfinite(mcl.door_angle(0)));
}
