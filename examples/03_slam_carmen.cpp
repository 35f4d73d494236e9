// Tutorial 03: 2D laser SLAM with loop closure (paper 000 §3; Hess et al. 2016).
//
//   03_slam_carmen [LOG] [--relations FILE] [--out DIR] [--no-loop-closure] [--max-scans N]
//                  [--laser FLASER|RLASER|ROBOTLASER1|RAWLASER1..4]
//
// rangenav::LaserSlam, default-constructed, maps a CARMEN log (plain or .gz):
//   1. the front end registers every scan against a local sparse point map (scan-to-scan
//      pre-alignment, then point-to-line ICP) and fuses the result with the odometry increment
//      by information, so odometry carries what the scan leaves free (a corridor's axis);
//   2. key frames become pose-graph nodes and are grouped into submaps;
//   3. each key frame is matched against the finished submaps within its uncertainty window by
//      the branch-and-bound correlative matcher, refined by ICP and verified;
//   4. accepted loop edges enter the pose graph with a robust kernel; the graph is optimised and
//      the submaps and the trajectory re-anchored.
// It writes DIR/trajectory.txt (`t x y theta` per scan, what ../shared/tools/eval_traj.py reads)
// and DIR/map.svg (map, trajectory, loop edges). With --relations it prints the Freiburg
// benchmark's errors. Without LOG it maps a simulated apartment tour out and back (a loop)
// with drifting odometry and scores it against the simulator's truth. The last line is JSON.

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "rangenav/io/carmen.hpp"
#include "rangenav/io/slam_relations.hpp"
#include "rangenav/io/svg.hpp"
#include "rangenav/io/trajectory.hpp"
#include "rangenav/mapping/loop_closing_mapper.hpp"
#include "rangenav/sim/sensors.hpp"
#include "rangenav/sim/worlds.hpp"

namespace {

struct Input {
  std::vector<rangenav::LaserScan<double>> scans;
  std::vector<std::optional<rangenav::Pose2d>> odometry;
  std::vector<double> timestamps;
  std::vector<rangenav::Pose2d> truth;  // simulated input only
};

// The apartment's tour (sim/worlds.hpp) and back to the start, in 5 cm steps, scanned by a
// SICK S300 model every 10 cm; the odometry over-estimates distance by 3 % and drifts in
// heading by 1°/m.
Input apartment_loop() {
  const auto scene = rangenav::sim::apartment();
  const rangenav::sim::LaserScanner2D scanner;
  std::mt19937 rng(7);
  Input in;
  rangenav::Pose2d pose = scene.start, odom = pose;
  double t = 0, travelled = 0;
  auto tour = scene.tour;
  for (std::size_t i = scene.tour.size(); i-- > 0;)
    tour.push_back(scene.tour[i]);
  tour.push_back(scene.start.position());
  for (const auto& goal : tour)
    for (int guard = 0; guard < 10000 && (goal - pose.position()).norm() > 0.05; ++guard) {
      const double bearing =
          rangenav::normalize_angle(std::atan2(goal.y() - pose.y, goal.x() - pose.x) - pose.theta);
      const rangenav::Pose2d step{std::abs(bearing) < 0.3 ? 0.05 : 0.0, 0.0,
                                  std::clamp(bearing, -0.1, 0.1)};
      pose = rangenav::compose(pose, step);
      odom = rangenav::compose(odom, {step.x * 1.03, 0.0, step.theta + 0.0175 * step.x});
      t += 0.05;
      if ((travelled += step.x + 0.2 * std::abs(step.theta)) < 0.1) continue;
      travelled = 0;
      in.scans.push_back(scanner.scan(scene.world, pose, rng, t));
      in.odometry.emplace_back(odom);
      in.timestamps.push_back(t);
      in.truth.push_back(pose);
    }
  return in;
}

// One laser of the log (`laser`, else the one with the most records) with the odometry of that
// laser's frame: the scans are in that frame.
Input read_log(const std::filesystem::path& path, std::size_t max_scans,
               std::optional<rangenav::io::CarmenLaserType> laser) {
  Input in;
  auto log = rangenav::io::read_carmen_scan_log(path, laser);
  if (log.other_laser_records > 0)
    std::cout << "using the log's " << log.records.size() << " "
              << rangenav::io::to_string(log.laser) << " records; " << log.other_laser_records
              << " records of other lasers left out\n";
  for (std::size_t i = 0; i < log.records.size() && i < max_scans; ++i) {
    in.timestamps.push_back(log.records[i].timestamp);
    in.odometry.push_back(log.odometry[i]);
    in.scans.push_back(std::move(log.records[i].scan));
  }
  return in;
}

}  // namespace

int main(int argc, char** argv) try {
  std::filesystem::path log, out_dir = ".", relations;
  std::size_t max_scans = static_cast<std::size_t>(-1);
  std::optional<rangenav::io::CarmenLaserType> laser;
  bool loop_closure = true;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--out" && i + 1 < argc)
      out_dir = argv[++i];
    else if (arg == "--relations" && i + 1 < argc)
      relations = argv[++i];
    else if (arg == "--max-scans" && i + 1 < argc)
      max_scans = std::stoul(argv[++i]);
    else if (arg == "--laser" && i + 1 < argc) {
      laser = rangenav::io::carmen_laser_type(argv[++i]);
      if (!laser) {
        std::cerr << "03_slam_carmen: unknown laser '" << argv[i] << "'\n";
        return 2;
      }
    } else if (arg == "--no-loop-closure")
      loop_closure = false;
    else if (!arg.empty() && arg[0] != '-')
      log = arg;
    else {
      std::cerr << "usage: 03_slam_carmen [LOG] [--relations FILE] [--out DIR] "
                   "[--no-loop-closure] [--max-scans N] [--laser FLASER|RLASER|ROBOTLASER1|"
                   "RAWLASER1..4]\n";
      return 2;
    }
  }
  const Input in = log.empty() ? apartment_loop() : read_log(log, max_scans, laser);

  // The one default configuration; --no-loop-closure keeps the front end alone.
  rangenav::LoopClosureParams<double> loops;
  loops.enabled = loop_closure;
  rangenav::LaserSlam<double> slam(rangenav::laser_slam_params<double>(), loops);
  const std::clock_t cpu_start = std::clock();
  for (std::size_t i = 0; i < in.scans.size(); ++i) {
    std::optional<rangenav::Transform2d> odom;
    if (in.odometry[i]) odom = in.odometry[i]->to_isometry();
    slam.process(in.scans[i], odom);
  }
  slam.finish();
  const double cpu_seconds = double(std::clock() - cpu_start) / CLOCKS_PER_SEC;

  // The trajectory at the optimised key frames: every scan's pose.
  std::vector<rangenav::io::StampedPose2d> trajectory;
  std::vector<rangenav::Pose2d> poses;
  for (const auto& t : slam.trajectory())
    poses.push_back(rangenav::Pose2d::from_isometry(t));
  for (std::size_t i = 0; i < poses.size(); ++i)
    trajectory.push_back({in.timestamps[i], poses[i]});
  std::filesystem::create_directories(out_dir);
  rangenav::io::write_xytheta(out_dir / "trajectory.txt", trajectory);

  // The map: submaps re-anchored to the optimised poses, the path, and the loop edges.
  rangenav::io::SvgDrawing svg;
  svg.layer("map").points(slam.map_points(), {.stroke = "#333", .point_radius_px = 0.8});
  svg.layer("estimated path").path(poses, {.stroke = "crimson", .stroke_width_px = 1.0});
  const auto nodes = slam.key_frame_poses();
  for (const auto& c : slam.loop_closures())
    svg.layer("loop edges")
        .segment(nodes[c.from].translation(), nodes[c.node].translation(),
                 {.stroke = "royalblue", .stroke_width_px = 0.8});
  std::string truth_json;
  if (!in.truth.empty()) {  // simulated input: the true path and the absolute trajectory error
    std::vector<rangenav::Pose2d> truth;
    double sum_sq = 0;
    for (std::size_t i = 0; i < in.truth.size(); ++i) {
      truth.push_back(rangenav::relative(in.truth.front(), in.truth[i]));
      sum_sq += (rangenav::relative(poses.front(), poses[i]).position() - truth.back().position())
                    .squaredNorm();
    }
    svg.layer("true path").path(truth, {.stroke = "seagreen", .stroke_width_px = 1.0});
    truth_json = ",\"ate_m\":" + std::to_string(std::sqrt(sum_sq / double(truth.size())));
  }
  svg.save(out_dir / "map.svg");

  const auto& st = slam.loop_statistics();
  std::cout << "input: " << (log.empty() ? "simulated apartment tour, out and back" : log.string())
            << "\n"
            << slam.key_frames() << " key frames in " << slam.submaps() << " submaps; "
            << slam.loop_closures().size() << " loop closures accepted of " << slam.loop_attempts()
            << " candidates matched (rejected: " << st.low_score << " low score, " << st.ambiguous
            << " ambiguous, " << st.icp_failed << " ICP, " << st.disagreed
            << " ICP and matcher disagree, " << st.too_wide << " submap too wide), "
            << slam.optimizations() << " optimisations\nwrote "
            << (out_dir / "trajectory.txt").string() << " and " << (out_dir / "map.svg").string()
            << "\n";

  std::string relation_json;
  if (!relations.empty()) {
    // The Freiburg benchmark's metric (io/slam_relations.hpp): mean ± std of the relative-pose
    // errors, over all relations and split into short (< 2 s apart) and long ones.
    const auto e = rangenav::io::evaluate_slam_relations(
        rangenav::io::read_slam_relations(relations), in.timestamps, poses);
    const auto deg = [](double rad) { return rad * 180.0 / std::numbers::pi; };
    for (const auto& [name, g] : {std::pair{"all", e.all}, std::pair{"short (< 2 s)", e.short_gap},
                                  std::pair{"long", e.long_gap}})
      std::printf("relations %s: %zu, %.4f +- %.4f m, %.3f +- %.3f deg\n", name, g.count,
                  g.translation_mean, g.translation_stddev, deg(g.rotation_mean),
                  deg(g.rotation_stddev));
    relation_json = ",\"trans_error_m\":" + std::to_string(e.all.translation_mean) +
                    ",\"long_trans_error_m\":" + std::to_string(e.long_gap.translation_mean);
  }
  std::printf(
      "{\"scans\":%zu,\"key_frames\":%zu,\"loop_closures\":%zu,\"cpu_seconds\":%.3f,"
      "\"scans_per_second\":%.1f%s%s}\n",
      poses.size(), slam.key_frames(), slam.loop_closures().size(), cpu_seconds,
      double(poses.size()) / std::max(cpu_seconds, 1e-9), truth_json.c_str(),
      relation_json.c_str());
  return 0;
} catch (const std::exception& e) {
  std::cerr << "03_slam_carmen: " << e.what() << "\n";
  return 1;
}
