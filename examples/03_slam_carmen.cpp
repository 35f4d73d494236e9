// Tutorial 03: incremental SLAM with ICP and a sparse point map (paper 000 §3, paper 002 §6).
//
//   03_slam_carmen LOG [--out DIR] [--max-scans N] [--relations FILE]
//
// runs rangenav::IncrementalMapper on a CARMEN log (plain or .gz): every laser scan is matched
// against the sparse map built so far, starting from the last correction composed with the
// odometry increment; key frames (0.5 m / 25°) are added to the map with Eq. (5). It writes
// DIR/trajectory.txt (`timestamp x y theta` for every laser scan) and DIR/map.svg (sparse map
// and trajectory), and prints one JSON line: scans, map points, seconds, scans per second. With
// --relations it also prints the Freiburg benchmark's errors for that trajectory.
//
// Without a LOG it maps the first 250 scans of ../shared/data/carmen/mit-csail.clf.gz when that
// file exists, and a simulated corridor tour otherwise.

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "rangenav/io/carmen.hpp"
#include "rangenav/io/slam_relations.hpp"
#include "rangenav/io/svg.hpp"
#include "rangenav/io/trajectory.hpp"
#include "rangenav/mapping/incremental_mapper.hpp"
#include "rangenav/scan/laser_scan.hpp"
#include "rangenav/sim/world.hpp"

namespace {

struct Input {
  std::vector<rangenav::LaserScan<double>> scans;
  std::vector<std::optional<rangenav::Pose2d>> odometry;
  std::vector<double> timestamps;
  std::vector<rangenav::Pose2d> truth;  // simulated input only
};

// A robot drives down an L-shaped corridor with doors and pillars; odometry drifts.
Input simulated_tour() {
  rangenav::sim::World world;
  const std::vector<rangenav::Point2d> outline = {{-1, -1}, {20, -1}, {20, 12},
                                                  {17, 12}, {17, 2},  {-1, 2}};
  world.add_polygon(outline);
  for (double x = 2; x < 16; x += 3.5)
    world.add_wall({x, 2}, {x + 0.9, 2.6});  // door niches
  for (double y = 3; y < 11; y += 2.5)
    world.add_wall({17, y}, {16.4, y + 0.4});
  world.build_index();
  Input in;
  const auto geometry = rangenav::ScanGeometry<double>::from_fov(
      std::numbers::pi, std::numbers::pi / 360, 0.05, 30.0);
  rangenav::Pose2d pose{0, 0.5, 0}, odom = pose;
  for (int i = 0; i < 160; ++i) {
    const rangenav::Pose2d step = i < 90   ? rangenav::Pose2d{0.2, 0, 0}
                                  : i < 98 ? rangenav::Pose2d{0.05, 0, std::numbers::pi / 16}
                                           : rangenav::Pose2d{0.15, 0, 0};
    pose = rangenav::compose(pose, step);
    odom =
        rangenav::compose(odom, rangenav::Pose2d{step.x * 1.03, step.y, step.theta * 1.02 + 0.002});
    std::vector<double> ranges(geometry.beam_count);
    for (std::size_t b = 0; b < ranges.size(); ++b) {
      const double a = pose.theta + geometry.angle(b);
      const auto hit = world.cast_ray_2d(pose.position(), {std::cos(a), std::sin(a)}, 0.3, 30.0);
      ranges[b] = hit.hit() ? hit.range : 0.0;
    }
    in.scans.emplace_back(geometry, std::move(ranges), std::vector<double>{}, 0.1 * i);
    in.odometry.emplace_back(odom);
    in.timestamps.push_back(0.1 * i);
    in.truth.push_back(pose);
  }
  return in;
}

Input read_log(const std::filesystem::path& path, std::size_t max_scans) {
  Input in;
  for (auto& laser : rangenav::io::read_carmen_lasers(path)) {
    if (in.scans.size() >= max_scans) break;
    in.timestamps.push_back(laser.timestamp);
    in.odometry.push_back(laser.odom_pose);
    in.scans.push_back(std::move(laser.scan));
  }
  return in;
}

}  // namespace

int main(int argc, char** argv) try {
  std::filesystem::path log, out_dir = ".", relations;
  std::size_t max_scans = static_cast<std::size_t>(-1);
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--out" && i + 1 < argc)
      out_dir = argv[++i];
    else if (arg == "--max-scans" && i + 1 < argc)
      max_scans = std::stoul(argv[++i]);
    else if (arg == "--relations" && i + 1 < argc)
      relations = argv[++i];
    else if (!arg.empty() && arg[0] != '-')
      log = arg;
    else {
      std::cerr << "usage: 03_slam_carmen LOG [--out DIR] [--max-scans N] [--relations FILE]\n";
      return 2;
    }
  }
  std::string source;
  Input in;
  if (log.empty()) {
    const std::filesystem::path shared =
        std::filesystem::path(RANGENAV_EXAMPLE_DATA_DIR) / "carmen/mit-csail.clf.gz";
    if (std::filesystem::exists(shared)) {
      in = read_log(shared, std::min<std::size_t>(max_scans, 250));
      source = shared.string() + " (first 250 scans)";
    } else {
      in = simulated_tour();
      source = "simulated corridor tour";
    }
  } else {
    in = read_log(log, max_scans);
    source = log.string();
  }

  // The mapper's defaults are the papers' values: eps_D = 0.15 m, key frames at 0.5 m / 25°,
  // fitness rejection below 0.5; PaperIcp = decaying distance threshold + unique model points.
  rangenav::IncrementalMapper<2> mapper;
  std::vector<rangenav::io::StampedPose2d> trajectory;
  std::size_t rejected = 0;
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < in.scans.size(); ++i) {
    std::optional<rangenav::Transform2d> odom;
    if (in.odometry[i]) odom = in.odometry[i]->to_isometry();
    const auto update = mapper.process(in.scans[i], odom);
    if (update.icp && !update.registration_accepted) ++rejected;
    trajectory.push_back({in.timestamps[i], rangenav::Pose2d::from_isometry(update.pose)});
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::filesystem::create_directories(out_dir);
  rangenav::io::write_xytheta(out_dir / "trajectory.txt", trajectory);
  rangenav::io::SvgDrawing svg;
  svg.layer("sparse map").points(mapper.map().points(), {.stroke = "#333", .point_radius_px = 1.0});
  std::vector<rangenav::Point2d> path;
  for (const auto& p : trajectory)
    path.push_back(p.pose.position());
  svg.layer("estimated path").polyline(path, {.stroke = "crimson", .stroke_width_px = 1.5});
  if (!in.truth.empty()) {
    std::vector<rangenav::Point2d> truth;
    const auto t0 = in.truth.front();
    for (const auto& p : in.truth)
      truth.push_back(rangenav::relative(t0, p).position());
    svg.layer("true path").polyline(truth, {.stroke = "seagreen", .stroke_width_px = 1.0});
  }
  svg.save(out_dir / "map.svg");

  std::cout << "input: " << source << "\n";
  std::cout << "wrote " << (out_dir / "trajectory.txt").string() << " and "
            << (out_dir / "map.svg").string() << "\n";
  std::cout << "map: " << mapper.map().size() << " of " << mapper.map().points_offered()
            << " offered points stored, " << mapper.map().memory_bytes() << " bytes; " << rejected
            << " registrations rejected\n";

  double ate = -1;
  if (!in.truth.empty()) {  // absolute trajectory error in the first pose's frame
    double sum_sq = 0;
    for (std::size_t i = 0; i < trajectory.size(); ++i) {
      const auto truth = rangenav::relative(in.truth.front(), in.truth[i]);
      sum_sq += (trajectory[i].pose.position() - truth.position()).squaredNorm();
    }
    ate = std::sqrt(sum_sq / static_cast<double>(trajectory.size()));
  }
  std::string relation_json;
  if (!relations.empty()) {
    // The Freiburg benchmark's metric (io/slam_relations.hpp): mean ± std of the relative-pose
    // errors, over all relations and split into short (< 2 s apart) and long ones.
    std::vector<double> stamps;
    std::vector<rangenav::Pose2d> poses;
    for (const auto& p : trajectory) {
      stamps.push_back(p.timestamp);
      poses.push_back(p.pose);
    }
    const auto rel = rangenav::io::read_slam_relations(relations);
    const auto e = rangenav::io::evaluate_slam_relations(rel, stamps, poses);
    const auto deg = [](double rad) { return rad * 180.0 / std::numbers::pi; };
    for (const auto& [name, g] : {std::pair{"all", e.all}, std::pair{"short (< 2 s)", e.short_gap},
                                  std::pair{"long", e.long_gap}})
      std::printf("relations %s: %zu, %.4f +- %.4f m, %.3f +- %.3f deg\n", name, g.count,
                  g.translation_mean, g.translation_stddev, deg(g.rotation_mean),
                  deg(g.rotation_stddev));
    char buf[200];
    std::snprintf(buf, sizeof buf, ",\"trans_error_m\":%.4f,\"rot_error_deg\":%.3f",
                  e.all.translation_mean, deg(e.all.rotation_mean));
    relation_json = buf;
  }
  std::printf(
      "{\"scans\":%zu,\"map_points\":%zu,\"points_offered\":%zu,\"seconds\":%.3f,"
      "\"scans_per_second\":%.1f%s%s}\n",
      trajectory.size(), mapper.map().size(), mapper.map().points_offered(), seconds,
      static_cast<double>(trajectory.size()) / std::max(seconds, 1e-9),
      ate >= 0 ? (",\"ate_m\":" + std::to_string(ate)).c_str() : "", relation_json.c_str());
  return 0;
} catch (const std::exception& e) {
  std::cerr << "03_slam_carmen: " << e.what() << "\n";
  return 1;
}
