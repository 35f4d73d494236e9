#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "rangenav/egocentric/pitching_stream.hpp"

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
  CHECK_THROWS_WITH(reduce_to_cluster_centroids(std::span<const Point2d>(pts), 0.0, out),
                    "rangenav: reduce_to_cluster_centroids: argument 'max_gap' = 0 must be finite "
                    "and > 0");
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
