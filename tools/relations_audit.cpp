// relations_audit: the ground-truth relations of the Freiburg SLAM benchmark (Kümmerle et al.
// 2009) that a 2D SLAM result misses most, and what the two scans of each say about them.
//
// The benchmark's relations are alignments of scan pairs that a person inspected. Where the
// registration of a pair has two minima (along a corridor, in a symmetric room) a relation and a
// SLAM estimate can sit in different ones, and a large error then says little about which is
// wrong. For each of the N relations with the largest translational error, the scan at the
// second timestamp is registered to the scan at the first twice with the same point-to-line ICP
// (align(), 2D point_to_plane, pairs within 0.3 m unless --max-distance says otherwise): started
// from the relation and started from the estimate. Two ends within 1 cm of each other are one
// minimum (the ICP stops on steps of 0.1 mm), and the verdict is which of the two it lies nearer:
// the relation (the SLAM result is off there) or the estimate (the scans do not support the
// relation). Otherwise the scans hold two minima; the fitness (fraction of the scan paired) and
// RMSE of each are printed.
//
//   relations_audit [--log LOG] [--relations FILE] [--trajectory FILE] [--worst N]
//                   [--max-distance M] [--cauchy D]
//
//   --log, --relations  default: carmen/mit-csail.clf.gz and slam-benchmark/mit-csail.relations
//                       in the shared data folder
//   --trajectory FILE   the estimate: "t x y theta" per line, t the log's scan timestamps (as
//                       03_slam_carmen writes trajectory.txt); default: LaserSlam, default
//                       configuration, run on the log here
//   --worst N           how many relations to examine (default 20)
//   --max-distance M    the ICP's pairing distance (m; default 0.3)
//   --cauchy D          a Cauchy kernel of scale D metres on the ICP's residuals (default none)
//
// Prints one line per relation, then one JSON line: the relations examined, their share of the
// summed error, how many have one minimum at the relation, one at the estimate, or two, and over
// those with one minimum the mean distance of that minimum from the relation and the estimate's
// mean error. With --worst larger than the file, that compares the trajectory with registering
// each relation's two scans directly: the most local estimate there is.
//
// Where the log has odometry, the JSON line also splits the short relations (< 2 s) with one
// minimum by what the reference did with the log's odometry between the two scans: kept it
// (the relation's translation within 1 cm of the odometry's: `odometry_kept`) or moved it
// (`odometry_moved`; on MIT CSAIL by steps of a 5 cm lattice, docs/benchmarks.md). On each it
// gives the mean distance of the scans' minimum and of the estimate from the relation, and on
// the moved ones how far along the segment from the relation to the odometry each lies (the
// mean of its projection, as a fraction of the segment: 0 at the relation, 1 at the odometry).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "rangenav/io/carmen.hpp"
#include "rangenav/io/slam_relations.hpp"
#include "rangenav/io/trajectory.hpp"
#include "rangenav/mapping/loop_closing_mapper.hpp"
#include "rangenav/registration/align.hpp"

namespace {

using rangenav::Pose2d;
using rangenav::io::nearest_timestamp;

double distance(const rangenav::Transform2d& a, const rangenav::Transform2d& b) {
  return (a.translation() - b.translation()).norm();
}

}  // namespace

int main(int argc, char** argv) try {
  const std::filesystem::path data(RANGENAV_EXAMPLE_DATA_DIR);
  std::filesystem::path log_path = data / "carmen/mit-csail.clf.gz";
  std::filesystem::path relations_path = data / "slam-benchmark/mit-csail.relations";
  std::filesystem::path trajectory_path;
  std::size_t worst = 20;
  double max_distance = 0.3, cauchy = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--log" && i + 1 < argc) {
      log_path = argv[++i];
    } else if (arg == "--relations" && i + 1 < argc) {
      relations_path = argv[++i];
    } else if (arg == "--trajectory" && i + 1 < argc) {
      trajectory_path = argv[++i];
    } else if (arg == "--worst" && i + 1 < argc && std::atoi(argv[i + 1]) > 0) {
      worst = static_cast<std::size_t>(std::atoi(argv[++i]));
    } else if (arg == "--max-distance" && i + 1 < argc && std::atof(argv[i + 1]) > 0) {
      max_distance = std::atof(argv[++i]);
    } else if (arg == "--cauchy" && i + 1 < argc && std::atof(argv[i + 1]) > 0) {
      cauchy = std::atof(argv[++i]);
    } else {
      std::fprintf(stderr,
                   "usage: relations_audit [--log LOG] [--relations FILE] [--trajectory FILE] "
                   "[--worst N] [--max-distance M] [--cauchy D]\n");
      return 2;
    }
  }
  if (!std::filesystem::exists(log_path) || !std::filesystem::exists(relations_path)) {
    std::fprintf(stderr, "skipped: %s or %s not found\n", log_path.c_str(), relations_path.c_str());
    return 0;
  }
  const auto log = rangenav::io::read_carmen_scan_log(log_path);
  const auto relations = rangenav::io::read_slam_relations(relations_path);
  std::vector<double> scan_stamps;
  for (const auto& r : log.records)
    scan_stamps.push_back(r.timestamp);
  if (!std::is_sorted(scan_stamps.begin(), scan_stamps.end())) {
    std::fprintf(stderr, "relations_audit: the log's scan timestamps do not increase\n");
    return 1;
  }

  // The estimate: a trajectory file, or LaserSlam run here.
  std::vector<double> stamps;
  std::vector<Pose2d> poses;
  if (!trajectory_path.empty()) {
    for (const auto& p : rangenav::io::read_xytheta(trajectory_path)) {
      stamps.push_back(p.timestamp);
      poses.push_back(p.pose);
    }
  } else {
    rangenav::LaserSlam<double> slam;
    for (std::size_t i = 0; i < log.records.size(); ++i) {
      std::optional<rangenav::Transform2d> odometry;
      if (log.odometry[i]) odometry = log.odometry[i]->to_isometry();
      slam.process(log.records[i].scan, odometry);
    }
    slam.finish();
    stamps = scan_stamps;
    for (const auto& t : slam.trajectory())
      poses.push_back(Pose2d::from_isometry(t));
  }

  // Each relation's error: the benchmark's metric over that relation alone.
  struct Row {
    std::size_t relation;
    double error;
  };
  std::vector<Row> rows;
  double total = 0;
  for (std::size_t i = 0; i < relations.size(); ++i) {
    const auto e =
        rangenav::io::evaluate_slam_relations(std::span(&relations[i], 1), stamps, poses);
    if (e.all.count == 0) continue;
    rows.push_back({i, e.all.translation_mean});
    total += e.all.translation_mean;
  }
  std::sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) { return a.error > b.error; });
  rows.resize(std::min(rows.size(), worst));

  rangenav::AlignSettings<double> icp;
  icp.method = rangenav::RegistrationMethod::point_to_plane;
  icp.max_correspondence_distance = max_distance;
  if (cauchy > 0) icp.kernel = rangenav::RobustKernel<double>::cauchy(cauchy);
  const auto points = [&](std::size_t record) {
    std::vector<rangenav::Point2d> out;
    for (const auto& p : log.records[record].scan.points())
      if (p.allFinite()) out.push_back(p);
    return out;
  };
  std::size_t at_relation = 0, at_estimate = 0, two_minima = 0;
  double listed = 0;
  // Over the relations with one minimum: its distance from the relation, the estimate's error.
  double minimum_to_relation = 0, estimate_error = 0;
  // The short relations with one minimum, by what the reference did with the odometry.
  struct Split {
    std::size_t count = 0;
    double minimum_error = 0, estimate_error = 0, minimum_along = 0, estimate_along = 0;
  } kept, moved;
  std::printf("%7s %7s %7s | %-26s | %-26s | %s\n", "t1 (s)", "gap (s)", "error",
              "ICP from the relation", "ICP from the estimate", "the scans' minimum");
  for (const Row& row : rows) {
    const auto& r = relations[row.relation];
    const auto a = nearest_timestamp(scan_stamps, r.first),
               b = nearest_timestamp(scan_stamps, r.second);
    const auto pa = nearest_timestamp(stamps, r.first), pb = nearest_timestamp(stamps, r.second);
    if (!a || !b || !pa || !pb) continue;
    listed += row.error;
    const rangenav::Transform2d relation = r.delta.to_isometry();
    const rangenav::Transform2d estimate =
        poses[*pa].to_isometry().inverse(Eigen::Isometry) * poses[*pb].to_isometry();
    const auto model = points(*a), scan = points(*b);
    const auto from_relation = rangenav::align(model, scan, relation, icp);
    const auto from_estimate = rangenav::align(model, scan, estimate, icp);
    char verdict[128];
    if (distance(from_relation.transform, from_estimate.transform) < 0.01) {
      const double to_r = distance(from_estimate.transform, relation);
      const double to_e = distance(from_estimate.transform, estimate);
      (to_r < to_e ? at_relation : at_estimate)++;
      minimum_to_relation += to_r;
      estimate_error += row.error;
      if (r.second - r.first < 2 && log.odometry[*a] && log.odometry[*b]) {
        const Eigen::Vector2d odometry = (log.odometry[*a]->to_isometry().inverse(Eigen::Isometry) *
                                          log.odometry[*b]->to_isometry())
                                             .translation();
        const Eigen::Vector2d segment = odometry - relation.translation();
        const bool kept_it = segment.norm() < 0.01;
        Split& split = kept_it ? kept : moved;
        ++split.count;
        split.minimum_error += to_r;
        split.estimate_error += row.error;
        if (!kept_it) {
          const auto along = [&](const rangenav::Transform2d& t) {
            return (t.translation() - relation.translation()).dot(segment) / segment.squaredNorm();
          };
          split.minimum_along += along(from_estimate.transform);
          split.estimate_along += along(estimate);
        }
      }
      std::snprintf(verdict, sizeof verdict,
                    "one, %.3f m from the relation, %.3f m from the estimate", to_r, to_e);
    } else {
      ++two_minima;
      std::snprintf(verdict, sizeof verdict, "two");
    }
    std::printf("%7.1f %7.1f %5.3f m | fitness %.2f rmse %.3f m | fitness %.2f rmse %.3f m | %s\n",
                r.first - scan_stamps.front(), r.second - r.first, row.error, from_relation.fitness,
                from_relation.rmse, from_estimate.fitness, from_estimate.rmse, verdict);
  }
  const auto mean = [](double sum, std::size_t n) { return sum / std::max<double>(1, double(n)); };
  const std::size_t one = at_relation + at_estimate;
  std::printf(
      "{\"relations\":%zu,\"examined\":%zu,\"share_of_error\":%.3f,\"one_minimum_at_relation\":%zu,"
      "\"one_minimum_at_estimate\":%zu,\"two_minima\":%zu,\"one_minimum_to_relation_m\":%.4f,"
      "\"one_minimum_estimate_error_m\":%.4f,\"odometry_kept\":%zu,\"kept_minimum_m\":%.4f,"
      "\"kept_estimate_m\":%.4f,\"odometry_moved\":%zu,\"moved_minimum_m\":%.4f,"
      "\"moved_estimate_m\":%.4f,\"moved_minimum_along\":%.2f,\"moved_estimate_along\":%.2f}\n",
      relations.size(), at_relation + at_estimate + two_minima, total > 0 ? listed / total : 0.0,
      at_relation, at_estimate, two_minima, mean(minimum_to_relation, one),
      mean(estimate_error, one), kept.count, mean(kept.minimum_error, kept.count),
      mean(kept.estimate_error, kept.count), moved.count, mean(moved.minimum_error, moved.count),
      mean(moved.estimate_error, moved.count), mean(moved.minimum_along, moved.count),
      mean(moved.estimate_along, moved.count));
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "relations_audit: %s\n", e.what());
  return 1;
}
