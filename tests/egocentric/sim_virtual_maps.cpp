// The egocentric virtual maps against the simulator's ground truth (paper 002 Fig. 2 obstacle
// classes in the simulated apartment; a person walking past; a flat noisy floor; the §6.1
// reduction of a sweep of a known room).
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "rangenav/egocentric/pitching_stream.hpp"
#include "rangenav/egocentric/sweep_reduction.hpp"
#include "rangenav/egocentric/virtual_map.hpp"
#include "rangenav/registration/icp.hpp"
#include "rangenav/search/kd_tree.hpp"
#include "rangenav/sim/robot.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

using namespace rangenav;

namespace {

constexpr double half_pi = std::numbers::pi / 2;

sim::PitchingScannerParams scanner_params() {
  sim::PitchingScannerParams p;
  p.noise.sigma = 0.005;  // SICK LMS 2xx: about 5 mm (1 sigma)
  return p;
}

struct Observation {
  ObstacleMap<double> obstacle;
  LaserScan<double> structure;
  LaserScan<double> scan2d;
};

// The robot stands at `pose` while the pitching scanner nods twice; the obstacle map is fed scan by
// scan, the structure scan is the last complete sweep's.
Observation observe(const sim::Scene& scene, const Pose2d& pose) {
  std::mt19937 rng(11);
  const sim::PitchingScanner scanner(scanner_params());
  PitchingObstacleExtractor<double> extractor(scanner.params().sensor_offset);
  SweepAssembler<double> sweeps(SweepParams<double>{scanner.params().sensor_offset});
  Observation o;
  const auto scans = static_cast<std::size_t>(2 * scanner.nod_period() / 0.01332) + 20;
  for (std::size_t k = 0; k < scans; ++k) {
    const auto ps = scanner.scan(scene.world, pose, scanner.scan_time(k), rng);
    o.obstacle.update(Pose2d{}, extractor.push(ps, pose));
    if (sweeps.push(ps, pose)) o.structure = structure_scan(sweeps.sweep());
  }
  o.scan2d = sim::LaserScanner2D().scan(scene.world, pose, rng);
  return o;
}

// The true horizontal distance from the robot to `name` along `bearing` (robot frame), from 2D
// rays cast through the robot's height band.
double true_range(const sim::Scene& scene, const std::string& name, const Pose2d& pose,
                  double bearing) {
  const auto& obj = scene.object(name);
  const double a = pose.theta + bearing;
  double best = std::numeric_limits<double>::infinity();
  for (double z = 0.002; z <= 1.0; z += 0.004) {
    const auto hit = scene.world.cast_ray_2d({pose.x, pose.y}, {std::cos(a), std::sin(a)}, z, 10.0);
    if (hit.hit() && obj.contains(sim::PrimitiveRef{hit.kind, hit.index}))
      best = std::min(best, hit.range);
  }
  return best;
}

// The nearest non-dummy reading of the map within one bin of `bearing`.
double map_range(const ObstacleMap<double>& map, double bearing) {
  const std::size_t k = map.bin_index(bearing);
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t j = k + map.size() - 1; j <= k + map.size() + 1; ++j) {
    const auto& b = map.bin(j % map.size());
    if (!b.dummy) best = std::min(best, b.range);
  }
  return best;
}

double scan_range(const LaserScan<double>& scan, double bearing) {
  const auto i =
      static_cast<std::size_t>(std::llround((bearing - scan.angle_min()) / scan.angle_increment()));
  return scan.is_valid(i) ? scan.range(i) : std::numeric_limits<double>::infinity();
}

struct Case {
  std::string name;
  Pose2d pose;
};

}  // namespace

TEST_CASE("pitching obstacle map finds each obstacle class of Fig. 2 at its true position",
          "[egocentric][sim]") {
  const sim::Scene scene = sim::apartment();
  const std::vector<Case> cases = {
      {"book", {0.8, 2.6, -half_pi}},         // small object, 3 cm
      {"couch_table", {3.0, 3.3, -half_pi}},  // table top at 0.40-0.44 m
      {"drawer", {8.35, 3.5, 0.0}},           // open drawer at 0.55-0.70 m
      {"stair", {8.8, 6.0, half_pi}},         // descending stair from y = 7.2
  };
  for (const auto& c : cases) {
    INFO(c.name);
    const Observation o = observe(scene, c.pose);
    for (const double bearing : {-0.05, 0.0, 0.05}) {
      INFO("bearing " << bearing);
      const double truth = c.name == "stair"
                               ? (scene.object("stair").min.y() - c.pose.y) / std::cos(bearing)
                               : true_range(scene, c.name, c.pose, bearing);
      REQUIRE(std::isfinite(truth));
      CHECK(map_range(o.obstacle, bearing) == Approx(truth).margin(0.05));
      CHECK(scan_range(o.scan2d, bearing) > truth + 0.1);  // the 2D scan misses it
      REQUIRE(o.structure.size() > 0);
      CHECK(scan_range(o.structure, bearing) > truth + 0.1);  // the structure map rejects it
    }
  }
}

TEST_CASE("a person walking past leaves a trace that ages out", "[egocentric][sim]") {
  // A 3 m wide corridor; the robot drives along +x at 0.3 m/s while a person (a 0.2 m cylinder)
  // crosses 2.5 m ahead of the start.
  const auto make_world = [](double person_y, bool person) {
    sim::World w;
    w.add_wall({-2, -1.5}, {20, -1.5});
    w.add_wall({-2, 1.5}, {20, 1.5});
    if (person) w.add_cylinder({{2.5, person_y}, 0.2, 0.0, 1.7});
    w.build_index();
    return w;
  };
  std::mt19937 rng(5);
  const sim::PitchingScanner scanner(scanner_params());
  PitchingObstacleExtractor<double> extractor(scanner.params().sensor_offset);
  VirtualMapParams<double> mp;
  mp.max_age = 150;  // 2 s at 75 Hz
  ObstacleMap<double> map(mp);
  const double dt = 0.01332, v = 0.3;
  Pose2d pose{0, 0, 0}, previous = pose;
  // Map points (world frame) on the person's path, away from the walls.
  const auto trace = [&]() {
    std::size_t n = 0;
    for (const auto& p : map.valid_points()) {
      const Point2d w = pose.transform_point(p);
      if (std::abs(w.x() - 2.5) < 0.35 && std::abs(w.y()) < 1.1) ++n;
    }
    return n;
  };
  std::size_t k = 0, trace_when_gone = 0;
  const std::size_t crossing = 120;  // scans the person needs to cross (1.6 s)
  for (; k < crossing + 2 * mp.max_age; ++k) {
    const bool present = k < crossing;
    const double y = -1.3 + 2.6 * static_cast<double>(k) / crossing;
    const sim::World world = make_world(y, present);
    const auto ps = scanner.scan(world, pose, scanner.scan_time(k), rng);
    map.update(relative(previous, pose), extractor.push(ps, pose));
    if (k == crossing + extractor.delay()) trace_when_gone = trace();
    // The trace stays until the configured count: the person's last readings away from the
    // walls (|y| < 1.1 m, seen up to about 10 scans before the person is gone) have been moved
    // fewer than max_age times here...
    if (k == crossing + extractor.delay() + mp.max_age - 20) CHECK(trace() > 0);
    // ...and are gone once the newest of them has been moved more than max_age times.
    if (k == crossing + extractor.delay() + mp.max_age + 2) CHECK(trace() == 0);
    // Floor points never enter: every map point lies on a wall or on the person's path.
    for (const auto& p : map.valid_points()) {
      const Point2d w = pose.transform_point(p);
      const bool on_wall = std::abs(std::abs(w.y()) - 1.5) < 0.05;
      const bool on_path = std::abs(w.x() - 2.5) < 0.35;
      REQUIRE((on_wall || on_path));
    }
    previous = pose;
    pose = sim::DifferentialDriveRobot::integrate(pose, v, 0.0, dt);
  }
  CHECK(trace_when_gone > 5);
  CHECK(trace() == 0);
}

TEST_CASE("with the simulator's default noise, floor stays out and a 3-cm object gets in",
          "[egocentric][sim]") {
  // A 3 m wide corridor with a 3-cm box (0.2 x 0.3 m) on the floor 3 m ahead; the robot drives
  // towards it at 0.3 m/s with the simulator's default pitching scanner (1 cm range noise) and
  // the default floor classification (thresholds derived from that noise, floor.hpp).
  sim::World world;
  world.add_wall({-2, -1.5}, {20, -1.5});
  world.add_wall({-2, 1.5}, {20, 1.5});
  const sim::Box box{{3.1, 0.0}, {0.2, 0.3}, 0.0, 0.0, 0.03};
  world.add_box(box);
  world.build_index();
  const sim::PitchingScanner scanner;  // defaults
  REQUIRE(scanner.params().noise.sigma == 0.01);
  PitchingObstacleExtractor<double> extractor(scanner.params().sensor_offset);
  ObstacleMap<double> map;
  std::mt19937 rng(17);
  const double dt = 0.01332, v = 0.3;
  Pose2d pose{0, 0, 0}, previous = pose;
  std::size_t floor_points = 0;
  for (std::size_t k = 0; k < 300; ++k) {  // 4 m -> 1.2 m from the box, three nods
    const auto ps = scanner.scan(world, pose, scanner.scan_time(k), rng);
    map.update(relative(previous, pose), extractor.push(ps, pose));
    for (const auto& p : map.valid_points()) {
      const Point2d w = pose.transform_point(p);
      const bool on_wall = std::abs(std::abs(w.y()) - 1.5) < 0.05;
      const bool on_box = std::abs(w.x() - 3.1) < 0.15 && std::abs(w.y()) < 0.2;
      floor_points += on_wall || on_box ? 0 : 1;
    }
    previous = pose;
    pose = sim::DifferentialDriveRobot::integrate(pose, v, 0.0, dt);
  }
  CHECK(floor_points == 0);
  // The box's front face (x = 3.0) straight ahead, within 5 cm.
  for (const double bearing : {-0.04, 0.0, 0.04}) {
    INFO("bearing " << bearing);
    const double truth = (3.0 - pose.x) / std::cos(bearing);
    CHECK(map_range(map, bearing) == Approx(truth).margin(0.05));
  }
}

TEST_CASE("§6.1 reduction: lines on the true walls, planes of the walls and the floor",
          "[egocentric][sim][reduction]") {
  // A five-walled room (one wall oblique); the robot drives at 0.2 m/s while the scanner nods.
  const std::vector<Point2d> corners = {{0, 0}, {6, 0}, {6, 3}, {4, 4.5}, {0, 4.5}};
  sim::World world;
  world.add_polygon(corners, 2.5);
  world.build_index();
  struct TrueWall {
    Point2d a, b, normal;
  };
  std::vector<TrueWall> walls;
  for (std::size_t i = 0; i < corners.size(); ++i) {
    const Point2d a = corners[i], b = corners[(i + 1) % corners.size()];
    const Point2d d = (b - a).normalized();
    walls.push_back({a, b, Point2d(-d.y(), d.x())});
  }
  // Distance of a world point from wall w's vertical plane, and whether it lies over the wall.
  const auto off_wall = [&](const TrueWall& w, const Point2d& p) {
    return std::abs(w.normal.dot(p - w.a));
  };
  const auto over_wall = [&](const TrueWall& w, const Point2d& p) {
    const double length = (w.b - w.a).norm();
    const double t = (p - w.a).dot(w.b - w.a) / length;
    return t > -0.05 && t < length + 0.05;
  };
  std::mt19937 rng(21);
  const sim::PitchingScanner scanner(scanner_params());
  SweepAssembler<double> sweeps(SweepParams<double>{scanner.params().sensor_offset});
  SweepReductionParams<double> rp;
  rp.floor.range_noise = scanner.params().noise.sigma;
  SweepReducer<double> reducer(rp);
  SweepReduction<double> red;
  Pose2d pose{1.5, 2.0, 0.4};
  std::size_t reduced = 0;
  for (std::size_t k = 0; reduced < 2; ++k) {
    REQUIRE(k < 400);
    const auto ps = scanner.scan(world, pose, scanner.scan_time(k), rng);
    if (sweeps.push(ps, pose)) {
      ++reduced;
      const Sweep<double>& sweep = sweeps.sweep();
      reducer.reduce(sweep, red);
      const Pose2d base = sweep.base_pose;
      const auto world_xy = [&](const Point3d& p) {
        return base.transform_point(Point2d(p.x(), p.y()));
      };
      // Step 1: far fewer points than readings.
      INFO("readings " << red.input_points << ", reduced " << red.points.size() << " + "
                       << red.floor_points.size() << " floor, ratio " << red.reduction_ratio());
      CHECK(red.input_points > 4000);
      CHECK(red.reduction_ratio() > 1.3);
      // Step 4: floor centroids lie on the floor, every other centroid on a wall.
      for (const auto& p : red.floor_points)
        REQUIRE(std::abs(p.z()) < 0.03);
      for (const auto& p : red.points) {
        double nearest = 1e9;
        for (const auto& w : walls)
          nearest = std::min(nearest, off_wall(w, world_xy(p)));
        REQUIRE(nearest < 0.05);
      }
      // Step 2: every line segment lies on the floor or along one true wall, end to end.
      std::vector<std::size_t> wall_lines(walls.size(), 0);
      std::size_t floor_lines = 0;
      REQUIRE(red.lines.size() > 30);
      for (const auto& line : red.lines) {
        CHECK(line.length() >= 0.1);
        CHECK(line.rms < 0.01);
        if (line.floor) {
          ++floor_lines;
          CHECK(std::abs(line.a.z()) < 0.03);
          CHECK(std::abs(line.b.z()) < 0.03);
          continue;
        }
        bool on_a_wall = false;
        for (std::size_t w = 0; w < walls.size() && !on_a_wall; ++w) {
          const Point2d a = world_xy(line.a), b = world_xy(line.b);
          if (off_wall(walls[w], a) < 0.03 && off_wall(walls[w], b) < 0.03 &&
              over_wall(walls[w], a) && over_wall(walls[w], b)) {
            on_a_wall = true;
            ++wall_lines[w];
          }
        }
        INFO("line of row " << line.row << " from " << world_xy(line.a).transpose() << " to "
                            << world_xy(line.b).transpose() << ", z " << line.a.z() << " beams "
                            << line.first << " + " << line.count);
        CHECK(on_a_wall);
      }
      CHECK(floor_lines > 5);
      // Step 3: each wall seen by several lines and the floor are planes at their true place.
      bool floor_plane = false;
      std::vector<bool> wall_plane(walls.size(), false);
      for (const auto& plane : red.planes) {
        if (plane.normal.z() > std::cos(deg_to_rad(3.0))) {
          CHECK(std::abs(plane.distance) < 0.02);  // z = 0 in the base frame
          CHECK(plane.floor);
          floor_plane = true;
          continue;
        }
        // A wall: horizontal normal, in the world rotated by the base pose's heading.
        INFO("plane n " << plane.normal.transpose() << " d " << plane.distance << " lines "
                        << plane.line_count << " rows " << plane.first_row << "-" << plane.last_row
                        << " rms " << plane.rms);
        CHECK(std::abs(plane.normal.z()) < std::sin(deg_to_rad(3.0)));
        const Point2d n = Eigen::Rotation2Dd(base.theta) *
                          Point2d(plane.normal.x(), plane.normal.y()).normalized();
        const Point2d c = world_xy(plane.centroid);
        bool matched = false;
        for (std::size_t w = 0; w < walls.size(); ++w)
          if (std::abs(n.dot(walls[w].normal)) > std::cos(deg_to_rad(3.0)) &&
              off_wall(walls[w], c) < 0.03 && over_wall(walls[w], c)) {
            matched = true;
            wall_plane[w] = true;
          }
        INFO("plane n " << plane.normal.transpose() << " d " << plane.distance << " lines "
                        << plane.line_count << " rows " << plane.first_row << "-" << plane.last_row
                        << " rms " << plane.rms);
        CHECK(matched);
      }
      CHECK(floor_plane);
      for (std::size_t w = 0; w < walls.size(); ++w) {
        INFO("wall " << w << " with " << wall_lines[w] << " lines");
        if (wall_lines[w] >= 10) CHECK(wall_plane[w]);
      }
      // Each line's plane index points to a reported plane or nowhere.
      for (const auto& line : red.lines)
        CHECK((line.plane == LineSegment<3, double>::npos || line.plane < red.planes.size()));
    }
    pose = sim::DifferentialDriveRobot::integrate(pose, 0.2, 0.0, scanner.params().scan_period);
  }
}

TEST_CASE("an obstacle in the pitching scanner's blind zone is not forgotten while turning",
          "[egocentric][sim]") {
  // The robot drives toward a can (10 cm high) until it is 0.5 m away, as the virtual roadway
  // stops it there, then turns on the spot left and right for 6 s. The can is nearer than the
  // scanner's lowest beam reaches: it is never measured again, and ageing alone (§4.4.2) would
  // remove it (paper 002 assumes a static obstacle is "immediately measured again").
  sim::World world;
  world.add_cylinder({{2.0, 0.1}, 0.05, 0.0, 0.10});
  world.build_index();
  const sim::PitchingScanner scanner(scanner_params());
  const auto run = [&](double blind_range) {
    std::mt19937 rng(9);
    PitchingObstacleExtractor<double> extractor(scanner.params().sensor_offset);
    VirtualMapParams<double> mp;
    mp.max_age = 225;  // 3 s at 75 Hz
    mp.blind_range = blind_range;
    ObstacleMap<double> map(mp);
    const double dt = scanner.params().scan_period;
    Pose2d pose{0, 0, 0}, previous = pose;
    for (std::size_t k = 0; k < 1000; ++k) {
      const double t = static_cast<double>(k) * dt;
      const auto ps = scanner.scan(world, pose, scanner.scan_time(k), rng);
      map.update(relative(previous, pose), extractor.push(ps, pose));
      previous = pose;
      const bool driving = 2.0 - pose.x > 0.5;
      const double omega = driving ? 0.0 : (std::fmod(t, 1.0) < 0.5 ? 0.6 : -0.6);
      pose = sim::DifferentialDriveRobot::integrate(pose, driving ? 0.3 : 0.0, omega, dt);
    }
    // Map points on the can (robot frame of the last pose).
    const Point2d can = relative(pose, Pose2d{2.0, 0.1, 0.0}).position();
    REQUIRE(can.norm() < 0.6);
    std::size_t on_can = 0;
    for (const auto& p : map.valid_points())
      on_can += (p - can).norm() < 0.1 ? 1 : 0;
    return on_can;
  };
  const double blind =
      pitching_blind_range(scanner.params().sensor_offset, scanner.params().pitch_max, 0.10);
  CHECK(blind > 0.6);     // the can at 0.5 m is inside it
  CHECK(run(blind) > 0);  // kept
  CHECK(run(0.0) == 0);   // the paper's rule forgets it
}

TEST_CASE("structure scans of consecutive sweeps feed 3-DOF scan matching unchanged (§6.1)",
          "[egocentric][sim]") {
  // The robot drives through the apartment at 0.3 m/s, turning gently, while the scanner nods;
  // every sweep's structure map is a virtual 2D scan, and the paper's ICP (§6.3) run on two
  // consecutive ones recovers the true motion between their base poses.
  const sim::Scene scene = sim::apartment();
  std::mt19937 rng(4);
  const sim::PitchingScanner scanner(scanner_params());
  SweepAssembler<double> sweeps(SweepParams<double>{scanner.params().sensor_offset});
  Pose2d pose{1.2, 1.0, 0.6};
  std::vector<std::pair<Pose2d, LaserScan<double>>> scans;
  for (std::size_t k = 0; scans.size() < 3; ++k) {
    REQUIRE(k < 600);
    if (sweeps.push(scanner.scan(scene.world, pose, scanner.scan_time(k), rng), pose))
      scans.emplace_back(sweeps.sweep().base_pose, structure_scan(sweeps.sweep()));
    pose = sim::DifferentialDriveRobot::integrate(pose, 0.3, 0.1, scanner.params().scan_period);
  }
  for (std::size_t s = 1; s < scans.size(); ++s) {
    const auto& [model_pose, model] = scans[s - 1];
    const auto& [data_pose, data] = scans[s];
    REQUIRE(model.valid_count() > 100);
    const Pose2d truth = relative(model_pose, data_pose);
    PaperIcp<2> icp;
    const auto result = icp.align(KdTree<2, double>(model), data);
    INFO("truth " << truth.x << " " << truth.y << " " << truth.theta);
    CHECK(result.converged);
    const Transform2d t = result.transform;
    CHECK(t.translation().x() == Approx(truth.x).margin(0.02));
    CHECK(t.translation().y() == Approx(truth.y).margin(0.02));
    CHECK(std::atan2(t.linear()(1, 0), t.linear()(0, 0)) == Approx(truth.theta).margin(0.01));
    CHECK(std::hypot(truth.x, truth.y) > 0.1);  // the sweeps are apart
  }
}
