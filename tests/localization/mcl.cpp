#include "rangenav/localization/mcl.hpp"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "rangenav/io/carmen.hpp"
#include "rangenav/sim/robot.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"
#include "test_support.hpp"

using namespace rangenav;

namespace {

/// The laser of issue 8's figures: 181 beams over 180 deg.
sim::LaserScanner2D laser_181() {
  sim::LaserScannerParams p;
  p.geometry = ScanGeometry<double>::from_fov(std::numbers::pi, deg_to_rad(1.0), 0.05, 30.0);
  return sim::LaserScanner2D(p);
}

/// A grid of a world mapped with true poses along the corridor's centre line, both ways.
OccupancyGrid corridor_map(const sim::World& world) {
  OccupancyGrid grid = OccupancyGrid::covering({0, -4}, {20, 6}, 0.5);
  const sim::LaserScanner2D laser;  // 270 deg for mapping
  std::mt19937_64 rng(11);
  for (int pass = 0; pass < 2; ++pass)
    for (int k = 0; k <= 94; ++k) {
      const double x = pass == 0 ? 0.6 + 0.2 * k : 19.4 - 0.2 * k;
      const Pose2d pose{x, 1.0, pass == 0 ? 0.0 : std::numbers::pi};
      grid.integrate(pose, laser.scan(world, pose, rng));
    }
  return grid;
}

struct Run {
  std::vector<double> position_errors;
  std::vector<double> heading_errors;
  std::vector<Pose2d> estimates;
  std::vector<std::size_t> particle_counts;
};

enum class Start { tracking, global };

/// Drives the robot along the corridor (y = 1) from `start` with noisy odometry and runs MCL on
/// a scan every 0.2 s.
Run drive(const sim::World& world, const OccupancyGrid& grid, const Pose2d& start, double x_end,
          Start how, std::size_t particles, std::uint64_t seed,
          const LikelihoodFieldParams& lp = {}, std::size_t global_min_particles = 5000) {
  sim::DifferentialDriveParams rp;
  rp.odometry.v_scale = 0.03;
  rp.odometry.omega_bias = 0.02;
  rp.odometry.v_sigma = 0.05;
  rp.odometry.omega_sigma = 0.05;
  sim::DifferentialDriveRobot robot(rp, start);
  const auto laser = laser_181();
  OdometryMotionParams mp;
  mp.alpha1 = 0.1;
  mp.alpha2 = 0.05;
  mp.alpha3 = 0.1;
  mp.alpha4 = 0.05;
  MclParams params;
  params.min_particles = how == Start::global ? global_min_particles : particles;
  params.max_particles = particles;
  MonteCarloLocalization<> mcl(OdometryMotionModel(mp), LikelihoodFieldModel(grid, lp), params);
  std::mt19937_64 sim_rng(seed), rng(seed + 1);
  if (how == Start::tracking)
    mcl.initialize_gaussian(start, {0.05, 0.05, 0.02}, particles, rng);
  else
    mcl.initialize_uniform(grid, particles, rng);
  LikelihoodFieldModel::Observation z;
  Run run;
  Pose2d last_odometry = robot.odometry();
  const double direction = x_end > start.x ? 1.0 : -1.0;
  while ((x_end - robot.pose().x) * direction > 0) {
    for (int k = 0; k < 10; ++k) {
      const Pose2d& p = robot.pose();
      const double heading = direction > 0 ? 0.0 : std::numbers::pi;
      const double lateral = (p.y - 1.0) * direction;
      robot.step(world, 0.5, -1.5 * lateral - 2.0 * normalize_angle(p.theta - heading), sim_rng);
    }
    mcl.sensor_model().prepare(laser.scan(world, robot.pose(), sim_rng), Pose2d{}, z);
    mcl.update(OdometryReading{last_odometry, robot.odometry()}, z, rng);
    last_odometry = robot.odometry();
    const Pose2d e = mcl.estimate();
    run.estimates.push_back(e);
    run.position_errors.push_back(std::hypot(e.x - robot.pose().x, e.y - robot.pose().y));
    run.heading_errors.push_back(std::abs(normalize_angle(e.theta - robot.pose().theta)));
    run.particle_counts.push_back(mcl.particle_count());
  }
  return run;
}

double mean(const std::vector<double>& v, std::size_t from = 0) {
  double s = 0;
  for (std::size_t i = from; i < v.size(); ++i)
    s += v[i];
  return s / static_cast<double>(v.size() - from);
}

}  // namespace

TEST_CASE("particle filter: low-variance resampling keeps proportions exactly", "[localization]") {
  const std::vector<double> xs = {0, 1, 2, 3};
  ParticleFilter<double> pf(xs);
  auto& ps = pf.particles();
  const double w[] = {0.5, 0.25, 0.25, 0.0};
  for (std::size_t i = 0; i < 4; ++i)
    ps[i].weight = w[i];
  CHECK(pf.effective_sample_size() == Approx(1.0 / (0.25 + 0.0625 + 0.0625)));
  for (std::uint64_t seed = 0; seed < 20; ++seed) {
    ParticleFilter<double> q = pf;
    std::mt19937_64 rng(seed);
    q.resample(4, rng);  // pointers r, r + 1/4, r + 1/2, r + 3/4 with r in [0, 1/4)
    std::vector<double> got;
    for (const auto& p : q.particles())
      got.push_back(p.state);
    CHECK(got == std::vector<double>{0, 0, 1, 2});
    for (const auto& p : q.particles())
      CHECK(p.weight == Approx(0.25));
  }
  std::mt19937_64 rng(1);
  CHECK_THROWS_WITH(pf.resample(0, rng),
                    "rangenav: ParticleFilter::resample: argument 'count' = 0 must be > 0");
  CHECK_THROWS_WITH(pf.reset(std::vector<double>{}),
                    "rangenav: ParticleFilter::reset: states is empty");
}

namespace {
struct GaussianSensor {  // log N(z; x, 1)
  [[nodiscard]] double log_likelihood(double x, double z) const { return -0.5 * (z - x) * (z - x); }
};
struct ShiftMotion {
  template <class E>
  [[nodiscard]] double sample(double x, double u, E&) const {
    return x + u;
  }
};
static_assert(SensorModel<GaussianSensor, double, double>);
static_assert(!SensorModel<GaussianSensor, Pose2d, double>);
static_assert(MotionModel<ShiftMotion, double, double, std::mt19937_64>);
static_assert(MotionModel<OdometryMotionModel, Pose2d, OdometryReading, std::mt19937_64>);
static_assert(!MotionModel<OdometryMotionModel, Pose2d, double, std::mt19937_64>);
static_assert(SensorModel<LikelihoodFieldModel, Pose2d, LikelihoodFieldModel::Observation>);
}  // namespace

TEST_CASE("particle filter: weights follow Bayes' rule for a Gaussian sensor", "[localization]") {
  const std::vector<double> xs = {-1, 0, 1, 2};
  ParticleFilter<double> pf(xs);
  std::mt19937_64 rng(3);
  pf.predict(ShiftMotion{}, 1.0, rng);  // 0, 1, 2, 3
  // Two updates multiply: exp(-(z1 - x)^2 / 2 - (z2 - x)^2 / 2), normalised.
  pf.update(GaussianSensor{}, 1.0);
  pf.update(GaussianSensor{}, 2.0);
  double norm = 0;
  std::vector<double> expected;
  for (const double x : {0.0, 1.0, 2.0, 3.0}) {
    expected.push_back(std::exp(-0.5 * (1 - x) * (1 - x) - 0.5 * (2 - x) * (2 - x)));
    norm += expected.back();
  }
  for (std::size_t i = 0; i < 4; ++i) {
    CHECK(pf.particles()[i].weight == Approx(expected[i] / norm));
    CHECK(pf.particles()[i].log_weight == Approx(std::log(expected[i] / norm)));
  }
  // 2000 beams' worth of log-likelihood does not underflow.
  for (int k = 0; k < 2000; ++k)
    pf.update(GaussianSensor{}, 1.5);
  CHECK(pf.particles()[1].weight == Approx(0.5));
  CHECK(pf.particles()[2].weight == Approx(0.5));
}

TEST_CASE("odometry motion model: exact without noise, Table 5.6 variances with",
          "[localization]") {
  const OdometryReading u{{1, 2, 0.3}, {1.8, 2.5, 0.9}};
  const Pose2d x{-3, 4, -1.0};
  std::mt19937_64 rng(5);
  const OdometryMotionModel exact(OdometryMotionParams{0, 0, 0, 0});
  const Pose2d moved = exact.sample(x, u, rng);
  const Pose2d expected = compose(x, relative(u.previous, u.current));
  CHECK(moved.x == Approx(expected.x));
  CHECK(moved.y == Approx(expected.y));
  CHECK(moved.theta == Approx(expected.theta));
  // A pure translation of 1 m: trans' ~ N(1, alpha3), headings unchanged in the mean.
  const OdometryMotionModel noisy(OdometryMotionParams{0.0, 0.0, 0.04, 0.0});
  const OdometryReading straight{{0, 0, 0}, {1, 0, 0}};
  double s = 0, s2 = 0;
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    const Pose2d p = noisy.sample(Pose2d{}, straight, rng);
    CHECK(p.theta == Approx(0.0).margin(1e-12));
    s += p.x;
    s2 += p.x * p.x;
  }
  const double m = s / n, var = s2 / n - m * m;
  CHECK(m == Approx(1.0).margin(0.005));
  CHECK(var == Approx(0.04).epsilon(0.05));
  // A 5 mm sideways creep without rotation (a stopping robot) is not a quarter turn, a creep
  // and a quarter turn back: the headings stay within the alpha2 trans^2 noise (sd 2.2 mrad),
  // not the alpha1 rot^2 noise of rot1 = pi/2 (sd 0.7 rad per rotation).
  const OdometryMotionModel amcl(OdometryMotionParams{0.2, 0.2, 0.2, 0.2});
  const OdometryReading creep{{0, 0, 0}, {0, 0.005, 0}};
  double max_turn = 0;
  for (int k = 0; k < 1000; ++k)
    max_turn = std::max(max_turn, std::abs(amcl.sample(Pose2d{}, creep, rng).theta));
  CHECK(max_turn < 0.02);
  CHECK_THROWS_WITH(
      OdometryMotionModel(OdometryMotionParams{-1, 0, 0, 0}),
      "rangenav: OdometryMotionModel: argument 'alpha1' = -1 must be finite and >= 0");
}

TEST_CASE("likelihood field: exact distance transform and end-point likelihoods",
          "[localization]") {
  // Against brute force on a random mask.
  std::mt19937_64 rng(9);
  const std::size_t w = 37, h = 23;
  std::vector<std::uint8_t> mask(w * h, 0);
  std::bernoulli_distribution set(0.03);
  for (auto& m : mask)
    m = set(rng) ? 1 : 0;
  mask[5] = 1;
  const std::vector<float> d_sq = squared_distance_transform(mask, w, h);
  for (std::size_t y = 0; y < h; ++y)
    for (std::size_t x = 0; x < w; ++x) {
      double best = 1e18;
      for (std::size_t v = 0; v < h; ++v)
        for (std::size_t u = 0; u < w; ++u)
          if (mask[v * w + u]) {
            const double dx = double(x) - double(u), dy = double(y) - double(v);
            best = std::min(best, dx * dx + dy * dy);
          }
      CHECK(d_sq[y * w + x] == Approx(best));
    }
  CHECK(std::isinf(squared_distance_transform(std::vector<std::uint8_t>(6, 0), 3, 2)[4]));
  CHECK_THROWS_WITH(squared_distance_transform(mask, w, h + 1),
                    "rangenav: squared_distance_transform: argument 'mask.size()' = 851 must "
                    "equal width * height = 888");

  // A wall along x in [2, 2.1) (cells of 0.1 m): beams of a scan from (0.05, 1.05) hit it.
  OccupancyGridParams gp;
  gp.resolution = 0.1;
  OccupancyGrid grid({0, -1}, 40, 40, gp);
  for (int y = 0; y < 40; ++y)
    grid.set_log_odds({20, y}, 2.0);
  LikelihoodFieldParams lp;
  lp.sigma_hit = 0.1;
  const LikelihoodFieldModel field(grid, lp);
  CHECK(field.distance({2.05, 1.0}) == Approx(0.0));
  CHECK(field.distance({1.55, 1.0}) == Approx(0.5));
  CHECK(field.distance({2.75, 1.3}) == Approx(0.7));
  CHECK(field.distance({0.05, 1.0}) == Approx(2.0));  // clamped at max_distance
  CHECK(field.log_likelihood_at({1.85, 1.0}) == Approx(field.log_likelihood_of_distance(0.2)));
  CHECK(field.log_likelihood_at({-5, 1.0}) == Approx(field.log_likelihood_of_distance(2.0)));
  std::vector<double> ranges;
  for (int i = 0; i < 21; ++i)
    ranges.push_back(2.0 / std::cos(-0.5 + 0.05 * i));
  const LaserScand scan(-0.5, 0.05, 0.05, 30.0, ranges);
  const auto z = field.prepare(scan);
  REQUIRE(z.end_points.size() == 21);
  const double at_truth = field.log_likelihood(Pose2d{0.05, 1.05, 0}, z);
  CHECK(at_truth == Approx(21 * field.log_likelihood_of_distance(0.0)).epsilon(1e-4));
  CHECK(field.log_likelihood(Pose2d{0.25, 1.05, 0}, z) < at_truth);
  CHECK(field.log_likelihood(Pose2d{0.05, 1.05, 0.2}, z) < at_truth);
  // Beam selection: at most max_beams (default 30) evenly spaced from the first to the last.
  const auto used = [](std::size_t n, std::size_t stride, std::size_t max_beams) {
    LikelihoodFieldParams p;
    p.beam_stride = stride;
    p.max_beams = max_beams;
    std::vector<std::size_t> ks;
    for_each_used_beam(n, p, [&](std::size_t k) { ks.push_back(k); });
    return ks;
  };
  const auto picks = used(181, 1, LikelihoodFieldParams{}.max_beams);
  REQUIRE(picks.size() == 30);
  CHECK(picks.front() == 0);
  CHECK(picks.back() == 180);
  for (std::size_t m = 1; m < picks.size(); ++m) {
    CHECK(picks[m] - picks[m - 1] >= 6);  // 180 / 29 = 6.2
    CHECK(picks[m] - picks[m - 1] <= 7);
  }
  CHECK(used(181, 2, 0).size() == 91);
  CHECK(used(181, 2, 0).back() == 180);
  CHECK(used(10, 1, 30).size() == 10);
  CHECK(used(181, 4, 10) == std::vector<std::size_t>{0, 20, 40, 60, 80, 100, 120, 140, 160, 180});
  CHECK(used(50, 1, 1) == std::vector<std::size_t>{0});
  CHECK(used(0, 1, 30).empty());
  // The sensor's mount: the same scan taken 0.2 m behind the robot's centre.
  const auto z_mounted = field.prepare(scan, Pose2d{-0.2, 0, 0});
  CHECK(field.log_likelihood(Pose2d{0.25, 1.05, 0}, z_mounted) == Approx(at_truth));
}

TEST_CASE("mcl: tracking in the simulated office corridor stays within a few cm",
          "[localization][sim]") {
  const sim::Scene scene = sim::office_corridor();
  const OccupancyGrid grid = corridor_map(scene.world);
  const Run run = drive(scene.world, grid, {1.0, 1.0, 0.0}, 18.5, Start::tracking, 1000, 21);
  REQUIRE(run.position_errors.size() > 100);
  const double mean_err = mean(run.position_errors);
  const double max_err = *std::max_element(run.position_errors.begin(), run.position_errors.end());
  WARN("corridor tracking: mean " << mean_err << " m, max " << max_err << " m over "
                                  << run.position_errors.size() << " scans");
  CHECK(mean_err < 0.05);
  CHECK(max_err < 0.2);
  CHECK(mean(run.heading_errors) < 0.02);
}

TEST_CASE("mcl: tracks with closed doors that are missing from the map", "[localization][sim]") {
  // Issue 8 / paper 001 §V.B: standard MCL with the doors removed from the map. Mapped with all
  // doors open, then driven with all doors closed: every scan holds two short segments per
  // doorway that the map cannot explain. The paper's standard MCL fluctuates between 0.05 and
  // 0.22 m here. With all 181 beams treated as independent and sigma_hit = 0.1 m, the scan
  // likelihood preferred poses that hide the doorways behind walls by tens of nats per scan,
  // and the filter fell behind by metres (mean 5.1 m, max 11.4 m for this seed); the defaults
  // (AMCL's: 30 beams, sigma_hit 0.2 m) keep it on the robot: mean 0.19 m, max 0.67 m here,
  // means 0.16-0.29 m over seeds 2-6 (measured), slightly above the paper's band.
  const OccupancyGrid grid =
      corridor_map(sim::office_corridor(std::vector<double>(8, std::numbers::pi / 2)).world);
  const sim::Scene closed = sim::office_corridor();
  const Run run = drive(closed.world, grid, {1.0, 1.0, 0.0}, 18.5, Start::tracking, 500, 1);
  REQUIRE(run.position_errors.size() > 100);
  const double mean_err = mean(run.position_errors);
  const double max_err = *std::max_element(run.position_errors.begin(), run.position_errors.end());
  WARN("closed doors missing from the map: mean " << mean_err << " m, max " << max_err << " m");
  CHECK(mean_err < 0.3);
  CHECK(max_err < 1.0);
  CHECK(mean(run.heading_errors) < 0.05);
}

TEST_CASE("mcl: deterministic for a seed", "[localization][sim]") {
  const sim::Scene scene = sim::office_corridor();
  const OccupancyGrid grid = corridor_map(scene.world);
  const Run a = drive(scene.world, grid, {1.0, 1.0, 0.0}, 4.0, Start::tracking, 300, 5);
  const Run b = drive(scene.world, grid, {1.0, 1.0, 0.0}, 4.0, Start::tracking, 300, 5);
  const Run c = drive(scene.world, grid, {1.0, 1.0, 0.0}, 4.0, Start::tracking, 300, 6);
  REQUIRE(a.estimates.size() == b.estimates.size());
  for (std::size_t i = 0; i < a.estimates.size(); ++i)
    CHECK(a.estimates[i] == b.estimates[i]);
  CHECK(!(a.estimates.back() == c.estimates.back()));
}

TEST_CASE("mcl: global localization converges in an asymmetric corridor", "[localization][sim]") {
  // Three doors open: the corridor is no longer symmetric under a half turn.
  const sim::Scene scene = sim::office_corridor(
      {std::numbers::pi / 2, 0, 0, std::numbers::pi / 3, 0, std::numbers::pi / 4, 0, 0});
  const OccupancyGrid grid = corridor_map(scene.world);
  // A wider end-point model (sigma_hit 0.2 m) than for tracking: the uniform prior puts few
  // particles near the truth, and a flatter likelihood keeps them alive; the KLD bound never
  // drops below 5000 particles (measured: seeds 3-5 all converge; with sigma_hit 0.1 m or a
  // 1000-particle floor some lock onto the corridor's near-symmetric twin).
  LikelihoodFieldParams lp;
  lp.sigma_hit = 0.2;
  const Run run = drive(scene.world, grid, {1.0, 1.0, 0.0}, 18.0, Start::global, 20000, 3, lp);
  const std::size_t n = run.position_errors.size();
  REQUIRE(n > 20);
  WARN("global localization: final error "
       << run.position_errors.back() << " m, " << run.heading_errors.back() << " rad, particles "
       << run.particle_counts.front() << " -> " << run.particle_counts.back());
  // Converged over the last quarter of the run: the paper's success criterion.
  for (std::size_t i = 3 * n / 4; i < n; ++i) {
    CHECK(run.position_errors[i] < 0.3);
    CHECK(run.heading_errors[i] < 0.1);
  }
  CHECK(run.particle_counts.back() < 20000);  // KLD shrank the set
}

TEST_CASE("mcl: bad arguments", "[localization]") {
  OccupancyGrid grid({0, 0}, 10, 10);
  MclParams p;
  p.max_particles = 10;
  p.min_particles = 20;
  CHECK_THROWS_WITH(
      (MonteCarloLocalization<>{OdometryMotionModel(), LikelihoodFieldModel(grid), p}),
      "rangenav: MonteCarloLocalization: argument 'max_particles' = 10 must be >= "
      "min_particles = 20");
  MonteCarloLocalization<> mcl{OdometryMotionModel(), LikelihoodFieldModel(grid)};
  std::mt19937_64 rng(1);
  CHECK_THROWS_WITH(mcl.initialize_uniform(grid, 100, rng),
                    "rangenav: MonteCarloLocalization::initialize_uniform: the grid has no free "
                    "cell");
  CHECK_THROWS_WITH(mcl.initialize_gaussian({}, {0.1, -1, 0}, 100, rng),
                    "rangenav: MonteCarloLocalization::initialize_gaussian: sigma must be finite "
                    "and >= 0");
  CHECK_THROWS_WITH(mcl.update(OdometryReading{}, LikelihoodFieldModel::Observation{}, rng),
                    "rangenav: MonteCarloLocalization::update: not initialised");
}

namespace {

/// A corrected CARMEN log: each scan with its corrected pose and the raw odometry at its time.
///
/// The raw odometry: these GMapping-corrected logs follow every FLASER with an ODOM record whose
/// logger timestamp is 0 and whose pose is the scan's corrected pose; the ODOM records after it
/// continue from there. Taking the last ODOM pose before each scan therefore telescopes into the
/// corrected trajectory (its dead reckoning ends 0.14 m from the truth on Intel, 0.016 m on
/// FR079). The raw odometry chains the increments between consecutive ODOM records and skips
/// the jumps into the timestamp-0 records (dead reckoning then ends 36.7 m / 45.6 m off).
struct CorrectedLog {
  std::vector<io::CarmenLaser> lasers;
  std::vector<Pose2d> odometry;  ///< the raw odometry at each laser
  [[nodiscard]] const Pose2d& corrected(std::size_t i) const { return *lasers[i].laser_pose; }
};

CorrectedLog read_corrected_log(const std::filesystem::path& path) {
  io::CarmenReader reader(path, io::CarmenReaderOptions{.range_max = 81.0});
  CorrectedLog log;
  Pose2d raw{}, last_record{};
  bool have_record = false;
  while (auto record = reader.next()) {
    if (const auto* o = std::get_if<io::CarmenOdometry>(&*record)) {
      if (have_record && o->logger_timestamp != 0.0)
        raw = compose(raw, relative(last_record, o->pose));
      last_record = o->pose;
      have_record = true;
    } else if (auto* l = std::get_if<io::CarmenLaser>(&*record)) {
      if (!have_record || !l->laser_pose) continue;
      log.lasers.push_back(std::move(*l));
      log.odometry.push_back(raw);
    }
  }
  REQUIRE(log.lasers.size() > 100);
  return log;
}

/// Inconsistency of the corrected poses with the robot's own odometry: the steps (between
/// consecutive scans) on which the corrected pose moves more than 3 cm backwards while the raw
/// odometry moves more than 3 cm forwards. These robots do not reverse, so such a step is the
/// corrected trajectory jumping (GMapping's best particle changing), not the robot moving.
struct BackwardSteps {
  double metres{0};                       ///< summed backward length
  std::size_t steps{0};                   ///< how many
  std::size_t run_first{0}, run_last{0};  ///< the longest run (gaps of <= 3 scans joined)
};
BackwardSteps backward_corrected_steps(const CorrectedLog& log) {
  BackwardSteps b;
  std::size_t first = 0, last = 0;
  for (std::size_t i = 1; i < log.lasers.size(); ++i) {
    const Pose2d c = relative(log.corrected(i - 1), log.corrected(i));
    const Pose2d o = relative(log.odometry[i - 1], log.odometry[i]);
    if (!(c.x < -0.03 && o.x > 0.03)) continue;
    b.metres -= c.x;
    ++b.steps;
    if (b.steps == 1 || i > last + 3) first = i;
    last = i;
    if (last - first > b.run_last - b.run_first) {
      b.run_first = first;
      b.run_last = last;
    }
  }
  return b;
}

/// The grid of a corrected log, 10 cm cells, from every map_step-th scan at its corrected pose:
/// plain occupancy mapping (classify_dynamic = false) with miss_probability 0.49 instead of 0.4,
/// so that a beam passing through a wall that an inconsistent pass put elsewhere only dents it
/// (log-odds -0.04 per miss against +0.85 per hit). With the default 0.4 the passes of FR079
/// whose corrected poses disagree erase each other's walls: standard MCL (300 particles, every
/// other scan, seeds 1-3) then has mean 0.084-0.091 m, max 0.65-0.86 m from scan 1402 on and
/// loses the map before scan 1373 (0.52-0.57 m mean); with 0.49: 0.063-0.065 m, 0.49-0.58 m and
/// 0.089-0.093 m, 1.43-1.46 m.
OccupancyGrid corrected_log_map(const CorrectedLog& log, std::size_t map_step) {
  Point2d lo = Point2d::Constant(1e18), hi = -lo;
  for (const auto& l : log.lasers) {
    lo = lo.cwiseMin(l.laser_pose->position());
    hi = hi.cwiseMax(l.laser_pose->position());
  }
  OccupancyGridParams gp;
  gp.resolution = 0.1;
  gp.classify_dynamic = false;
  gp.miss_probability = 0.49;
  OccupancyGrid grid = OccupancyGrid::covering(lo, hi, 15.0, gp);
  for (std::size_t i = 0; i < log.lasers.size(); i += map_step)
    grid.integrate(log.corrected(i), log.lasers[i].scan);
  return grid;
}

struct RealRun {
  double mean_err{0}, max_err{0}, final_err{0};
  double dead_reckoning_final_err{0};  ///< the raw odometry alone, from the same start
  std::size_t scans{0};
};

struct RealRunOptions {
  std::size_t particles{300};
  std::size_t first_scan{0};  ///< track scans [first_scan, last_scan)
  std::size_t last_scan{std::numeric_limits<std::size_t>::max()};
  std::size_t scan_step{1};  ///< filter every scan_step-th scan (odometry composed in between)
};

/// Standard MCL on a corrected log: default likelihood field but range_max = 81 m (the logs'
/// no-return value), motion from the raw odometry, started from the first tracked scan's
/// corrected pose disturbed by (0.3 m, -0.2 m, 0.1 rad) with particles spread N(0, (0.3 m, 0.3
/// m, 0.1 rad)). Errors are against the corrected poses, after 20 filter steps.
RealRun track_real_log(const CorrectedLog& log, const OccupancyGrid& grid,
                       const RealRunOptions& opt) {
  LikelihoodFieldParams lp;
  lp.range_max = 81.0;
  MclParams mp;
  mp.min_particles = opt.particles;
  mp.max_particles = opt.particles;
  mp.adapt_particle_count = false;
  // alpha = 0.05: these logs' raw odometry is good to about 3 cm and 0.012 rad per 0.1 m step
  // on FR079 (median difference to the corrected increments).
  MonteCarloLocalization<> mcl(OdometryMotionModel(OdometryMotionParams{0.05, 0.05, 0.05, 0.05}),
                               LikelihoodFieldModel(grid, lp), mp);
  std::mt19937_64 rng(17);
  const Pose2d& first = log.corrected(opt.first_scan);
  mcl.initialize_gaussian({first.x + 0.3, first.y - 0.2, first.theta + 0.1}, {0.3, 0.3, 0.1},
                          opt.particles, rng);
  LikelihoodFieldModel::Observation z;
  RealRun run;
  double sum = 0;
  Pose2d dead = first;
  std::size_t steps = 0, last = opt.first_scan;
  const std::size_t end = std::min(opt.last_scan, log.lasers.size());
  for (std::size_t i = opt.first_scan; i < end; i += opt.scan_step, ++steps) {
    const OdometryReading u{log.odometry[last], log.odometry[i]};
    last = i;
    dead = compose(dead, relative(u.previous, u.current));
    mcl.sensor_model().prepare(log.lasers[i].scan, Pose2d{}, z);
    mcl.update(u, z, rng);
    const Pose2d e = mcl.estimate();
    const double err = (e.position() - log.corrected(i).position()).norm();
    if (steps >= 20) {  // after the start-up transient
      sum += err;
      ++run.scans;
      run.max_err = std::max(run.max_err, err);
    }
    run.final_err = err;
  }
  run.mean_err = sum / static_cast<double>(run.scans);
  run.dead_reckoning_final_err = (dead.position() - log.corrected(last).position()).norm();
  return run;
}

}  // namespace

TEST_CASE("mcl: tracking on the corrected Intel log from raw odometry", "[localization][data]") {
  const auto path = test::data_file_or_skip("carmen_corrected/intel-corrected.log.gz");
  if (path.empty()) return;
  const CorrectedLog log = read_corrected_log(path);
  // The corrected poses agree with the odometry: 3 backward steps, 0.13 m in all.
  const BackwardSteps back = backward_corrected_steps(log);
  CHECK(back.metres < 0.5);
  // 300 particles, every scan (910, about 0.55 m apart); measured over seeds 1-3: mean
  // 0.054-0.058 m, max 0.29-0.34 m (with the default miss_probability 0.4 grid: 0.065-0.066 m,
  // 0.33-0.38 m).
  const RealRun r = track_real_log(log, corrected_log_map(log, 1), {});
  WARN("intel: MCL vs corrected poses over "
       << r.scans << " scans: mean " << r.mean_err << " m, max " << r.max_err << " m, final "
       << r.final_err << " m; raw odometry alone ends " << r.dead_reckoning_final_err
       << " m off; corrected poses step backwards over " << back.metres << " m");
  CHECK(r.dead_reckoning_final_err > 10.0);  // the odometry really is raw
  CHECK(r.mean_err < 0.1);
  CHECK(r.max_err < 0.6);
  CHECK(r.final_err < 0.2);
}

TEST_CASE("mcl: tracking on the corrected FR079 log from raw odometry", "[localization][data]") {
  const auto path = test::data_file_or_skip("carmen_corrected/freiburg-079-corrected.log.gz");
  if (path.empty()) return;
  const CorrectedLog log = read_corrected_log(path);
  // FR079's corrected poses are not one consistent trajectory: GMapping logged each scan's pose
  // from its best particle at the time, and when that particle changed the logged pose jumped.
  // Measured: 103 steps, 8.7 m in all, on which the corrected pose moves backwards while the
  // odometry moves forwards; runs at scans 838-843, 908-916, 1094-1097 and 1373-1401 (29
  // scans: 3 m backwards while the robot drove 3 m forwards, so the corrected frame shifts by
  // about 6 m along the corridor), single steps up to scan 4618. A tracker that follows the
  // robot is metres from the corrected poses after such a run until it finds the map again,
  // which standard MCL (no recovery) may not. Over the whole log it does here (seeds 1-8, 300
  // particles, every other scan: mean 0.15-0.16 m, max 5.7-6.0 m at scan 1412; 1000 particles
  // on every scan, seeds 1-4: 0.22-0.26 m, 5.2-5.4 m), but before the occupancy grid's
  // surface margin 1 of those 8 seeds lost the map after scan 1401. So the filter is checked
  // on both sides of the longest run, restarted after it, where the corrected poses are a
  // fair reference.
  const BackwardSteps back = backward_corrected_steps(log);
  WARN("fr079: corrected poses step backwards over "
       << back.metres << " m in " << back.steps << " steps; longest run: scans " << back.run_first
       << "-" << back.run_last);
  CHECK(back.metres > 5.0);
  CHECK(back.run_last - back.run_first >= 20);
  // Every other scan, grid from every other scan, 300 particles. Measured over seeds 1-3:
  // before the run mean 0.089-0.093 m, max 1.43-1.46 m (at scan 918, the end of the 908-916
  // run); after it 0.063-0.065 m, 0.49-0.58 m (at scans 1734-1816, single backward steps).
  const OccupancyGrid grid = corrected_log_map(log, 2);
  RealRunOptions before;
  before.scan_step = 2;
  before.last_scan = back.run_first;
  RealRunOptions after = before;
  after.first_scan = back.run_last + 1;
  after.last_scan = log.lasers.size();
  for (const auto& [name, opt] : {std::pair{"before", before}, std::pair{"after", after}}) {
    const RealRun r = track_real_log(log, grid, opt);
    WARN("fr079 " << name << " the run: MCL vs corrected poses over " << r.scans
                  << " filter steps: mean " << r.mean_err << " m, max " << r.max_err << " m, final "
                  << r.final_err << " m");
    CHECK(r.mean_err < 0.12);
    CHECK(r.max_err < 2.0);
    CHECK(r.final_err < 0.3);
  }
}
