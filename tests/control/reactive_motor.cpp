// Reactive behaviours (paper 002 §5, paper 003 §2.2.2) in closed form, and the feed-forward + PI
// motor controller (paper 003 §2.1) on a first-order (PT1) motor model.

#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <vector>

#include "rangenav/control/motor_control.hpp"
#include "rangenav/control/reactive.hpp"
#include "rangenav/sim/motor.hpp"

using Catch::Matchers::Equals;
using rangenav::Point2d;

namespace {
constexpr double pi = std::numbers::pi;
}

TEST_CASE("reactive: virtual roadway speed law") {
  const rangenav::VirtualRoadwayParams r;  // 0.5 m, 6 m, 4 m/s (Kurt3D)
  CHECK(rangenav::roadway_speed(10.0, r) == 4.0);
  CHECK(rangenav::roadway_speed(6.0, r) == 4.0);
  CHECK(rangenav::roadway_speed(3.0, r) == Approx(3.0 / 6.0 * 4.0));  // v = dto / dto_max v_max
  CHECK(rangenav::roadway_speed(0.5, r) == Approx(0.5 / 6.0 * 4.0));
  CHECK(rangenav::roadway_speed(0.49, r) == 0.0);
  CHECK(rangenav::roadway_speed(NAN, r) == 0.0);

  // Only points on the roadway (|y| <= half width, ahead) count.
  const std::vector<Point2d> pts{{2.0, 0.1}, {1.0, 0.5}, {-0.5, 0.0}, {3.0, -0.16}};
  CHECK(rangenav::roadway_distance(pts, r) == Approx(2.0));
  rangenav::VirtualRoadwayParams front = r;
  front.front_offset = 0.3;
  CHECK(rangenav::roadway_distance(pts, front) == Approx(1.7));
  CHECK(std::isinf(rangenav::roadway_distance(std::vector<Point2d>{}, r)));
}

TEST_CASE("reactive: free-space orientation, Eqs. (5) and (6) of paper 002") {
  CHECK(rangenav::free_space_angle_weight(0.0) == 1.0);
  CHECK(rangenav::free_space_angle_weight(0.6) == Approx(std::cos(0.5)));
  CHECK(rangenav::free_space_angle_weight(2.5) == 0.0);             // cos(2.08) < 0 clamped
  CHECK(rangenav::free_space_distance_weight(6.0) == Approx(0.5));  // inflection at dto_max
  CHECK(rangenav::free_space_distance_weight(6.5) == Approx(1.0 / (1.0 + std::exp(-1.0))));

  // Two readings: the weighted mean direction, closed form.
  const std::vector<Point2d> two{{4.0 * std::cos(0.3), 4.0 * std::sin(0.3)},
                                 {8.0 * std::cos(-0.5), 8.0 * std::sin(-0.5)}};
  const double w1 = std::cos(0.3 / 1.2) / (1 + std::exp(-(4.0 - 6.0) / 0.5));
  const double w2 = std::cos(0.5 / 1.2) / (1 + std::exp(-(8.0 - 6.0) / 0.5));
  const auto alpha = rangenav::free_space_orientation(two);
  REQUIRE(alpha);
  CHECK(*alpha == Approx(std::atan2(std::sin(0.3) * w1 + std::sin(-0.5) * w2,
                                    std::cos(0.3) * w1 + std::cos(-0.5) * w2)));
  CHECK(!rangenav::free_space_orientation(std::vector<Point2d>{}));

  // A corridor whose left wall is nearer than its right one: free space lies to the right.
  rangenav::ScanGeometry<double> geo{-pi / 2, pi / 180, 181, 0.02, 30.0};
  std::vector<double> ranges(181);
  for (std::size_t i = 0; i < 181; ++i) {
    const double a = geo.angle(i);
    const double to_wall = a > 0 ? 1.0 / std::sin(a) : (a < 0 ? -3.0 / std::sin(a) : 30.0);
    ranges[i] = std::min(to_wall, 30.0);  // 30 m = range_max: nothing seen
  }
  const rangenav::LaserScan<double> scan(geo, ranges);
  const auto free = rangenav::free_space_orientation(scan);
  REQUIRE(free);
  CHECK(*free < -0.01);
  // Mirrored corridor, mirrored answer.
  std::vector<double> mirrored(ranges.rbegin(), ranges.rend());
  CHECK(*rangenav::free_space_orientation(rangenav::LaserScan<double>(geo, mirrored)) ==
        Approx(-*free));
}

TEST_CASE("reactive: behaviours scale, stop, turn, back off and bend toward free space") {
  rangenav::ReactiveParams p;
  p.roadway.v_max = 0.3;
  p.roadway.dto_max = 1.5;
  p.roadway.dto_min = 0.4;
  p.free_space.influence = 0.0;
  rangenav::ReactiveBehaviours b(p);
  const std::vector<Point2d> ahead{{1.0, 0.0}};
  auto cmd = b.apply(0.3, 0.1, ahead);
  CHECK(cmd.dto == Approx(1.0));
  CHECK(cmd.v == Approx(0.3 * 1.0 / 1.5));
  CHECK(cmd.omega == Approx(0.1));
  CHECK(!cmd.stopped);
  // Below dto_min: stop and turn on the spot toward free space (a wall on the left -> right).
  // Only the far reading on the right carries weight (f_d of the near ones is ~1e-5).
  const std::vector<Point2d> close{{0.3, 0.0}, {0.3, 0.3}, {0.2, 0.5}, {0.0, 0.6}, {0.5, -5.0}};
  cmd = b.apply(0.3, 0.0, close);
  CHECK(cmd.stopped);
  CHECK(cmd.v == 0.0);
  CHECK(cmd.omega == Approx(-p.roadway.turn_rate));
  // A goal-directed controller that wants to turn left keeps its sense of turn
  // (StopTurn::commanded); without a commanded turn the free-space vote decides.
  rangenav::ReactiveParams keep = p;
  keep.stop_turn = rangenav::StopTurn::commanded;
  CHECK(rangenav::ReactiveBehaviours(keep).apply(0.3, 0.4, close).omega ==
        Approx(p.roadway.turn_rate));
  CHECK(b.apply(0.3, 0.4, close).omega == Approx(-p.roadway.turn_rate));
  CHECK(rangenav::ReactiveBehaviours(keep).apply(0.3, 0.0, close).omega ==
        Approx(-p.roadway.turn_rate));
  // Once stopped, the robot keeps its sense of turn until the roadway is free, even when the
  // free-space vote flips (no twitching left and right on the spot).
  rangenav::ReactiveBehaviours latch(p);
  const std::vector<Point2d> mirrored{
      {0.3, 0.0}, {0.3, -0.3}, {0.2, -0.5}, {0.0, -0.6}, {0.5, 5.0}};
  CHECK(latch.apply(0.3, 0.0, close).omega == Approx(-p.roadway.turn_rate));
  CHECK(latch.apply(0.3, 0.0, mirrored).omega == Approx(-p.roadway.turn_rate));
  CHECK(!latch.apply(0.3, 0.0, ahead).stopped);  // free: the next stop decides anew
  CHECK(latch.apply(0.3, 0.0, mirrored).omega == Approx(p.roadway.turn_rate));
  latch.reset();
  CHECK(latch.apply(0.3, 0.0, close).omega == Approx(-p.roadway.turn_rate));
  // ... or back off.
  rangenav::ReactiveParams back = p;
  back.roadway.backoff_speed = 0.1;
  cmd = rangenav::ReactiveBehaviours(back).apply(0.3, 0.0, close);
  CHECK(cmd.v == Approx(-0.1));
  CHECK(cmd.omega == 0.0);
  // Free roadway: unchanged speed; free-space influence adds influence * alpha_free.
  rangenav::ReactiveParams bend = p;
  bend.free_space.influence = 0.2;
  const std::vector<Point2d> side{{2.0, 0.8}};
  cmd = rangenav::ReactiveBehaviours(bend).apply(0.3, 0.0, side);
  CHECK(cmd.v == Approx(0.3));
  REQUIRE(cmd.alpha_free);
  CHECK(*cmd.alpha_free == Approx(std::atan2(0.8, 2.0)));
  CHECK(cmd.omega == Approx(0.2 * std::atan2(0.8, 2.0)));

  rangenav::ReactiveParams bad;
  bad.roadway.dto_max = 0.2;
  CHECK_THROWS_WITH(rangenav::ReactiveBehaviours(bad),
                    Equals("rangenav: ReactiveBehaviours: argument 'roadway.dto_max' = "
                           "0.20000000000000001 must exceed dto_min = 0.5"));
}

namespace {

// The no-load characteristic of a motor, measured like paper 003 Fig. 2 (right): non-linear in
// the upper range.
rangenav::SpeedPwmTable measured_table() {
  std::vector<double> pwm, speed;
  for (int i = 0; i <= 1023; i += 31) {
    pwm.push_back(i);
    speed.push_back(5.2 * (1.0 - std::exp(-i / 400.0)));
  }
  return {pwm, speed};
}

// The simulator's first-order (PT1) motor on the table's characteristic (paper 003 Fig. 2, left).
rangenav::sim::Pt1Motor pt1_motor(const rangenav::SpeedPwmTable& t, double gain = 1.0) {
  return rangenav::sim::Pt1Motor([&t](double u) { return t.speed(u); },
                                 {.time_constant = 0.15, .gain = gain, .load_offset = 0.2});
}

}  // namespace

TEST_CASE("motor: lookup table and its inverse") {
  const auto t = measured_table();
  for (double v : {0.3, 1.0, 2.5, 4.0}) {
    CHECK(t.speed(t.pwm(v)) == Approx(v).epsilon(1e-12));
    CHECK(t.pwm(-v) == Approx(-t.pwm(v)));
  }
  CHECK(t.pwm(100.0) == t.max_pwm());
  const rangenav::SpeedPwmTable flat({0, 10, 20, 30}, {0, 1, 1, 2});
  CHECK(flat.pwm(1.0) == Approx(10.0));  // the lowest PWM of a flat stretch
  CHECK(flat.speed(15.0) == Approx(1.0));
  CHECK_THROWS_WITH(rangenav::SpeedPwmTable({0, 10, 10}, {0, 1, 2}),
                    Equals("rangenav: SpeedPwmTable: argument 'pwm[2]' = 10 must exceed the "
                           "previous entry"));
  CHECK_THROWS_WITH(rangenav::SpeedPwmTable({0, 10}, {0, NAN}),
                    Equals("rangenav: SpeedPwmTable: argument 'speed[1]' = nan must be finite"));
  CHECK_THROWS_WITH(rangenav::SpeedPwmTable({0, 10}, {0}),
                    Equals("rangenav: SpeedPwmTable: argument 'speed.size()' = 1 must equal "
                           "pwm.size() = 2"));
}

TEST_CASE("motor: feed-forward + PI tracks speed steps on a PT1 motor") {
  const auto table = measured_table();
  rangenav::MotorControllerParams params;
  params.load_offset = 0.2;  // the carpet offset, known from the measurement
  params.max_pwm_step = 200.0;
  const double dt = params.dt;
  // A weak battery: the motor delivers 85 % of the table's speed, which only the PI term sees.
  for (const double battery : {1.0, 0.85}) {
    rangenav::MotorController pi_control(table, params);
    rangenav::MotorControllerParams ff_only_params = params;
    ff_only_params.kp = ff_only_params.ki = 0.0;
    rangenav::MotorController ff_only(table, ff_only_params);
    rangenav::sim::Pt1Motor motor = pt1_motor(table, battery), open = pt1_motor(table, battery);
    double previous = 0.0;
    for (const double set : {1.0, 2.5, 0.5, -1.0}) {
      const double direction = set > previous ? 1.0 : -1.0;
      double overshoot = 0.0;
      for (int k = 0; k < 300; ++k) {  // 3 s per step
        const double before = pi_control.output();
        const double u = pi_control.step(set, motor.speed());
        REQUIRE(std::abs(u) <= 1023.0);                 // within the PWM band
        REQUIRE(std::abs(u - before) <= 200.0 + 1e-9);  // and its change per cycle limited
        motor.step(u, dt);
        open.step(ff_only.step(set, open.speed()), dt);
        overshoot = std::max(overshoot, (motor.speed() - set) * direction);
      }
      INFO("battery " << battery << ", set " << set);
      CHECK(motor.speed() == Approx(set).epsilon(0.01).margin(0.01));  // within 1 % after 3 s
      CHECK(overshoot <= 0.1 * std::abs(set - previous));              // small overshoot
      previous = set;
      if (battery == 1.0)
        CHECK(open.speed() ==
              Approx(set).margin(0.01));  // feed-forward alone hits the working point
      else
        CHECK(std::abs(open.speed() - set) > 0.05);  // ... but not with a weak battery
    }
  }
  rangenav::MotorControllerParams bad;
  bad.side = 0.5;
  CHECK_THROWS_WITH(
      rangenav::MotorController(table, bad),
      Equals("rangenav: MotorController: argument 'params.side' = 0.5 must be +1 or -1"));
  bad = {};
  bad.dt = 0.0;
  CHECK_THROWS_WITH(
      rangenav::MotorController(table, bad),
      Equals("rangenav: MotorController: argument 'params.dt' = 0 must be finite and > 0"));
}

TEST_CASE("motor: the F_omega feed-forward term compensates the turning friction") {
  const auto table = measured_table();
  // Paper 003: F_omega = 1 / pi cm.
  CHECK(rangenav::MotorControllerParams{}.feed_forward_omega == Approx(0.01 / pi));
  // A skid-steered wheel loses c |omega| against its turning direction while the robot turns
  // (here c = 5 cm per rad/s): steady speed = T(pwm) - offset - side c omega.
  const double c = 0.05, dt = 0.01;
  for (const double side : {1.0, -1.0}) {
    for (const double f_omega : {c, 0.0}) {
      rangenav::MotorControllerParams params;
      params.load_offset = 0.2;
      params.kp = params.ki = 0.0;  // feed-forward alone
      params.feed_forward_omega = f_omega;
      params.side = side;
      rangenav::MotorController control(table, params);
      const double omega = 2.0, v_set = 1.0 + side * 0.2 * omega;  // v +- omega b / 2, b = 0.4 m
      // Closed form: T^-1(F_v v + side F_omega omega + offset).
      CHECK(control.feed_forward(v_set, omega) ==
            Approx(table.pwm(v_set + side * f_omega * omega + 0.2)));
      rangenav::sim::Pt1Motor motor = pt1_motor(table);
      for (int k = 0; k < 300; ++k)
        motor.step(control.step(v_set, motor.speed(), omega), dt, side * c * omega);
      INFO("side " << side << ", F_omega " << f_omega);
      if (f_omega == c)
        CHECK(motor.speed() == Approx(v_set).margin(1e-6));  // hits the set speed while turning
      else
        CHECK(motor.speed() == Approx(v_set - side * c * omega).margin(1e-6));  // misses by c omega
    }
  }
  // Driving straight, the term vanishes.
  const rangenav::MotorController straight(table);
  CHECK(straight.feed_forward(1.0, 0.0) == Approx(table.pwm(1.0)));
}
