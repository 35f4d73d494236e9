// Tests of HAYAI (paper 003 §3) on scans ray cast from simple polygonal worlds, whose corners and
// jump edges are known exactly.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/registration/hayai.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

using namespace rangenav;

namespace {

constexpr double pi = std::numbers::pi;

struct Wall {
  Point2d a, b;
};

using World = std::vector<Wall>;

// Closed polygon (vertices in order) as walls.
void add_polygon(World& world, const std::vector<Point2d>& vertices) {
  for (std::size_t i = 0; i < vertices.size(); ++i)
    world.push_back({vertices[i], vertices[(i + 1) % vertices.size()]});
}

double cross(const Point2d& a, const Point2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// Ray casts the world from `pose`: one range per beam, range_max when nothing is hit, plus
// Gaussian noise of `sigma` when an engine is given.
LaserScand cast(const World& world, const Pose2d& pose, const ScanGeometry<double>& geometry,
                double sigma = 0.0, std::mt19937* rng = nullptr) {
  std::vector<double> ranges(geometry.beam_count, geometry.range_max);
  std::normal_distribution<double> noise(0.0, sigma);
  const Point2d origin = pose.position();
  for (std::size_t i = 0; i < geometry.beam_count; ++i) {
    const double phi = pose.theta + geometry.angle(i);
    const Point2d dir(std::cos(phi), std::sin(phi));
    double best = std::numeric_limits<double>::infinity();
    for (const auto& w : world) {
      const Point2d e = w.b - w.a;
      const double denom = cross(dir, e);
      if (std::abs(denom) < 1e-12) continue;
      const Point2d to_a = w.a - origin;
      const double t = cross(to_a, e) / denom;
      const double u = cross(to_a, dir) / denom;
      if (t > 1e-9 && u >= 0.0 && u <= 1.0) best = std::min(best, t);
    }
    if (best < geometry.range_max) ranges[i] = best + (rng ? noise(*rng) : 0.0);
  }
  return LaserScand(geometry, std::move(ranges));
}

ScanGeometry<double> front_scan(std::size_t beams) {  // 180° like a SICK LMS
  return {-pi / 2, pi / static_cast<double>(beams - 1), beams, 0.05, 30.0};
}

ScanGeometry<double> full_turn_scan(std::size_t beams) {
  return {-pi, 2 * pi / static_cast<double>(beams), beams, 0.05, 30.0};
}

// An irregular convex hexagonal room around the origin: six concave corners, no jump edges.
const std::vector<Point2d> hexagon{{4.0, -1.0}, {3.0, 2.5},   {-1.0, 3.0},
                                   {-3.5, 1.0}, {-2.5, -2.5}, {1.5, -3.0}};

World hexagon_room() {
  World w;
  add_polygon(w, hexagon);
  return w;
}

// A rectangular room with a square pillar in front of the robot (at the origin, facing +x).
World room_with_pillar() {
  World w;
  add_polygon(w, {{-5.0, -6.0}, {6.0, -6.0}, {6.0, 5.0}, {-5.0, 5.0}});
  add_polygon(w, {{2.5, -2.0}, {3.5, -2.0}, {3.5, -1.0}, {2.5, -1.0}});
  return w;
}

// The feature of `features` nearest to `p` (in the scan frame), or nullptr.
const HayaiFeature<double>* nearest(const std::vector<HayaiFeature<double>>& features,
                                    const Point2d& p) {
  const HayaiFeature<double>* best = nullptr;
  for (const auto& f : features)
    if (!best || (f.position - p).norm() < (best->position - p).norm()) best = &f;
  return best;
}

Point2d in_frame(const Pose2d& pose, const Point2d& world_point) {
  return inverse(pose).transform_point(world_point);
}

double position_error(const Pose2d& a, const Pose2d& b) {
  return std::hypot(a.x - b.x, a.y - b.y);
}

}  // namespace

TEST_CASE("HAYAI finds the corners of a room at their exact positions", "[registration][hayai]") {
  const auto world = hexagon_room();
  const Pose2d pose{0.2, -0.1, 0.3};
  const auto scan = cast(world, pose, full_turn_scan(720));
  const auto features = extract_hayai_features(scan);
  REQUIRE(features.size() == hexagon.size());
  for (const auto& v : hexagon) {
    const auto* f = nearest(features, in_frame(pose, v));
    REQUIRE(f != nullptr);
    CHECK((f->position - in_frame(pose, v)).norm() < 1e-9);  // lines' intersection is exact
    CHECK(f->type == HayaiFeatureType::maximum);             // concave corners: range peaks
    CHECK_FALSE(f->jump_edge);
    CHECK(f->range == Approx(f->position.norm()));
    CHECK(f->bearing == Approx(std::atan2(f->position.y(), f->position.x())));
  }
  // Without refinement a corner sits at its beam's point, less than a beam spacing away.
  HayaiParams<double> raw;
  raw.refine_corners = false;
  const auto unrefined = extract_hayai_features(scan, raw);
  REQUIRE(unrefined.size() == hexagon.size());
  for (const auto& v : hexagon) {
    const Point2d p = in_frame(pose, v);
    const auto* f = nearest(unrefined, p);
    CHECK((f->position - p).norm() < 2.5 * p.norm() * scan.angle_increment());
    CHECK(scan.point(f->beam) == f->position);
  }
}

TEST_CASE("HAYAI finds jump edges and classifies corners as maximum or minimum",
          "[registration][hayai]") {
  const auto scan = cast(room_with_pillar(), {}, front_scan(361));
  const auto features = extract_hayai_features(scan);
  // Two room corners, the pillar's near corner, and the occluding ends of the two jump edges at
  // the pillar's silhouette; the wall's foot points (smooth minima) are no features.
  REQUIRE(features.size() == 5);
  struct Expected {
    Point2d where;
    HayaiFeatureType type;
    bool jump;
  };
  const std::vector<Expected> expected{
      {{6.0, -6.0}, HayaiFeatureType::maximum, false},
      {{6.0, 5.0}, HayaiFeatureType::maximum, false},
      {{2.5, -1.0}, HayaiFeatureType::minimum, false},  // convex corner: range dips
      {{3.5, -1.0}, HayaiFeatureType::minimum, true},   // silhouette, near side
      {{2.5, -2.0}, HayaiFeatureType::minimum, true}};
  for (const auto& e : expected) {
    const auto* f = nearest(features, e.where);
    REQUIRE(f != nullptr);
    CHECK(f->type == e.type);
    CHECK(f->jump_edge == e.jump);
    if (!e.jump) {
      CHECK((f->position - e.where).norm() < 1e-9);
      continue;
    }
    // A silhouette lies between two beams: its feature is placed half a beam out from the last
    // beam on the pillar, so it is off by at most half the beams' spacing on the pillar's face.
    const std::size_t inner =
        std::abs(scan.range(f->beam - 1) - scan.range(f->beam)) < 0.5 ? f->beam - 1 : f->beam + 1;
    const double spacing = (scan.point(f->beam) - scan.point(inner)).norm();
    CHECK((f->position - e.where).norm() < 0.55 * spacing);
    CHECK((scan.point(f->beam) - e.where).norm() < spacing);
    CHECK(f->sigma == Approx(std::hypot(0.01, spacing / std::sqrt(12.0))));
  }
  // Features come in beam order.
  for (std::size_t k = 1; k < features.size(); ++k)
    CHECK(features[k - 1].beam < features[k].beam);

  SECTION("shadow edges are features only on request, as maxima") {
    HayaiParams<double> params;
    params.use_shadow_edges = true;
    const auto with_shadows = extract_hayai_features(scan, params);
    REQUIRE(with_shadows.size() == 7);
    std::size_t shadows = 0;
    for (const auto& f : with_shadows)
      if (f.jump_edge && f.type == HayaiFeatureType::maximum) {
        ++shadows;
        CHECK(f.position.x() == Approx(6.0));  // on the wall behind the pillar
      }
    CHECK(shadows == 2);
  }
}

TEST_CASE("a corner through which the range keeps rising is an inflection point",
          "[registration][hayai]") {
  World world{{{2.0, -3.0}, {2.0, 1.0}}, {{2.0, 1.0}, {5.0, 4.0}}};
  const auto scan = cast(world, {}, front_scan(361));
  const auto features = extract_hayai_features(scan);
  // The ends next to beams without return are no features; nor is the wall's foot point.
  REQUIRE(features.size() == 1);
  CHECK(features[0].type == HayaiFeatureType::inflection);
  CHECK((features[0].position - Point2d(2.0, 1.0)).norm() < 1e-9);
  // The mirror image: the range falls through the corner.
  World mirrored{{{5.0, -4.0}, {2.0, -1.0}}, {{2.0, -1.0}, {2.0, 3.0}}};
  const auto mirror_features = extract_hayai_features(cast(mirrored, {}, front_scan(361)));
  REQUIRE(mirror_features.size() == 1);
  CHECK(mirror_features[0].type == HayaiFeatureType::inflection);
  CHECK((mirror_features[0].position - Point2d(2.0, -1.0)).norm() < 1e-9);
}

TEST_CASE("HAYAI skips invalid beams without inventing features", "[registration][hayai]") {
  const auto world = hexagon_room();
  const auto clean = cast(world, {}, full_turn_scan(720));
  const auto reference = extract_hayai_features(clean);
  REQUIRE(reference.size() == 6);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();

  SECTION("a gap in the middle of a wall") {
    auto ranges = clean.ranges();
    // Bearing 0 looks at the middle of the wall (4,-1)-(3,2.5).
    for (std::size_t i = 358; i < 363; ++i)
      ranges[i] = (i % 2 == 0) ? nan : 0.0;
    ranges[364] = inf;
    const auto features = extract_hayai_features(LaserScand(clean.geometry(), ranges));
    REQUIRE(features.size() == 6);
    for (std::size_t k = 0; k < 6; ++k)
      CHECK((features[k].position - reference[k].position).norm() < 1e-9);
  }
  SECTION("an invalid beam next to a corner loses that corner only") {
    auto ranges = clean.ranges();
    ranges[reference[2].beam + 1] = nan;
    const auto features = extract_hayai_features(LaserScand(clean.geometry(), ranges));
    CHECK(features.size() == 5);
    for (const auto& f : features) {
      const auto* r = nearest(reference, f.position);
      CHECK((f.position - r->position).norm() < 1e-9);
      CHECK(r->beam != reference[2].beam);
    }
  }
  SECTION("a scan without a valid beam, and tiny scans") {
    const LaserScand none(clean.geometry(), std::vector<double>(720, nan));
    CHECK(extract_hayai_features(none).empty());
    CHECK(extract_hayai_features(LaserScand()).empty());
    CHECK(extract_hayai_features(LaserScand(0.0, 0.01, 0.0, 10.0, {1.0, 2.0})).empty());
  }
}

TEST_CASE("HAYAI recovers a known shift exactly on noise-free scans", "[registration][hayai]") {
  const auto world = hexagon_room();
  const Pose2d reference_pose{0.1, 0.2, -0.2};
  const auto reference = cast(world, reference_pose, full_turn_scan(720));
  // Shifts of the current scan in the reference frame; small ones without a prediction, large
  // ones with an (erroneous) odometry prediction.
  struct Case {
    Pose2d shift;
    Pose2d predicted;
  };
  const std::vector<Case> cases{{{0.05, 0.0, 0.0}, {}},
                                {{0.08, -0.04, deg_to_rad(2.0)}, {}},
                                {{-0.05, 0.1, deg_to_rad(-3.0)}, {}},
                                {{0.6, 0.3, deg_to_rad(15.0)}, {0.55, 0.35, deg_to_rad(12.0)}},
                                {{-0.4, -0.7, deg_to_rad(-25.0)}, {-0.3, -0.8, deg_to_rad(-20.0)}}};
  for (const auto& c : cases) {
    const auto current = cast(world, compose(reference_pose, c.shift), full_turn_scan(720));
    const auto result = register_hayai(reference, current, HayaiParams<double>{}, c.predicted);
    INFO("shift " << c.shift.x << " " << c.shift.y << " " << c.shift.theta);
    REQUIRE(result.ok());
    CHECK(result.matched == 6);
    CHECK(result.model_features == 6);
    CHECK(result.data_features == 6);
    CHECK(result.shift.x == Approx(c.shift.x).margin(1e-9));
    CHECK(result.shift.y == Approx(c.shift.y).margin(1e-9));
    CHECK(result.shift.theta == Approx(c.shift.theta).margin(1e-9));
    CHECK(result.rms_residual < 1e-9);
  }

  SECTION("a 180-degree scan with jump edges: corners exact, jump ends within a beam") {
    const auto pillar = room_with_pillar();
    const Pose2d shift{0.12, 0.05, deg_to_rad(2.0)};
    const auto a = cast(pillar, {}, front_scan(361));
    const auto b = cast(pillar, shift, front_scan(361));
    const auto result = register_hayai(a, b);
    REQUIRE(result.ok());
    CHECK(result.matched == 5);
    CHECK(position_error(result.shift, shift) < 0.01);
    CHECK(std::abs(angle_difference(result.shift.theta, shift.theta)) < deg_to_rad(0.3));
    // Without the jump edges' beam quantisation the corners alone give the exact shift.
    HayaiParams<double> strict;
    strict.max_pair_residual = 1e-6;
    const auto corners_only = register_hayai(a, b, strict);
    REQUIRE(corners_only.ok());
    CHECK(corners_only.matched == 3);
    CHECK(position_error(corners_only.shift, shift) < 1e-9);
    CHECK(corners_only.shift.theta == Approx(shift.theta).margin(1e-9));
  }
}

TEST_CASE("HAYAI reports failure instead of a wrong pose", "[registration][hayai]") {
  SECTION("a featureless corridor") {
    // Two parallel walls far longer than the scanner's range: no corner, no jump edge.
    const World corridor{{{-100.0, -1.0}, {100.0, -1.0}}, {{-100.0, 1.2}, {100.0, 1.2}}};
    const auto a = cast(corridor, {}, front_scan(181));
    const auto b = cast(corridor, {0.3, 0.05, 0.02}, front_scan(181));
    CHECK(extract_hayai_features(a).empty());
    const auto result = register_hayai(a, b);
    CHECK(result.status == HayaiStatus::featureless);
    CHECK_FALSE(result.ok());
    CHECK(result.shift == Pose2d{});
    CHECK(result.matched == 0);
    CHECK(to_string(result.status) == "featureless");
  }
  SECTION("too few matched features after a large unpredicted motion") {
    const auto world = hexagon_room();
    const auto a = cast(world, {}, full_turn_scan(720));
    const auto b = cast(world, {1.2, -0.8, 0.5}, full_turn_scan(720));
    const auto result = register_hayai(a, b);
    CHECK(result.status == HayaiStatus::too_few_matches);
    CHECK(result.matched < 3);
    CHECK(result.shift == Pose2d{});
  }
  SECTION("fewer features than needed") {
    // Only the inflection corner: one feature per scan.
    const World world{{{2.0, -3.0}, {2.0, 1.0}}, {{2.0, 1.0}, {5.0, 4.0}}};
    const auto a = cast(world, {}, front_scan(361));
    const auto b = cast(world, {0.05, 0.0, 0.0}, front_scan(361));
    const auto result = register_hayai(a, b);
    CHECK(result.status == HayaiStatus::featureless);
    CHECK(result.model_features == 1);
    HayaiParams<double> two;
    two.min_matched_features = 2;
    CHECK(register_hayai(a, b, two).status == HayaiStatus::featureless);
  }
  SECTION("two pairs are accepted only where the prediction confirms them") {
    // A wall with a doorway: its two door frames are the only features (near ends of jumps).
    const World doorway{
        {{3.0, -100.0}, {3.0, -0.45}}, {{3.0, 0.45}, {3.0, 100.0}}, {{8.0, -100.0}, {8.0, 100.0}}};
    const Pose2d shift{0.04, 0.01, deg_to_rad(0.5)};
    const auto a = cast(doorway, {}, front_scan(361));
    const auto b = cast(doorway, shift, front_scan(361));
    REQUIRE(extract_hayai_features(a).size() == 2);
    // Near the prediction, two pairs give the pose (exactly, up to the jump ends' half beam).
    const auto near = register_hayai(a, b, {}, Pose2d{0.03, 0.0, 0.0});
    REQUIRE(near.ok());
    CHECK(near.matched == 2);
    CHECK(near.shift.x == Approx(shift.x).margin(0.01));
    CHECK(near.shift.y == Approx(shift.y).margin(0.01));
    CHECK(near.shift.theta == Approx(shift.theta).margin(deg_to_rad(0.3)));
    // Far from it (here 3.5° beyond the unverified rotation gate of 2°) nothing checks them:
    // reported, no pose.
    const auto far = register_hayai(a, b, {}, Pose2d{0.04, 0.0, deg_to_rad(4.0)});
    CHECK(far.status == HayaiStatus::unconfirmed);
    CHECK(far.matched == 2);
    CHECK(far.shift == Pose2d{});
    CHECK(to_string(far.status) == "unconfirmed");
    // Requiring three pairs, as for every pose, turns two into too few.
    HayaiParams<double> three;
    three.min_matched_features = 3;
    CHECK(register_hayai(a, b, three, Pose2d{0.03, 0.0, 0.0}).status == HayaiStatus::featureless);
  }
  SECTION("two coincident features cannot fix the rotation") {
    std::vector<HayaiFeature<double>> m(2), d(2);
    for (auto* set : {&m, &d})
      for (auto& f : *set)
        f = {{2.0, 1.0}, std::atan2(1.0, 2.0), std::sqrt(5.0)};
    d[1].position.x() += 1e-4;
    HayaiParams<double> params;
    params.min_matched_features = 2;
    HayaiMatcher<double> matcher(params);
    std::vector<HayaiPair<double>> pairs;
    const auto result = matcher.register_features(m, d, {}, false, pairs);
    CHECK(result.matched == 2);
    CHECK(result.status == HayaiStatus::degenerate);
    CHECK(result.shift == Pose2d{});
  }
}

TEST_CASE("Eq. (4) distance and the type inhibition", "[registration][hayai]") {
  HayaiParams<double> params;
  params.omega_bearing = 2.0;
  params.omega_range = 4.0;
  params.omega_cartesian = 0.5;
  HayaiMatcher<double> matcher(params);
  const auto feature = [](double x, double y, HayaiFeatureType type) {
    return HayaiFeature<double>{{x, y}, std::atan2(y, x), std::hypot(x, y), type, 0, false};
  };
  const auto m = feature(3.0, 0.0, HayaiFeatureType::maximum);
  const auto d = feature(0.0, 4.0, HayaiFeatureType::maximum);
  // sqrt((2 · π/2)² + 4 · (3 − 4)²) + 0.5 · 5
  CHECK(matcher.distance(m, d) == Approx(std::sqrt(pi * pi + 4.0) + 2.5));
  CHECK(matcher.distance(m, feature(0.0, 4.0, HayaiFeatureType::minimum)) ==
        std::numeric_limits<double>::infinity());
  // Pairs of different types are never matched, even when they coincide.
  std::vector<HayaiFeature<double>> model{m, feature(1.0, 1.0, HayaiFeatureType::inflection)};
  std::vector<HayaiFeature<double>> data{feature(3.0, 0.0, HayaiFeatureType::minimum),
                                         feature(1.0, 1.02, HayaiFeatureType::inflection)};
  std::vector<HayaiPair<double>> pairs;
  matcher.match(model, data, {}, false, pairs);
  REQUIRE(pairs.size() == 1);
  CHECK(pairs[0].model == 1);
  CHECK(pairs[0].data == 1);
}

TEST_CASE("matching is unique and keeps the features' order", "[registration][hayai]") {
  HayaiMatcher<double> matcher;
  const auto feature = [](double x, double y) {
    return HayaiFeature<double>{
        {x, y}, std::atan2(y, x), std::hypot(x, y), HayaiFeatureType::maximum, 0, false};
  };
  // Model and data in beam (bearing) order. Model 0 is nearest to data 1 and model 1 nearest to
  // data 0 (at another range): the greedy pairs cross. Model 2 and data 2 agree.
  const std::vector<HayaiFeature<double>> model{feature(2.0, 0.0), feature(4.0, 0.2),
                                                feature(3.0, 1.0)};
  const std::vector<HayaiFeature<double>> data{feature(4.0, 0.1), feature(2.0, 0.1),
                                               feature(3.0, 1.02)};
  REQUIRE(data[0].bearing < data[1].bearing);
  std::vector<HayaiPair<double>> pairs;
  matcher.match(model, data, {}, true, pairs);  // a full turn: no order check
  REQUIRE(pairs.size() == 3);
  for (std::size_t k = 0; k < 3; ++k)
    CHECK(pairs[k].model == k);  // one partner each
  CHECK(pairs[0].data == 1);
  CHECK(pairs[1].data == 0);
  CHECK(pairs[2].data == 2);
  // With the order check one of the crossing pairs goes.
  matcher.match(model, data, {}, false, pairs);
  REQUIRE(pairs.size() == 2);
  CHECK(pairs[0].data < pairs[1].data);
  CHECK(pairs[1].model == 2);
  CHECK(pairs[1].data == 2);
}

TEST_CASE("HAYAI stays accurate on noisy scans", "[registration][hayai]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> step(-0.1, 0.1), turn(-0.05, 0.05);
  const auto world = room_with_pillar();
  double sum_error = 0, worst = 0, worst_angle = 0;
  int successes = 0;
  const int trials = 40;
  for (int k = 0; k < trials; ++k) {
    const Pose2d pose{0.3 * step(rng), 3.0 * step(rng), 5.0 * turn(rng)};
    const Pose2d shift{std::abs(step(rng)), step(rng), turn(rng)};
    const auto a = cast(world, pose, front_scan(361), 0.01, &rng);
    const auto b = cast(world, compose(pose, shift), front_scan(361), 0.01, &rng);
    const auto result = register_hayai(a, b);
    if (!result.ok()) continue;
    ++successes;
    const double e = position_error(result.shift, shift);
    sum_error += e;
    worst = std::max(worst, e);
    worst_angle =
        std::max(worst_angle, std::abs(angle_difference(result.shift.theta, shift.theta)));
    // The reported covariance is of the right size for the error.
    CHECK(result.covariance(0, 0) > 0);
  }
  INFO("mean error " << sum_error / successes << " m, worst " << worst << " m, worst angle "
                     << rad_to_deg(worst_angle) << " deg");
  CHECK(successes >= trials * 9 / 10);
  CHECK(sum_error / successes < 0.015);
  CHECK(worst < 0.035);
  CHECK(worst_angle < deg_to_rad(1.5));
}

TEST_CASE("the tracker accumulates the pose with Eq. (3)", "[registration][hayai]") {
  const auto world = room_with_pillar();
  // Drive a gentle arc through the room, 5 cm and 1° per scan (4 m/s at 75 Hz is 5.3 cm).
  const Pose2d step{0.05, 0.0, deg_to_rad(1.0)};
  Pose2d truth{-2.0, -0.5, deg_to_rad(-10.0)};
  HayaiTracker<double> tracker({}, {}, truth);
  const auto first = tracker.track(cast(world, truth, front_scan(361)));
  CHECK(first.source == HayaiIncrementSource::first_scan);
  CHECK(first.match.data_features >= 3);
  for (int k = 0; k < 30; ++k) {
    truth = compose(truth, step);
    const auto r = tracker.track(cast(world, truth, front_scan(361)));
    REQUIRE(r.match.ok());
    CHECK(r.source == HayaiIncrementSource::hayai);
    CHECK(r.pose == tracker.pose());
  }
  CHECK(position_error(tracker.pose(), truth) < 0.02);
  CHECK(std::abs(angle_difference(tracker.pose().theta, truth.theta)) < deg_to_rad(0.5));
  CHECK(tracker.covariance()(0, 0) > 0);
  CHECK(tracker.covariance()(0, 0) < 1e-2);
}

TEST_CASE("the tracker fuses odometry and falls back to it", "[registration][hayai]") {
  const auto world = room_with_pillar();
  std::mt19937 rng(11);
  const Pose2d step{0.05, 0.0, deg_to_rad(1.0)};
  // Odometry that overestimates the distance by 10 % and drifts in heading.
  const Pose2d odometry{0.055, 0.0, deg_to_rad(1.3)};
  Pose2d truth{-2.0, -0.5, deg_to_rad(-10.0)}, dead_reckoning = truth;
  HayaiTracker<double> tracker({}, {}, truth);
  tracker.track(cast(world, truth, front_scan(361), 0.01, &rng));
  int fused = 0;
  for (int k = 0; k < 30; ++k) {
    truth = compose(truth, step);
    dead_reckoning = compose(dead_reckoning, odometry);
    const auto r = tracker.track(cast(world, truth, front_scan(361), 0.01, &rng), odometry);
    if (r.source == HayaiIncrementSource::fused) ++fused;
  }
  CHECK(fused >= 25);
  const double tracked = position_error(tracker.pose(), truth);
  const double odometry_only = position_error(dead_reckoning, truth);
  INFO("tracked " << tracked << " m, odometry " << odometry_only << " m");
  CHECK(tracked < 0.5 * odometry_only);

  SECTION("in a featureless corridor the odometry carries the pose") {
    const World corridor{{{-100.0, -1.0}, {100.0, -1.0}}, {{-100.0, 1.2}, {100.0, 1.2}}};
    HayaiTracker<double> t;
    t.track(cast(corridor, {}, front_scan(181)));
    const auto r = t.track(cast(corridor, {0.05, 0.0, 0.0}, front_scan(181)), odometry);
    CHECK(r.match.status == HayaiStatus::featureless);
    CHECK(r.source == HayaiIncrementSource::odometry);
    CHECK(r.increment == odometry);
    CHECK(t.pose().x == Approx(odometry.x));
    // Without odometry the failure is reported and the last increment repeated...
    const auto coasting = t.track(cast(corridor, {0.1, 0.0, 0.0}, front_scan(181)));
    CHECK(coasting.match.status == HayaiStatus::featureless);
    CHECK(coasting.source == HayaiIncrementSource::constant_velocity);
    CHECK(coasting.increment == odometry);
    CHECK(coasting.pose == compose(odometry, odometry));
    CHECK(to_string(coasting.source) == "constant_velocity");
    // ... or, on request, the pose is kept.
    HayaiParams<double> keep;
    keep.coast_on_failure = false;
    HayaiTracker<double> still(keep);
    still.track(cast(corridor, {}, front_scan(181)));
    still.track(cast(corridor, {0.05, 0.0, 0.0}, front_scan(181)), odometry);
    const auto lost = still.track(cast(corridor, {0.1, 0.0, 0.0}, front_scan(181)));
    CHECK(lost.source == HayaiIncrementSource::none);
    CHECK(lost.pose == still.pose());
    CHECK(lost.pose.x == Approx(odometry.x));
    CHECK(to_string(lost.source) == "none");
  }
  SECTION("when HAYAI and the odometry disagree, redundancy decides") {
    const auto hex = hexagon_room();
    // The scans say the robot stood still; odometry claims 0.25 m (a slipping wheel), far
    // outside its uncertainty. HAYAI still matches (the features are within the gate), on six
    // pairs that check each other: its shift is kept alone.
    const Pose2d slip{0.25, 0.0, 0.0};
    HayaiTracker<double> t;
    t.track(cast(hex, {}, full_turn_scan(720)));
    const auto r = t.track(cast(hex, {}, full_turn_scan(720)), slip);
    REQUIRE(r.match.ok());
    CHECK(r.match.matched == 6);
    CHECK(r.match.shift.x == Approx(0.0).margin(1e-9));
    CHECK(r.innovation_rejected);
    CHECK(r.source == HayaiIncrementSource::hayai);
    CHECK(r.increment == r.match.shift);
    // With fewer pairs than trusted_matches the odometry wins the disagreement.
    HayaiOdometryNoise<double> sceptical;
    sceptical.trusted_matches = 7;
    HayaiTracker<double> s({}, sceptical);
    s.track(cast(hex, {}, full_turn_scan(720)));
    const auto o = s.track(cast(hex, {}, full_turn_scan(720)), slip);
    CHECK(o.innovation_rejected);
    CHECK(o.source == HayaiIncrementSource::odometry);
    CHECK(o.increment == slip);
    // A generous gate fuses the two instead.
    HayaiOdometryNoise<double> loose;
    loose.innovation_gate = 1e6;
    HayaiTracker<double> trusting({}, loose);
    trusting.track(cast(hex, {}, full_turn_scan(720)));
    const auto trusted = trusting.track(cast(hex, {}, full_turn_scan(720)), slip);
    CHECK_FALSE(trusted.innovation_rejected);
    CHECK(trusted.source == HayaiIncrementSource::fused);
    CHECK(std::abs(trusted.increment.x) < 0.03);  // odometry claimed 0.25
  }
}

TEST_CASE("HAYAI in the simulator's office corridor", "[registration][hayai]") {
  // Some office doors open: the scanner sees door frames (wall ends), the open leaves, the
  // offices' corners through the doorways and the corridor's far end.
  const auto scene = sim::office_corridor({1.2, 0.0, 0.9, 1.5, 0.6, 1.4, 0.0, 1.0});
  sim::LaserScannerParams lms;
  lms.geometry = ScanGeometry<double>::from_fov(pi, deg_to_rad(0.5), 0.05, 30.0);
  lms.noise.sigma = 0.0;
  const sim::LaserScanner2D exact(lms);
  std::mt19937 rng(2005);
  // The world's true corners: wall ends and the corners of the door leaves.
  std::vector<Point2d> landmarks;
  for (const auto& w : scene.world.walls()) {
    landmarks.push_back(w.a);
    landmarks.push_back(w.b);
  }
  for (const auto& d : scene.world.doors()) {
    const auto leaf = d.leaf();
    const Point2d u(std::cos(leaf.yaw), std::sin(leaf.yaw)), v(-u.y(), u.x());
    for (const double a : {-0.5, 0.5})
      for (const double b : {-0.5, 0.5})
        landmarks.push_back(leaf.center + a * leaf.size.x() * u + b * leaf.size.y() * v);
  }
  const auto distance_to_landmark = [&landmarks](const Point2d& p) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& l : landmarks)
      best = std::min(best, (l - p).norm());
    return best;
  };

  SECTION("features lie at the world's corners and jump edges") {
    std::size_t corners = 0, jumps = 0;
    for (const Pose2d pose : {Pose2d{1.2, 1.0, 0.05}, Pose2d{4.0, 1.2, -0.1}, Pose2d{9.0, 0.8, 0.2},
                              Pose2d{15.0, 1.0, 0.0}}) {
      const auto features = extract_hayai_features(exact.scan(scene.world, pose, rng));
      for (const auto& f : features) {
        const Point2d world = pose.transform_point(f.position);
        INFO("feature at " << world.transpose() << (f.jump_edge ? " (jump edge)" : " (corner)"));
        // A jump edge lies within half a beam spacing (√3 σ of its quantisation) of the wall's
        // end; a corner at the fitted lines' intersection, exact without noise.
        CHECK(distance_to_landmark(world) < (f.jump_edge ? 2 * std::sqrt(3.0) * f.sigma : 0.01));
        ++(f.jump_edge ? jumps : corners);
      }
    }
    CHECK(corners >= 3);
    CHECK(jumps >= 8);
    // From x = 4 the door frames of the open north door n1 ahead are both found.
    const Pose2d at{4.0, 1.0, 0.0};
    const auto features = extract_hayai_features(exact.scan(scene.world, at, rng));
    for (const Point2d& frame : {Point2d{7.05, 2.0}, Point2d{7.95, 2.0}}) {
      const auto* f = nearest(features, in_frame(at, frame));
      REQUIRE(f != nullptr);
      CHECK(f->jump_edge);
      CHECK(f->type == HayaiFeatureType::minimum);
      CHECK((at.transform_point(f->position) - frame).norm() < 2 * std::sqrt(3.0) * f->sigma);
    }
  }
  SECTION("a known shift is recovered from noise-free scans") {
    const Pose2d from{1.2, 1.0, 0.05};
    const Pose2d shift{0.06, -0.01, deg_to_rad(0.8)};
    const auto r = register_hayai(exact.scan(scene.world, from, rng),
                                  exact.scan(scene.world, compose(from, shift), rng));
    REQUIRE(r.ok());
    CHECK(r.matched >= 4);
    CHECK(r.shift.x == Approx(shift.x).margin(0.005));
    CHECK(r.shift.y == Approx(shift.y).margin(0.005));
    CHECK(r.shift.theta == Approx(shift.theta).margin(deg_to_rad(0.1)));
  }
  SECTION("tracking at 3 m/s without odometry drifts a few per cent") {
    // 4 cm per scan (75 Hz) weaving down the corridor from x = 1 to x = 9, 1 cm range noise.
    lms.noise.sigma = 0.01;
    const sim::LaserScanner2D noisy(lms);
    const auto pose_at = [](double x) {
      const double k = 2 * pi / 6.0;
      return Pose2d{x, 1.0 + 0.25 * std::sin(k * x), std::atan(0.25 * k * std::cos(k * x))};
    };
    HayaiTracker<double> tracker({}, {}, pose_at(1.0));
    std::size_t registered = 0, steps = 0;
    for (double x = 1.0; x <= 9.0; x += 0.04, ++steps)
      if (tracker.track(noisy.scan(scene.world, pose_at(x), rng)).match.ok()) ++registered;
    const Pose2d truth = pose_at(1.0 + 0.04 * static_cast<double>(steps - 1));
    INFO("drift " << position_error(tracker.pose(), truth) << " m over 8 m, " << registered
                  << " of " << steps << " scans registered");
    CHECK(position_error(tracker.pose(), truth) < 0.04 * 8.0);
    CHECK(std::abs(angle_difference(tracker.pose().theta, truth.theta)) < deg_to_rad(10.0));
    CHECK(registered >= steps * 9 / 10);
  }
}

TEST_CASE("HAYAI registers virtual scans of the egocentric obstacle map", "[registration][hayai]") {
  // Paper 002 §4.4's obstacle map (360° in 0.5° bins) fed by a 360° scanner 0.3 m above the
  // floor; its virtual scan is an ordered scan like any other, its ranges read at bin centres.
  const auto world = hexagon_room();
  const PlanarMount<double> mount{{}, 0.3};
  // Beams at the bins' centres (beams on the bins' borders would share bins and leave others
  // empty, which splits the signal).
  const ScanGeometry<double> lidar{-pi + pi / 720, 2 * pi / 720, 720, 0.05, 30.0};
  ObstacleMap<double> map;
  map.insert(cast(world, {}, lidar), mount);
  const auto before = map.to_laser_scan();
  const Pose2d motion{0.12, -0.05, deg_to_rad(3.0)};
  map.update(motion, cast(world, motion, lidar), mount);
  const auto after = map.to_laser_scan();
  REQUIRE(covers_full_turn(after));
  const auto r = register_hayai(before, after);
  REQUIRE(r.ok());
  CHECK(extract_hayai_features(before).size() == 6);  // the hexagon's six corners
  CHECK(extract_hayai_features(after).size() == 6);
  CHECK(r.matched == 6);
  CHECK(r.shift.x == Approx(motion.x).margin(0.01));
  CHECK(r.shift.y == Approx(motion.y).margin(0.01));
  CHECK(r.shift.theta == Approx(motion.theta).margin(deg_to_rad(0.2)));
}

TEST_CASE("HAYAI works in single precision", "[registration][hayai]") {
  World world = hexagon_room();
  const auto a = cast(world, {}, full_turn_scan(720));
  const auto b = cast(world, {0.05, 0.02, 0.01}, full_turn_scan(720));
  const auto to_float = [](const LaserScand& s) {
    const auto& g = s.geometry();
    std::vector<float> ranges(s.ranges().begin(), s.ranges().end());
    return LaserScanf(
        ScanGeometry<float>{static_cast<float>(g.angle_min), static_cast<float>(g.angle_increment),
                            g.beam_count, static_cast<float>(g.range_min),
                            static_cast<float>(g.range_max)},
        ranges);
  };
  const auto result = register_hayai(to_float(a), to_float(b));
  REQUIRE(result.ok());
  CHECK(result.shift.x == Approx(0.05f).margin(2e-3));
  CHECK(result.shift.y == Approx(0.02f).margin(2e-3));
  CHECK(result.shift.theta == Approx(0.01f).margin(1e-3));
}

TEST_CASE("HAYAI rejects bad parameters and odometry with exact messages",
          "[registration][hayai]") {
  HayaiParams<double> p;
  p.line_fit_beams = 1;
  CHECK_THROWS_AS(HayaiFeatureExtractor<double>(p), invalid_argument);
  CHECK_THROWS_WITH(HayaiFeatureExtractor<double>(p),
                    "rangenav: HayaiFeatureExtractor: argument 'line_fit_beams' = 1 must be >= 2");
  p = {};
  p.max_match_distance = -1.0;
  CHECK_THROWS_WITH(HayaiMatcher<double>(p),
                    "rangenav: HayaiMatcher: argument 'max_match_distance' = -1 must be finite "
                    "and > 0");
  p = {};
  p.min_corner_angle = 2.0;
  CHECK_THROWS_WITH(HayaiTracker<double>(p),
                    "rangenav: HayaiFeatureExtractor: argument 'min_corner_angle' = 2 must be in "
                    "(0, pi/2]");
  p = {};
  p.omega_bearing = p.omega_range = p.omega_cartesian = 0.0;
  CHECK_THROWS_WITH(HayaiMatcher<double>(p),
                    "rangenav: HayaiMatcher: at least one of the weights omega_* must be > 0");
  p = {};
  p.min_matched_features = 1;
  CHECK_THROWS_WITH(register_hayai(LaserScand(), LaserScand(), p),
                    "rangenav: HayaiFeatureExtractor: argument 'min_matched_features' = 1 must be "
                    ">= 2");
  p = {};
  p.max_feature_sigma = 0.0;
  CHECK_THROWS_WITH(HayaiMatcher<double>(p),
                    "rangenav: HayaiMatcher: argument 'max_feature_sigma' = 0 must be finite and "
                    "> 0");
  HayaiOdometryNoise<double> noise;
  noise.innovation_gate = 0.0;
  CHECK_THROWS_WITH(
      HayaiTracker<double>({}, noise),
      "rangenav: HayaiTracker: argument 'innovation_gate' = 0 must be finite and > 0");
  HayaiTracker<double> tracker;
  CHECK_THROWS_WITH(
      tracker.track(LaserScand(), Pose2d{0.0, std::numeric_limits<double>::quiet_NaN(), 0.0}),
      "rangenav: HayaiTracker::track: argument 'odometry_increment.y' = nan must be finite");
}
