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
// Without a LOG it maps a simulated apartment tour and also prints the absolute trajectory error
// (RMS position error against the simulator's true poses); map.svg then shows the true path too.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "rangenav/io/carmen.hpp"
#include "rangenav/io/slam_relations.hpp"
#include "rangenav/io/svg.hpp"
#include "rangenav/io/trajectory.hpp"
#include "rangenav/mapping/incremental_mapper.hpp"
#include "rangenav/scan/laser_scan.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

namespace {

struct Input {
  std::vector<rangenav::LaserScan<double>> scans;
  std::vector<std::optional<rangenav::Pose2d>> odometry;
  std::vector<double> timestamps;
  std::vector<rangenav::Pose2d> truth;  // simulated input only
};

// The simulated robot follows the apartment's tour (waypoints from sim/worlds.hpp) in 5 cm /
// small-turn steps, scanning with a SICK S300 (270°, 1 cm noise) every 10 cm; its odometry
// over-estimates distance by 3 % and drifts in heading.
Input apartment_tour() {
  const auto scene = rangenav::sim::apartment();
  const rangenav::sim::LaserScanner2D scanner;
  std::mt19937 rng(7);
  Input in;
  rangenav::Pose2d pose = scene.start, odom = pose;
  double t = 0, travelled = 0;
  const auto record = [&] {
    in.scans.push_back(scanner.scan(scene.world, pose, rng, t));
    in.odometry.emplace_back(odom);
    in.timestamps.push_back(t);
    in.truth.push_back(pose);
  };
  record();
  for (const auto& goal : scene.tour) {
    for (int guard = 0; guard < 10000 && (goal - pose.position()).norm() > 0.05; ++guard) {
      const double bearing =
          rangenav::normalize_angle(std::atan2(goal.y() - pose.y, goal.x() - pose.x) - pose.theta);
      const double turn = std::clamp(bearing, -0.1, 0.1);
      const double forward = std::abs(bearing) < 0.3 ? 0.05 : 0.0;
      const rangenav::Pose2d step{forward, 0.0, turn};
      pose = rangenav::compose(pose, step);
      odom = rangenav::compose(odom, {step.x * 1.03, 0.0, step.theta * 1.01 + 0.0005});
      t += 0.05;
      travelled += forward + 0.2 * std::abs(turn);
      if (travelled >= 0.1) {
        travelled = 0;
        record();
      }
    }
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
    in = apartment_tour();
    source = "simulated apartment tour";
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
