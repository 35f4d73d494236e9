// laser_front_end_study: how sensitive the 2D laser front end (LaserSlamMapper, no loop closure)
// is on the MIT CSAIL benchmark log. It maps the log with laser_slam_params() and with each of its
// settings moved one step either way, and scores every run against the Freiburg relations. The
// front end's error over the long relations is a drift that a small change anywhere moves by
// tenths of a metre, so one configuration's figure says little: compare the spread (mean and
// median over the neighbourhood) when judging a change of the registration. With --slam the runs
// are of the whole loop-closing SLAM (LaserSlam: submaps, loop closure, pose graph) instead,
// scored on its optimised trajectory: its single figure moves by a few millimetres with any change
// that alters one loop decision, so judge a change of it by the spread too.
//
//   laser_front_end_study [--log LOG] [--relations FILE] [--gauss-newton-steps N] [--cauchy D]
//                         [--slam] [--odometry-jitter M [--runs N]]
//
//   --log, --relations       default: carmen/mit-csail.clf.gz and
//                            slam-benchmark/mit-csail.relations in the shared data folder
//   --gauss-newton-steps N   the point-to-line solver's steps per ICP iteration (default:
//                            laser_slam_params()'s solver_gauss_newton_steps, 10)
//   --cauchy D               a Cauchy kernel of scale D metres on the front end's map
//                            registration (its icp.solver.kernel; default none). LaserSlam's
//                            loop-closure ICP keeps the defaults' (none).
//   --slam                   LaserSlam with loop closure (LoopClosureParams' defaults) over the
//                            same front-end settings, instead of LaserSlamMapper
//   --odometry-jitter M      instead of the neighbourhood: laser_slam_params() N times (default
//                            16), the odometry's x and y moved by up to ±M metres (uniform, seed =
//                            run; run 0 as logged). Millimetres are far below the odometry's own
//                            error, so the spread is that of the front end's decisions (a
//                            registration that lands on either side of a gate), not of the input.
//
// Prints one line per run (mean translational error of all, short and long relations) and,
// last, one JSON line with the mean and median over the runs of the all-relations error and of
// the long-relations error.

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rangenav/io/carmen.hpp"
#include "rangenav/io/slam_relations.hpp"
#include "rangenav/mapping/incremental_mapper.hpp"
#include "rangenav/mapping/loop_closing_mapper.hpp"

namespace {

using Params = rangenav::IncrementalMapperParams<double>;

struct Errors {
  double all, long_gap;
};

double mean_of(const std::vector<double>& v) {
  double sum = 0;
  for (const double a : v)
    sum += a;
  return sum / static_cast<double>(v.size());
}

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

struct Setting {
  const char* name;
  std::function<void(Params&)> change;
};

std::vector<Setting> neighbourhood() {
  constexpr double deg = std::numbers::pi / 180;
  return {
      {"laser_slam_params()", [](Params&) {}},
      {"key frames 0.20 m", [](Params& p) { p.key_frames.min_distance = 0.2; }},
      {"key frames 0.30 m", [](Params& p) { p.key_frames.min_distance = 0.3; }},
      {"key frames 8 deg", [](Params& p) { p.key_frames.min_angle = 8 * deg; }},
      {"key frames 12 deg", [](Params& p) { p.key_frames.min_angle = 12 * deg; }},
      {"initial match 0.4 m", [](Params& p) { p.initial_match_distance = 0.4; }},
      {"initial match 0.6 m", [](Params& p) { p.initial_match_distance = 0.6; }},
      {"final match 0.18 m", [](Params& p) { p.final_match_distance = 0.18; }},
      {"final match 0.22 m", [](Params& p) { p.final_match_distance = 0.22; }},
      {"correction 0.4 m", [](Params& p) { p.max_correction_distance = 0.4; }},
      {"correction 0.6 m", [](Params& p) { p.max_correction_distance = 0.6; }},
      {"correction 2.5 deg", [](Params& p) { p.max_correction_angle = 2.5 * deg; }},
      {"correction 3.5 deg", [](Params& p) { p.max_correction_angle = 3.5 * deg; }},
      {"eps_D 0.13 m", [](Params& p) { p.map.epsilon_d = 0.13; }},
      {"eps_D 0.17 m", [](Params& p) { p.map.epsilon_d = 0.17; }},
  };
}

}  // namespace

int main(int argc, char** argv) {
  const std::filesystem::path data(RANGENAV_EXAMPLE_DATA_DIR);
  std::filesystem::path log_path = data / "carmen/mit-csail.clf.gz";
  std::filesystem::path relations_path = data / "slam-benchmark/mit-csail.relations";
  std::optional<int> steps;
  double cauchy = 0;
  bool slam = false;
  double jitter = 0;
  int runs = 16;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--log" && i + 1 < argc) {
      log_path = argv[++i];
    } else if (arg == "--relations" && i + 1 < argc) {
      relations_path = argv[++i];
    } else if (arg == "--gauss-newton-steps" && i + 1 < argc) {
      steps = std::atoi(argv[++i]);
    } else if (arg == "--cauchy" && i + 1 < argc) {
      cauchy = std::atof(argv[++i]);
    } else if (arg == "--slam") {
      slam = true;
    } else if (arg == "--odometry-jitter" && i + 1 < argc) {
      jitter = std::atof(argv[++i]);
    } else if (arg == "--runs" && i + 1 < argc) {
      runs = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr,
                   "usage: laser_front_end_study [--log LOG] [--relations FILE] "
                   "[--gauss-newton-steps N] [--cauchy D] [--slam] "
                   "[--odometry-jitter M [--runs N]]\n");
      return 2;
    }
  }
  if (!(jitter >= 0) || runs < 1 || !(cauchy >= 0)) {
    std::fprintf(stderr,
                 "laser_front_end_study: --odometry-jitter and --cauchy must be >= 0, --runs >= "
                 "1\n");
    return 2;
  }
  if (!std::filesystem::exists(log_path) || !std::filesystem::exists(relations_path)) {
    std::fprintf(stderr, "skipped: %s or %s not found\n", log_path.c_str(), relations_path.c_str());
    return 0;
  }
  const auto lasers = rangenav::io::read_carmen_lasers(log_path);
  const auto relations = rangenav::io::read_slam_relations(relations_path);

  // One run of the front end: the settings changed by `change`, the odometry jittered with `seed`
  // (0: as logged); prints the errors and returns the means over all and over the long relations.
  const auto run = [&](const char* name, const std::function<void(Params&)>& change,
                       unsigned seed) {
    Params params = rangenav::laser_slam_params<double>();
    if (steps) params.solver_gauss_newton_steps = *steps;
    change(params);
    // Only the mapper the run uses is built.
    std::optional<rangenav::LaserSlamMapper<double>> mapper;
    std::optional<rangenav::LaserSlam<double>> full;
    if (slam)
      full.emplace(params, rangenav::LoopClosureParams<double>{});
    else
      mapper.emplace(params);
    // The map registration's robust kernel (none by default).
    auto& icp = full ? full->front_end().icp : mapper->icp;
    if (cauchy > 0) icp.solver.kernel = rangenav::RobustKernel<double>::cauchy(cauchy);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> offset(-jitter, jitter);
    std::vector<double> stamps;
    std::vector<rangenav::Pose2d> poses;
    for (const auto& laser : lasers) {
      std::optional<rangenav::Transform2d> odometry;
      if (const auto own = rangenav::io::laser_odometry(laser)) {
        rangenav::Pose2d pose = *own;
        if (seed != 0) {
          pose.x += offset(rng);
          pose.y += offset(rng);
        }
        odometry = pose.to_isometry();
      }
      stamps.push_back(laser.timestamp);
      if (full)
        full->process(laser.scan, odometry);
      else
        poses.push_back(
            rangenav::Pose2d::from_isometry(mapper->process(laser.scan, odometry).pose));
    }
    if (full) {
      full->finish();
      for (const auto& pose : full->trajectory())
        poses.push_back(rangenav::Pose2d::from_isometry(pose));
    }
    const auto e = rangenav::io::evaluate_slam_relations(relations, stamps, poses);
    std::printf("%-22s all %.4f m  short %.4f m  long %.4f m\n", name, e.all.translation_mean,
                e.short_gap.translation_mean, e.long_gap.translation_mean);
    std::fflush(stdout);
    return Errors{e.all.translation_mean, e.long_gap.translation_mean};
  };

  std::vector<double> all, long_gap;
  const auto add = [&](const Errors& e) {
    all.push_back(e.all);
    long_gap.push_back(e.long_gap);
  };
  if (jitter > 0) {
    for (int r = 0; r < runs; ++r) {
      const std::string name = "run " + std::to_string(r);
      add(run(
          name.c_str(), [](Params&) {}, static_cast<unsigned>(r)));
    }
  } else {
    for (const auto& [name, change] : neighbourhood())
      add(run(name, change, 0));
  }
  std::printf(
      "{\"runs\":%zu,\"first_m\":%.4f,\"mean_m\":%.4f,\"median_m\":%.4f,\"long_mean_m\":%.4f,"
      "\"long_median_m\":%.4f}\n",
      all.size(), all.front(), mean_of(all), median_of(all), mean_of(long_gap),
      median_of(long_gap));
  return 0;
}
