#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "rangenav/egocentric/pitching_stream.hpp"
#include "rangenav/egocentric/sweep_reduction.hpp"

using namespace rangenav;

namespace {

constexpr double period = 0.01332;

// The pitch of scan k of a scanner nodding between -10 and 20 deg at 1 deg per scan.
double pitch_of(std::size_t k) {
  const auto phase = static_cast<int>(k % 60);
  return deg_to_rad(static_cast<double>(phase <= 30 ? -10 + phase : 50 - phase));
}

// Scan k of a pitching scanner (offset t_s) at robot pose `pose` looking at the wall x = 3 (world).
PitchedScan<double> wall_scan(std::size_t k, const Pose2d& pose, const Point3d& t_s) {
  const double p = pitch_of(k);
  std::vector<double> ranges(61);
  for (std::size_t i = 0; i < ranges.size(); ++i) {
    const double yaw = deg_to_rad(-60.0 + 2.0 * static_cast<double>(i));
    // Beam direction (Eq. 3 with d = 1) in the world: the robot only translates along x here.
    const double dx = std::cos(p) * std::cos(yaw);
    ranges[i] = (3.0 - pose.x - t_s.x()) / dx;
  }
  return {LaserScand(deg_to_rad(-60.0), deg_to_rad(2.0), 0.01, 30.0, ranges, {},
                     static_cast<double>(k) * period),
          p};
}

}  // namespace

TEST_CASE("area of interest: full aperture at standstill, virtual corridor when fast",
          "[egocentric][pitching]") {
  AreaOfInterestParams<double> p;  // corridor [0, 1] m, d_min 1 m, limits +-60 deg
  const auto corridor = virtual_corridor_aoi(0.55, p);
  CHECK(corridor.min == Approx(std::atan2(0.55 - 1.0, 1.0)));  // looks up to 1 m height at d_min
  CHECK(corridor.max == Approx(std::atan2(0.55, 1.0)));        // down to the floor at d_min
  const auto still = area_of_interest(0.0, 0.55, p);
  CHECK(still.min == Approx(-std::numbers::pi / 3));
  CHECK(still.max == Approx(std::numbers::pi / 3));
  const auto fast = area_of_interest(0.8, 0.55, p);
  CHECK(fast.min == Approx(corridor.min));
  CHECK(fast.max == Approx(corridor.max));
  const auto half = area_of_interest(-0.25, 0.55, p);  // reversing counts by its speed
  CHECK(half.min == Approx((still.min + corridor.min) / 2));
  // A scanner above the corridor never needs to look up.
  CHECK(virtual_corridor_aoi(1.2, p).min == 0.0);
  p.d_min = 0;
  CHECK_THROWS_WITH(area_of_interest(0.1, 0.55, p),
                    "rangenav: virtual_corridor_aoi: argument 'd_min' = 0 must be finite and > 0");
}

TEST_CASE("the pitching scanner's blind zone", "[egocentric][pitching]") {
  const Point3d offset(0.15, 0.0, 0.55);
  // Pitched down 40 deg, the lowest beam meets the floor 0.55 / tan(40 deg) ahead of the axis.
  const double pitch = 40.0 * std::numbers::pi / 180;
  CHECK(pitching_blind_range(offset, pitch) == Approx(0.15 + 0.55 / std::tan(pitch)));
  CHECK(pitching_blind_range(offset, pitch, 0.1) == Approx(0.15 + 0.45 / std::tan(pitch)));
  CHECK(pitching_blind_range(offset, std::numbers::pi / 4) == Approx(0.70));
  CHECK_THROWS_WITH(pitching_blind_range(offset, 0.0),
                    "rangenav: pitching_blind_range: argument 'pitch_max' = 0 must be in (0, pi / "
                    "2)");
  CHECK_THROWS_WITH(pitching_blind_range(offset, pitch, 0.6),
                    "rangenav: pitching_blind_range: argument 'height' = 0.59999999999999998 must "
                    "be below the sensor height 0.55000000000000004");
}

TEST_CASE("cluster centroids replace runs of close points (§6.1)", "[egocentric][pitching]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Point2d> pts = {{0, 0}, {0.01, 0}, {0.02, 0}, {1, 0}, {nan, 0}, {1.005, 0}};
  std::vector<Point2d> out;
  CHECK(reduce_to_cluster_centroids(std::span<const Point2d>(pts), 0.05, out) == 3);
  REQUIRE(out.size() == 3);
  CHECK(out[0].isApprox(Point2d(0.01, 0)));
  CHECK(out[1].isApprox(Point2d(1, 0)));
  CHECK(out[2].isApprox(Point2d(1.005, 0)));
  CHECK_THROWS_WITH(
      reduce_to_cluster_centroids(std::span<const Point2d>(pts), 0.0, out),
      "rangenav: reduce_to_cluster_centroids: argument 'max_distance' = 0 must be finite "
      "and > 0");
}

TEST_CASE("line segments: ratio growth, split at corners, gaps and invalid points end lines",
          "[egocentric][reduction]") {
  // An L of two walls, 5 cm spacing and +-2 mm zig-zag noise: two lines meeting at (2, 1).
  std::vector<Point2d> pts;
  for (int i = 0; i <= 40; ++i)
    pts.emplace_back(0.05 * i, 1.0 + (i % 2 == 0 ? 0.002 : -0.002));
  for (int i = 1; i <= 30; ++i)
    pts.emplace_back(2.0 + (i % 2 == 0 ? 0.002 : -0.002), 1.0 + 0.05 * i);
  std::vector<LineSegment<2, double>> lines;
  LineDetectionScratch stack;
  const LineDetectionParams<double> params;
  REQUIRE(detect_line_segments(std::span<const Point2d>(pts), params, lines, stack) == 2);
  CHECK(lines[0].a.isApprox(Point2d(0.0, 1.0), 0.01));
  CHECK(lines[0].b.x() == Approx(2.0).margin(0.01));
  CHECK(std::abs(lines[0].direction.y()) < 0.01);
  CHECK(lines[0].rms == Approx(0.002).margin(0.0005));
  CHECK(lines[1].b.isApprox(Point2d(2.0, 2.5), 0.01));
  CHECK(std::abs(lines[1].direction.x()) < 0.01);
  CHECK(lines[0].first == 0);
  CHECK(lines[1].first + lines[1].count == pts.size());
  // The corner point belongs to both legs; nothing else is shared.
  CHECK(lines[0].count + lines[1].count == pts.size() + 1);
  // A gap wider than max_gap and an invalid point each end a line; 3 points are no line.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Point2d> broken;
  for (int i = 0; i < 10; ++i)
    broken.emplace_back(0.05 * i, 0.0);
  for (int i = 0; i < 10; ++i)
    broken.emplace_back(1.0 + 0.05 * i, 0.0);  // 0.55 m gap
  broken.emplace_back(nan, 0.0);
  for (int i = 0; i < 10; ++i)
    broken.emplace_back(2.0 + 0.05 * i, 0.0);
  broken.emplace_back(nan, 0.0);
  for (int i = 0; i < 3; ++i)
    broken.emplace_back(3.0 + 0.05 * i, 0.0);
  lines.clear();
  CHECK(detect_line_segments(std::span<const Point2d>(broken), params, lines, stack) == 3);
  // A circle is cut into chords none of which strays from its points by more than max_distance.
  std::vector<Point3d> arc;
  for (int i = 0; i <= 90; ++i)
    arc.emplace_back(std::cos(deg_to_rad(2.0 * i)), std::sin(deg_to_rad(2.0 * i)), 0.5);
  std::vector<LineSegment<3, double>> chords;
  CHECK(detect_line_segments(std::span<const Point3d>(arc), params, chords, stack) > 5);
  for (const auto& c : chords) {
    for (std::size_t k = c.first; k < c.first + c.count; ++k)
      REQUIRE(detail::distance_to_chord_sq(arc[k], c.a, c.b) <= 0.015 * 0.015);
    CHECK(c.a.z() == Approx(0.5));
  }
  LineDetectionParams<double> bad;
  bad.min_ratio = 1.5;
  CHECK_THROWS_WITH(
      detect_line_segments(std::span<const Point2d>(pts), bad, lines, stack),
      "rangenav: detect_line_segments: argument 'min_ratio' = 1.5 must lie in (0, 1]");
  SweepReductionParams<double> bad_sweep;
  bad_sweep.planes.min_scans = 1;
  CHECK_THROWS_WITH(SweepReducer<double>(bad_sweep),
                    "rangenav: SweepReducer: argument 'min_scans' = 1 must be >= 2");
  // An empty sweep reduces to nothing.
  SweepReducer<double> reducer;
  const auto empty = reducer.reduce(Sweep<double>{});
  CHECK(empty.input_points == 0);
  CHECK(empty.reduction_ratio() == 0.0);
}

TEST_CASE("sweeps are segmented at pitch reversals and motion-compensated to the base pose",
          "[egocentric][pitching]") {
  const Point3d t_s(0.1, 0.0, 0.5);
  SweepAssembler<double> assembler(SweepParams<double>{t_s});
  std::size_t completed = 0;
  for (std::size_t k = 0; k < 200; ++k) {
    const Pose2d pose{0.3 * static_cast<double>(k) * period, 0.0, 0.0};  // 0.3 m/s ahead
    if (!assembler.push(wall_scan(k, pose, t_s), pose)) continue;
    ++completed;
    const Sweep<double>& s = assembler.sweep();
    REQUIRE(s.cloud.width == 61);
    REQUIRE(s.cloud.height == s.scan_count());
    CHECK(s.scan_count() >= 30);
    CHECK(s.scan_count() <= 31);
    CHECK(s.base_pose == s.poses.front());
    // Every point of the sweep lies on the wall as seen from the base pose, although the robot
    // drove up to 12 cm during the sweep.
    double worst = 0;
    for (const auto& p : s.cloud.points)
      worst = std::max(worst, std::abs(p.x() - (3.0 - s.base_pose.x)));
    CHECK(worst < 1e-9);
    CHECK(s.poses.back().x - s.poses.front().x > 0.1);
    // Each row's sensor origin in the base frame: t_s moved along with the robot.
    REQUIRE(s.origins.size() == s.scan_count());
    for (std::size_t r = 0; r < s.scan_count(); ++r)
      CHECK(s.origins[r].isApprox(Point3d(t_s.x() + s.poses[r].x - s.base_pose.x, t_s.y(), t_s.z()),
                                  1e-12));
    // Its structure scan sees the wall straight ahead.
    const LaserScan<double> st = structure_scan(s);
    const std::size_t ahead = st.size() / 2;
    REQUIRE(st.is_valid(ahead));
    CHECK(st.range(ahead) == Approx(3.0 - s.base_pose.x).margin(0.05));
  }
  CHECK(completed >= 5);
  CHECK(assembler.interruptions() == 0);
}

TEST_CASE("a fast turn interrupts the sweep", "[egocentric][pitching]") {
  const Point3d t_s(0.1, 0.0, 0.5);
  SweepAssembler<double> assembler(SweepParams<double>{t_s});
  double theta = 0;
  bool after_turn = false;
  for (std::size_t k = 0; k < 200; ++k) {
    if (k >= 40 && k < 50) theta += 0.05;  // 3.75 rad/s
    const Pose2d pose{0.0, 0.0, theta};
    // (The scans themselves do not matter for the segmentation.)
    if (assembler.push(wall_scan(k, Pose2d{}, t_s), pose) && k > 50)
      after_turn = after_turn || assembler.sweep().starts_after_interruption;
  }
  CHECK(assembler.interruptions() == 1);
  CHECK(after_turn);
  CHECK_THROWS_WITH(
      SweepAssembler<double>(SweepParams<double>{t_s, 0.0}),
      "rangenav: SweepAssembler: argument 'max_turn_rate' = 0 must be finite and > 0");
}

TEST_CASE("the streaming obstacle extractor waits for the neighbouring scans",
          "[egocentric][pitching]") {
  const Point3d t_s(0.1, 0.0, 0.5);
  PitchingObstacleExtractor<double> extractor(t_s);
  CHECK(extractor.delay() == 16);
  std::size_t first = 0;
  for (std::size_t k = 0; k < 40; ++k) {
    const auto out = extractor.push(wall_scan(k, Pose2d{}, t_s), Pose2d{});
    if (!out.empty() && first == 0) first = k;
    // The wall, in the robot frame, or (this synthetic wall has no floor in front of it: beams
    // that end below floor level) artificial obstacles on the floor plane.
    for (const auto& p : out)
      REQUIRE((std::abs(p.x() - 3.0) < 1e-9 || p.z() == 0.0));
  }
  CHECK(first == extractor.delay());
  CHECK_THROWS_WITH(
      PitchingObstacleExtractor<double>(Point3d(std::numeric_limits<double>::quiet_NaN(), 0, 0)),
      "rangenav: PitchingObstacleExtractor: sensor_offset must be finite");
}
