// Lesson 09: reactive collision avoidance, 2D against 3D sensing (paper 002 §5.2).
//
// A robot in an arena of low walls is commanded to drive forward at a constant 0.3 m/s; the three
// reactive behaviours of paper 002 §5 (virtual-roadway speed scaling, stop and turn on the spot,
// free-space orientation) adapt that command using an egocentric obstacle map. Small objects
// (8-10 cm high) lie on the floor in its way. It runs twice: with 2D perception (the scanner held
// horizontal, a plain 2D laser: the objects lie below it) and with 3D perception (the same
// scanner nodding, §3.3, its stream turned into obstacle points by the floor classification).
// The simulator refuses a step that would touch something (a bumper hit: the robot backs off and
// turns away) and counts these contacts: the 2D robot runs into the objects, the 3D robot turns
// away from them. Neither finds the exit in 45 s: the behaviours wander, as the paper notes.
//
// One detail matters in 3D: the nodding scanner cannot see the floor nearer than about 0.8 m
// (pitching_blind_range). While the robot turns on the spot in front of an object, the map's
// ageing (§4.4.2) would forget it there; VirtualMapParams::blind_range keeps such points.
//
// Run it as `09_avoidance [svg]` to also draw the runs (the arena and its drawing are in
// support/arena.hpp). Both runs are repeated with four noise seeds; it exits with status 1 unless
// every 2D run touches something and no 3D run anything (ctest runs it as a check). The last line
// printed is JSON.

#include <cstdint>
#include <iostream>
#include <numbers>
#include <random>
#include <set>
#include <vector>

#include "rangenav/control/reactive.hpp"
#include "rangenav/egocentric/pitching_stream.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/sim/robot.hpp"
#include "rangenav/sim/sensors.hpp"

#include "support/arena.hpp"

using namespace rangenav;

namespace {

constexpr double duration = 45.0;  // s of simulated time per run
constexpr double speed = 0.3;      // m/s, the commanded translational velocity (§5.2)

struct RunResult {
  std::vector<Point2d> trajectory;  // every 0.1 s
  std::vector<double> times;
  std::size_t contacts = 0;  // refused steps that started a contact
  std::set<std::uint32_t> objects_hit;
  bool escaped = false;  // left the arena through the exit
};

// One run: `three_d` selects the nodding scanner, otherwise it is held horizontal. The robot
// adapts the constant forward command using nothing but the obstacle map.
RunResult run(const sim::World& world, bool three_d, std::size_t wall_count, unsigned seed) {
  std::mt19937 rng(seed);
  sim::DifferentialDriveParams rp;
  rp.control_rate = 50.0;
  rp.max_v = 0.5;
  rp.footprint = sim::Footprint::circle(0.22, 0.01, 0.6);
  sim::DifferentialDriveRobot robot(rp, {0.6, 0.6, std::numbers::pi / 4});

  sim::PitchingScannerParams sp;  // SICK LMS 2xx on a pitch unit: 181 beams, 75 Hz
  sp.noise.sigma = 0.005;
  const sim::PitchingScanner nodding(sp);
  sim::LaserScannerParams lp;  // the same scanner held horizontal at the same place
  lp.geometry = sp.geometry;
  lp.mount = sim::mounting(sp.sensor_offset.x(), sp.sensor_offset.y(), sp.sensor_offset.z());
  lp.noise.sigma = 0.005;
  const sim::LaserScanner2D horizontal(lp);
  const PlanarMount<double> mount{{sp.sensor_offset.x(), sp.sensor_offset.y(), 0.0},
                                  sp.sensor_offset.z()};

  PitchingObstacleExtractor<double> extractor(sp.sensor_offset);  // floor removed
  VirtualMapParams<double> mp;
  mp.max_age = 225;  // 3 s at 75 Hz
  // Points the nodding scanner cannot measure again are not aged out; a 2D scanner sees all
  // around its plane and has no blind zone.
  if (three_d) mp.blind_range = pitching_blind_range(sp.sensor_offset, sp.pitch_max);
  ObstacleMap<double> map(mp, ObstacleMapPolicy{0.0, 0.6});  // the robot's height band

  // The behaviours, set for a slow indoor robot (paper 003's Kurt3D values are for 4 m/s).
  ReactiveParams behaviour;
  behaviour.roadway.half_width = 0.27;    // robot radius + 5 cm
  behaviour.roadway.front_offset = 0.22;  // dto from the robot's front
  behaviour.roadway.dto_min = behaviour.free_space.dto_min = 0.25;
  behaviour.roadway.dto_max = behaviour.free_space.dto_max = 1.0;
  behaviour.roadway.v_max = speed;
  behaviour.roadway.turn_rate = 0.9;
  behaviour.free_space.influence = 0.6;
  ReactiveBehaviours reactive(behaviour);

  RunResult result;
  Pose2d previous_odometry = robot.odometry();
  std::size_t scan_index = 0;
  double backoff_until = -1.0, reflex_turn = 1.2;
  bool in_contact = false;
  while (robot.time() < duration && !result.escaped) {
    const double t = robot.time();
    // Perception: every scan the scanner takes during this control period (75 Hz vs 50 Hz),
    // moved into the robot's frame by the odometry since the last one.
    while (nodding.scan_time(scan_index) <= t) {
      const double ts = nodding.scan_time(scan_index++);
      const Pose2d odometry = robot.odometry();
      const Pose2d motion = relative(previous_odometry, odometry);
      previous_odometry = odometry;
      if (three_d)
        map.update(motion, extractor.push(nodding.scan(world, robot.pose(), ts, rng), odometry));
      else
        map.update(motion, horizontal.scan(world, robot.pose(), rng, ts), mount);
    }
    // Behaviours: drive forward at 0.3 m/s, adapted to the obstacle map; after a contact the
    // bumper reflex backs off for 0.5 s, then turns away for 1 s.
    double v = -0.15, omega = 0.0;
    if (t >= backoff_until - 1.0) {
      v = 0.0;
      omega = reflex_turn;
    }
    if (t >= backoff_until) {
      const ReactiveCommand cmd = reactive.apply(speed, 0.0, map);
      v = cmd.v;
      omega = cmd.omega;
    }
    const sim::StepResult step = robot.step(world, v, omega, rng);
    if (!step.moved) {
      if (!in_contact) ++result.contacts;
      in_contact = true;
      for (const sim::PrimitiveRef& ref : step.contacts)
        if (ref.kind != sim::SurfaceKind::wall || ref.index >= wall_count)
          result.objects_hit.insert(static_cast<std::uint32_t>(ref.kind) * 1000 + ref.index);
      backoff_until = robot.time() + 1.5;
      reflex_turn = std::bernoulli_distribution(0.5)(rng) ? 1.2 : -1.2;
    } else if (t >= backoff_until) {
      in_contact = false;
    }
    if (result.times.empty() || robot.time() - result.times.back() >= 0.1) {
      result.trajectory.push_back(robot.pose().position());
      result.times.push_back(robot.time());
    }
    result.escaped = robot.pose().x > arena::side + 0.3;
  }
  return result;
}

void print(const char* name, const RunResult& r) {
  std::cout << name << r.contacts << " contacts, " << r.objects_hit.size() << " objects hit, "
            << (r.escaped ? "left the arena" : "still inside") << " after " << r.times.back()
            << " s\n";
}

}  // namespace

int main(int argc, char** argv) {
  std::cout << std::boolalpha;
  // Where do the objects go? Into the robot's way: a first 2D run in the empty arena gives the
  // path the behaviours take; the test objects are put on it, as one would lay them out in front
  // of the real robot.
  const sim::World empty = arena::world({});
  const std::size_t walls = empty.walls().size();
  const RunResult probe = run(empty, false, walls, 2);
  std::vector<Point2d> objects;  // one every 5 s from 6 s on, away from the walls
  for (std::size_t i = 0; i < probe.times.size() && objects.size() < 5; ++i) {
    const Point2d p = probe.trajectory[i];
    if (probe.times[i] >= 6.0 + 5.0 * static_cast<double>(objects.size()) && p.x() > 0.4 &&
        p.y() > 0.4 && p.x() < arena::side - 0.4 && p.y() < arena::side - 0.4)
      objects.push_back(p);
  }
  const sim::World world = arena::world(objects);

  const RunResult flat = run(world, false, walls, 2);
  const RunResult nodding = run(world, true, walls, 3);
  // The result must not hang on one noise draw: the same layout again with other seeds (sensor
  // noise, odometry noise and bumper reflexes differ), each 2D run must touch something and no
  // 3D run anything.
  constexpr unsigned trials = 4;
  std::size_t collided_2d = flat.contacts > 0, contacts_3d_all = nodding.contacts;
  for (unsigned k = 1; k < trials; ++k) {
    collided_2d += run(world, false, walls, 2 + 10 * k).contacts > 0;
    contacts_3d_all += run(world, true, walls, 3 + 10 * k).contacts;
  }

  std::cout << "arena " << arena::side << " m x " << arena::side << " m, exit " << arena::exit_width
            << " m wide; " << objects.size() << " small objects (8-10 cm high) on the floor\n";
  print("2D perception (scanner horizontal): ", flat);
  print("3D perception (scanner nodding):    ", nodding);
  std::cout << "over " << trials << " noise seeds: 2D perception touched something in "
            << collided_2d << ", 3D perception made " << contacts_3d_all << " contacts in all\n";

  if (argc > 1) {  // the arena, the objects and the two runs' paths
    arena::draw(world, objects, flat.trajectory, nodding.trajectory, argv[1]);
    std::cout << "wrote " << argv[1] << '\n';
  }
  std::cout << "{\"contacts_2d\": " << flat.contacts << ", \"contacts_3d\": " << nodding.contacts
            << ", \"objects\": " << objects.size()
            << ", \"objects_hit_2d\": " << flat.objects_hit.size()
            << ", \"objects_hit_3d\": " << nodding.objects_hit.size()
            << ", \"escaped_2d\": " << flat.escaped << ", \"escaped_3d\": " << nodding.escaped
            << ", \"trials\": " << trials << ", \"trials_2d_with_contacts\": " << collided_2d
            << ", \"contacts_3d_all_trials\": " << contacts_3d_all << "}\n";
  return collided_2d == trials && contacts_3d_all == 0 ? 0 : 1;
}
