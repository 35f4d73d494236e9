// Lesson 01: laser scans from a CARMEN log, drawn as SVG.
//
// A 2D laser scanner measures one range per beam while its mirror sweeps a fan of bearings. A
// log records those scans together with the pose the robot's odometry reported at the time. In
// this lesson we
//   1. read such a log (the CARMEN format used by the Radish and Freiburg data sets),
//   2. turn each scan's ranges into Cartesian points, keeping only the valid beams,
//   3. draw one scan in the sensor's own frame, and every scan placed at its odometry pose,
//   4. print a few facts about the log, ending with one JSON line a script can check.
//
// Run it as `01_scans [log.clf[.gz] [index of the scan to draw]]`. Without an argument it reads the
// MIT CSAIL log of the shared data set when it is present, else a five-scan log it writes itself
// (support/sample_log.hpp). Output: scans_out/scan.svg and scans_out/odometry.svg in the current
// directory.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include <rangenav/core/angles.hpp>
#include <rangenav/core/error.hpp>
#include <rangenav/core/types.hpp>
#include <rangenav/io/carmen.hpp>
#include <rangenav/io/svg.hpp>
#include <rangenav/scan/laser_scan.hpp>

#include "support/sample_log.hpp"

namespace fs = std::filesystem;
using rangenav::Point2d;
using rangenav::Pose2d;

namespace {

// Only letters, digits and a few signs, so the name can go into the JSON line as it is.
std::string json_safe(std::string text) {
  for (char& c : text)
    if (c == '"' || c == '\\' || static_cast<unsigned char>(c) < 0x20) c = '_';
  return text;
}

}  // namespace

int main(int argc, char** argv) try {
  const auto start = std::chrono::steady_clock::now();
  const fs::path out_dir = "scans_out";
  fs::create_directories(out_dir);
  const fs::path log = examples::choose_log(argc, argv, RANGENAV_EXAMPLE_DATA_DIR, out_dir);

  // ---- 1. Read the log ---------------------------------------------------------------------
  // A laser record of the log is one line:
  //   FLASER <n> <n ranges> <laser x y theta> <odometry x y theta> <timestamp> <host> <logger time>
  // The bearings are implicit: n beams spread over 180 degrees, from -90 (right) to +90 (left).
  // CarmenReader streams the file (plain or .gz) one record at a time. A record is either a
  // laser scan (CarmenLaser) or an odometry reading (CarmenOdometry); other lines are skipped.
  // A malformed line throws rangenav::io_error naming the file and the line.
  rangenav::io::CarmenReader reader(log);
  std::vector<rangenav::io::CarmenLaser> lasers;
  std::vector<Pose2d> odometry_records;
  while (auto record = reader.next()) {
    if (auto* laser = std::get_if<rangenav::io::CarmenLaser>(&*record))
      lasers.push_back(std::move(*laser));
    else
      odometry_records.push_back(std::get<rangenav::io::CarmenOdometry>(*record).pose);
  }
  if (lasers.empty()) {
    std::cerr << "no laser scans in " << log.string() << '\n';
    return 1;
  }

  // ---- 2. Ranges become points -------------------------------------------------------------
  // Each record holds a rangenav::LaserScan: the ranges d_i and the beam layout (first bearing,
  // bearing step, range limits). The scan computes every beam's Cartesian point
  // p_i = (d_i cos theta_i, d_i sin theta_i) once, in the sensor frame (x ahead, y left), and
  // flags the beams that measured nothing useful: NaN, 0, below range_min, or at range_max
  // ("no return"). Those are data, not errors; valid_points() holds the others.
  const rangenav::LaserScan<double>& first = lasers.front().scan;
  std::size_t beams = 0, valid = 0;
  for (const auto& laser : lasers) {
    beams += laser.scan.size();
    valid += laser.scan.valid_count();
  }
  const double valid_fraction = static_cast<double>(valid) / static_cast<double>(beams);

  // ---- 3a. One scan, in the sensor frame ---------------------------------------------------
  // SvgDrawing takes shapes in metres (y up) and fits the picture around them. Layers become
  // groups in the file and entries of the legend under the picture.
  std::size_t shown_index = lasers.size() / 2;
  if (argc > 2) shown_index = std::min<std::size_t>(std::stoul(argv[2]), lasers.size() - 1);
  const auto& shown = lasers[shown_index];
  const auto& scan = shown.scan;
  double reach = 0;  // the farthest valid reading: sizes the marks of invalid beams and the sensor
  for (const Point2d& p : scan.valid_points())
    reach = std::max(reach, p.norm());
  if (reach == 0) reach = 1;
  {
    rangenav::io::SvgDrawing svg;
    // The beams that returned, as faint rays from the sensor to their end points.
    svg.layer("beams");
    for (const Point2d& p : scan.valid_points())
      svg.segment({0, 0}, p, {.stroke = "#d0d8e8"});
    // The beams that did not: a short red ray shows the direction nothing was seen in.
    svg.layer("no return");
    for (std::size_t i = 0; i < scan.size(); ++i) {
      if (scan.is_valid(i)) continue;
      const double a = scan.angle(i);
      svg.segment({0, 0}, 0.15 * reach * Point2d(std::cos(a), std::sin(a)), {.stroke = "#e04040"});
    }
    // The valid end points. A LaserScan is itself a PointCloud of its valid points.
    svg.layer("end points").points(scan, {.stroke = "#1f5fbf", .point_radius_px = 2.5});
    // The sensor: the origin of its frame, looking along +x.
    svg.layer("sensor")
        .pose(Pose2d{0, 0, 0}, 0.08 * reach,
              {.stroke = "black", .fill = "black", .stroke_width_px = 2.0})
        .text({0.02 * reach, -0.06 * reach}, "sensor", 13, {.stroke = "black"});
    svg.save(out_dir / "scan.svg");
  }

  // ---- 3b. All scans at their poses ---------------------------------------------------------
  // A point p of a scan taken at laser pose (x, y, theta) lies at R(theta) p + (x, y) in the
  // world: Pose2d::transform_point. Odometry drifts, so walls seen twice do not quite overlap
  // (lesson material for scan matching later). Every step-th end point keeps the file small.
  std::vector<Pose2d> path;
  for (const auto& laser : lasers)
    if (laser.odom_pose) path.push_back(*laser.odom_pose);
  if (path.empty()) path = odometry_records;  // logs whose laser records carry no odometry
  const std::size_t max_drawn = 100000;
  const std::size_t step = std::max<std::size_t>(1, (valid + max_drawn - 1) / max_drawn);
  std::vector<Point2d> world_points;
  world_points.reserve(valid / step + 1);
  std::size_t counter = 0;
  for (const auto& laser : lasers) {
    const std::optional<Pose2d> pose = laser.laser_pose ? laser.laser_pose : laser.odom_pose;
    if (!pose) continue;
    for (const Point2d& p : laser.scan.valid_points())
      if (counter++ % step == 0) world_points.push_back(pose->transform_point(p));
  }
  double path_length = 0;
  for (std::size_t i = 1; i < path.size(); ++i)
    path_length += (path[i].position() - path[i - 1].position()).norm();
  {
    rangenav::io::SvgDrawing svg;
    svg.layer("scan end points")
        .points(world_points,
                {.stroke = "#505050", .point_radius_px = world_points.size() > 10000 ? 0.7 : 2.0});
    svg.layer("odometry").path(path, {.stroke = "#d62728", .stroke_width_px = 1.5});
    if (!path.empty()) {
      // Arrows 4% of the size of the area travelled (at least 20 cm).
      Point2d lo = path.front().position(), hi = lo;
      for (const Pose2d& p : path) {
        lo = lo.cwiseMin(p.position());
        hi = hi.cwiseMax(p.position());
      }
      const double arrow = std::max(0.2, 0.04 * (hi - lo).maxCoeff());
      svg.layer("start").pose(path.front(), arrow,
                              {.stroke = "#2ca02c", .fill = "#2ca02c", .stroke_width_px = 2.5});
      svg.layer("end").pose(path.back(), arrow,
                            {.stroke = "#1f3fbf", .fill = "#1f3fbf", .stroke_width_px = 2.5});
    }
    svg.save(out_dir / "odometry.svg");
  }

  // ---- 4. Facts ----------------------------------------------------------------------------
  const double duration = lasers.back().timestamp - lasers.front().timestamp;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << "log:             " << log.string() << '\n'
            << "laser scans:     " << lasers.size() << " over " << duration << " s\n"
            << "odometry lines:  " << odometry_records.size() << '\n'
            << "beams per scan:  " << first.size() << " over "
            << rangenav::rad_to_deg(first.angle_max() - first.angle_min()) << " deg, every "
            << rangenav::rad_to_deg(first.angle_increment()) << " deg, valid below "
            << first.range_max() << " m\n"
            << "valid beams:     " << valid << " of " << beams << " (" << 100 * valid_fraction
            << " %)\n"
            << "odometry path:   " << path_length << " m\n"
            << "wrote " << fs::absolute(out_dir / "scan.svg").string() << " (scan " << shown_index
            << ", " << scan.valid_count() << " valid beams)\n"
            << "wrote " << fs::absolute(out_dir / "odometry.svg").string() << " ("
            << world_points.size() << " end points, every " << step << ")\n";
  std::cout << "{\"log\": \"" << json_safe(log.filename().string())
            << "\", \"scans\": " << lasers.size() << ", \"beams\": " << first.size()
            << ", \"valid_fraction\": " << valid_fraction << ", \"path_length_m\": " << path_length
            << ", \"duration_s\": " << duration << ", \"drawn_points\": " << world_points.size()
            << ", \"seconds\": " << seconds << "}\n";
  return 0;
} catch (const std::exception& e) {
  // rangenav reports bad input and unreadable files as exceptions derived from rangenav::error.
  std::cerr << "01_scans: " << e.what() << '\n';
  return 1;
}
