#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "rangenav/sim/motor.hpp"
#include "rangenav/sim/robot.hpp"
#include "rangenav/sim/worlds.hpp"

#include "test_support.hpp"

using namespace rangenav;
using namespace rangenav::sim;

namespace {
const double pi = std::numbers::pi;

using rangenav::test::mean;
using rangenav::test::stddev;
}  // namespace

TEST_CASE("differential drive kinematics: lines and arcs", "[sim][robot]") {
  World empty;
  empty.build_index();
  DifferentialDriveRobot robot({}, {1, 2, 0});
  std::mt19937 rng(1);
  // 1 s at 0.5 m/s straight: 0.5 m.
  for (int i = 0; i < 50; ++i)
    robot.step(empty, 0.5, 0.0, rng);
  CHECK(robot.time() == Approx(1.0));
  CHECK(robot.pose().x == Approx(1.5));
  CHECK(robot.pose().y == Approx(2.0));
  // A quarter circle of radius 1 (v = 0.5, omega = 0.5) takes pi seconds.
  robot.reset({0, 0, 0});
  const int steps = static_cast<int>(std::lround(pi / robot.dt()));
  for (int i = 0; i < steps; ++i)
    robot.step(empty, 0.5, 0.5, rng);
  const double t = steps * robot.dt();
  CHECK(robot.pose().x == Approx(std::sin(0.5 * t)));
  CHECK(robot.pose().y == Approx(1 - std::cos(0.5 * t)));
  CHECK(robot.pose().theta == Approx(0.5 * t));
  // No odometry error configured: odometry is the true pose.
  CHECK(robot.odometry() == robot.pose());
  // Commands are clamped.
  robot.reset({0, 0, 0});
  robot.step(empty, 5.0, 0.0, rng);
  CHECK(robot.pose().x == Approx(robot.params().max_v * robot.dt()));
}

TEST_CASE("odometry error statistics match the configured noise", "[sim][robot]") {
  World empty;
  empty.build_index();
  DifferentialDriveParams p;
  p.odometry = {0.05, -0.02, 0.01, 0.03, 0.02};
  DifferentialDriveRobot robot(p, {0, 0, 0});
  std::mt19937 rng(123);
  std::vector<double> v_err, w_err;
  for (int i = 0; i < 20000; ++i) {
    const double v = 0.4, w = (i / 500) % 2 ? 0.3 : -0.3;
    const StepResult r = robot.step(empty, v, w, rng);
    REQUIRE(r.moved);
    v_err.push_back(r.v_measured - v);
    w_err.push_back(r.omega_measured - w);
  }
  CHECK(mean(v_err) == Approx(0.05 * 0.4).epsilon(0.03));
  CHECK(stddev(v_err) == Approx(0.03).epsilon(0.03));
  // omega alternates sign, so the scale error averages out and the bias remains.
  CHECK(mean(w_err) == Approx(0.01).epsilon(0.05));
  CHECK(stddev(w_err) == Approx(std::sqrt(0.02 * 0.02 + 0.02 * 0.02 * 0.3 * 0.3)).epsilon(0.03));
  // A pure scale error: 10 m driven, 10.5 m in the odometry; the true pose is exact.
  DifferentialDriveParams s;
  s.odometry.v_scale = 0.05;
  DifferentialDriveRobot straight(s, {0, 0, 0});
  for (int i = 0; i < 1000; ++i)
    straight.step(empty, 0.5, 0.0, rng);
  CHECK(straight.pose().x == Approx(10.0));
  CHECK(straight.odometry().x == Approx(10.5));
  CHECK(straight.odometry().y == Approx(0.0).margin(1e-12));
  // The same seed gives the same odometry.
  DifferentialDriveRobot a(p, {0, 0, 0}), b(p, {0, 0, 0});
  std::mt19937 ra(8), rb(8);
  for (int i = 0; i < 100; ++i) {
    a.step(empty, 0.3, 0.1, ra);
    b.step(empty, 0.3, 0.1, rb);
  }
  CHECK(a.odometry() == b.odometry());
  CHECK_FALSE(a.odometry() == a.pose());
}

TEST_CASE("collisions: circle and rectangle footprints with a height band", "[sim][robot]") {
  World w;
  w.add_wall({2, -5}, {2, 5});
  w.add_box({{-2, 0}, {1.0, 0.6}, 0, 0.40, 0.44});  // a table top, legs omitted
  w.add_cylinder({{0, 2}, 0.05, 0, 0.1});
  w.add_hole({{0, -2.5}, {1, 1}, 0, 0.5});
  w.build_index();
  const Footprint circle = Footprint::circle(0.3, 0.02, 1.2);
  CHECK(footprint_contacts(w, circle, {1.65, 0, 0}).empty());
  const auto wall = footprint_contacts(w, circle, {1.75, 0, 0});
  REQUIRE(wall.size() == 1);
  CHECK(wall[0] == PrimitiveRef{SurfaceKind::wall, 0});
  // Under the table top: a tall robot touches it, a low one (top at 0.35 m) drives under.
  CHECK(footprint_contacts(w, circle, {-2, 0, 0}).size() == 1);
  CHECK(footprint_contacts(w, Footprint::circle(0.3, 0.02, 0.35), {-2, 0, 0}).empty());
  // The 10 cm object is touched unless the robot's clearance is higher.
  CHECK(footprint_contacts(w, circle, {0, 2.3, 0}).size() == 1);
  CHECK(footprint_contacts(w, Footprint::circle(0.3, 0.12, 1.2), {0, 2.3, 0}).empty());
  CHECK(footprint_contacts(w, circle, {0, 2.36, 0}).empty());
  // Over the hole.
  const auto hole = footprint_contacts(w, circle, {0, -1.8, 0});
  REQUIRE(hole.size() == 1);
  CHECK(hole[0].kind == SurfaceKind::hole);
  // Rectangle 0.6 x 0.4: axis-aligned its front is at 1.95; turned 45 deg its corner reaches
  // 1.65 + (0.3 + 0.2) / sqrt(2) = 2.004.
  const Footprint rect = Footprint::rectangle(0.6, 0.4);
  CHECK(footprint_contacts(w, rect, {1.65, 0, 0}).empty());
  CHECK(footprint_contacts(w, rect, {1.65, 0, pi / 4}).size() == 1);
  CHECK(footprint_contacts(w, rect, {1.65, 0, pi / 2}).empty());
  // Driving into the wall: the robot stops in front of it and reports the contact.
  DifferentialDriveRobot robot({}, {0.5, 0, 0});
  std::mt19937 rng(1);
  StepResult last;
  for (int i = 0; i < 200 && last.moved; ++i)
    last = robot.step(w, 0.5, 0, rng);
  CHECK_FALSE(last.moved);
  REQUIRE(last.contacts.size() == 1);
  CHECK(last.contacts[0].kind == SurfaceKind::wall);
  CHECK(robot.pose().x < 1.7);
  CHECK(robot.pose().x > 1.7 - 0.5 * robot.dt() - 1e-9);
  CHECK_THROWS_WITH(DifferentialDriveRobot({0, 1, 1, Footprint::circle(0.3)}),
                    "rangenav: DifferentialDriveRobot: argument 'control_rate' = 0 must be finite "
                    "and > 0");
}

TEST_CASE("footprint clearance: closed form, and zero exactly where contacts begin",
          "[sim][robot]") {
  World w;
  w.add_wall({2, -5}, {2, 5});
  w.add_box({{-2, 0}, {1.0, 0.6}, 0, 0.40, 0.44});  // a table top
  w.add_cylinder({{0, 2}, 0.05, 0, 0.1});
  w.add_hole({{0, -2.5}, {1, 1}, 0, 0.5});
  w.build_index();
  const Footprint circle = Footprint::circle(0.3, 0.02, 1.2);
  CHECK(footprint_clearance(w, circle, {1.2, 0, 0}) == Approx(0.5));         // the wall
  CHECK(footprint_clearance(w, circle, {0, 1.5, 0}) == Approx(0.5 - 0.35));  // the can
  CHECK(footprint_clearance(w, circle, {0, -1.6, 0}) == Approx(0.4 - 0.3));  // the stair hole
  CHECK(footprint_clearance(w, circle, {-2, 0.9, 0}) == Approx(0.6 - 0.3));  // the table top
  CHECK(footprint_clearance(w, Footprint::circle(0.3, 0.02, 0.35), {-2, 0.9, 0}) == 1.0);  // under
  CHECK(footprint_clearance(w, circle, {0, 0, 0}, 0.5) == 0.5);  // nothing within 0.5 m
  CHECK(footprint_clearance(w, circle, {1.8, 0, 0}) == 0.0);     // touching
  const Footprint rect = Footprint::rectangle(0.6, 0.4);  // front 0.3 ahead, corner at 45 deg
  CHECK(footprint_clearance(w, rect, {1.2, 0, 0}) == Approx(0.5));
  CHECK(footprint_clearance(w, rect, {1.2, 0, pi / 4}) == Approx(0.8 - 0.5 / std::sqrt(2.0)));
  // Against footprint_contacts on random poses in the apartment: zero iff touching, and a
  // footprint grown by the clearance (minus a hair) touches nothing.
  const Scene apt = apartment();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> x(0.2, 9.8), a(-pi, pi);
  for (int i = 0; i < 300; ++i) {
    const Pose2d p{x(rng), x(rng), a(rng)};
    const double c = footprint_clearance(apt.world, circle, p);
    CHECK((c == 0.0) == !footprint_contacts(apt.world, circle, p).empty());
    if (c > 0.002)
      CHECK(
          footprint_contacts(apt.world, Footprint::circle(0.3 + c - 0.001, 0.02, 1.2), p).empty());
  }
}

TEST_CASE("the built-in worlds' start poses and tours are collision-free", "[sim][robot]") {
  const Footprint fp = Footprint::circle(0.3, 0.02, 1.5);
  for (const Scene& s : {apartment(), office_corridor(), kitchen()}) {
    CHECK(footprint_contacts(s.world, fp, s.start).empty());
    Point2d from = s.start.position();
    for (const Point2d& to : s.tour) {
      const double len = (to - from).norm();
      for (double d = 0; d <= len; d += 0.05) {
        const Point2d q = from + (to - from) * (d / len);
        INFO("at " << q.transpose());
        CHECK(footprint_contacts(s.world, fp, {q.x(), q.y(), 0}).empty());
      }
      from = to;
    }
  }
}

TEST_CASE("PT1 motor: step response in closed form", "[sim][motor]") {
  // A linear no-load characteristic T(u) = 0.005 u (m/s per PWM unit).
  const auto linear = [](double u) { return 0.005 * u; };
  const Pt1MotorParams params{.time_constant = 0.2, .gain = 0.9, .load_offset = 0.1};
  // Step from rest to u = 400: v_ss = 0.9 * 2.0 - 0.1 = 1.7 m/s, v(t) = v_ss (1 - e^{-t/tau}).
  for (const double dt : {0.001, 0.01, 0.05}) {
    Pt1Motor motor(linear, params);
    CHECK(motor.steady_state_speed(400.0) == Approx(1.7));
    double t = 0;
    for (int k = 0; k < static_cast<int>(std::lround(1.0 / dt)); ++k) {
      motor.step(400.0, dt);
      t += dt;
      INFO("dt " << dt << ", t " << t);
      REQUIRE(motor.speed() == Approx(1.7 * (1 - std::exp(-t / 0.2))).margin(1e-12));
    }
  }
  // 63.2 % of the step after one time constant, from any initial speed, in either direction.
  Pt1Motor motor(linear, params, 1.0);
  motor.step(-400.0, 0.2);
  CHECK(motor.speed() == Approx(-1.7 + (1.0 + 1.7) * std::exp(-1.0)));
  // The floor's offset eats small commands: below it the wheel coasts to a stop, not backwards.
  CHECK(motor.steady_state_speed(10.0) == 0.0);
  CHECK(motor.steady_state_speed(-10.0) == 0.0);
  CHECK(motor.steady_state_speed(0.0) == 0.0);
  // An extra signed load shifts the steady state (turning friction of one wheel).
  CHECK(motor.steady_state_speed(400.0, 0.25) == Approx(1.45));
  CHECK(motor.steady_state_speed(-400.0, 0.25) == Approx(-1.95));  // counted along +v
  CHECK(motor.steady_state_speed(400.0, -0.25) == Approx(1.95));
  // Friction stops a wheel but neither reverses it nor drives an undriven one.
  CHECK(motor.steady_state_speed(400.0, 2.0) == 0.0);
  CHECK(motor.steady_state_speed(-400.0, -2.0) == 0.0);
  CHECK(motor.steady_state_speed(0.0, 0.25) == 0.0);
  CHECK(motor.steady_state_speed(0.0, -0.25) == 0.0);
  motor.reset(0.5);
  for (int k = 0; k < 500; ++k)
    motor.step(0.0, 0.01);
  CHECK(motor.speed() == Approx(0.5 * std::exp(-5.0 / 0.2)).margin(1e-12));
  // Degenerate steps change nothing; a NaN command counts as 0.
  motor.reset(0.3);
  CHECK(motor.step(400.0, 0.0) == 0.3);
  CHECK(motor.step(400.0, std::nan("")) == 0.3);
  CHECK(motor.step(std::nan(""), 0.2) == Approx(0.3 * std::exp(-1.0)));

  using Catch::Matchers::Equals;
  CHECK_THROWS_WITH(Pt1Motor(linear, {.time_constant = 0.0}),
                    Equals("rangenav: Pt1MotorParams: argument 'time_constant' = 0 must be finite "
                           "and > 0"));
  CHECK_THROWS_WITH(
      Pt1Motor(linear, {.gain = -1.0}),
      Equals("rangenav: Pt1MotorParams: argument 'gain' = -1 must be finite and >= 0"));
  CHECK_THROWS_WITH(Pt1Motor(nullptr),
                    Equals("rangenav: Pt1Motor: argument 'no_load_speed' is empty"));
  CHECK_THROWS_WITH(Pt1Motor(linear, {}, std::nan("")),
                    Equals("rangenav: Pt1Motor: argument 'initial_speed' = nan must be finite"));
}
