// Tutorial 10: pose-graph optimisation, the back end that makes a map globally consistent.
//
//   10_pose_graph [FILE.g2o] [--out OUT.g2o] [--svg OUT.svg]
//
// A pose graph has one node per robot pose and one edge per relative-pose measurement
// (odometry, scan matching, loop closures), each with an information matrix. Optimising it finds
// the poses that best explain every measurement at once. With a g2o file (2D or 3D, e.g.
// ../shared/data/pose-graphs/intel.g2o) this optimises it with the default settings; without one
// it builds a small synthetic graph: a robot that drives three laps of a 20 m x 10 m block with
// noisy odometry and closes loops where laps meet, so the error against the truth can be shown.
// The last line is JSON: vertices, edges, chi2 before and after (g2o's definition, Σ eᵀΩe),
// iterations and the optimisation time in seconds (initialisation + Levenberg-Marquardt, no I/O).

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <variant>
#include <vector>

#include "rangenav/core/lie.hpp"
#include "rangenav/io/g2o.hpp"
#include "rangenav/io/svg.hpp"
#include "rangenav/pose_graph/pose_graph.hpp"

namespace {

struct Summary {
  std::size_t vertices{0}, edges{0};
  double chi2_initial{0}, chi2_final{0}, seconds{0};
  int iterations{0};
};

// The optimisation itself, the same for 2D and 3D: the graph's dimension is a template parameter.
template <int D>
Summary optimize(rangenav::io::G2oGraph<D>& records) {
  // io/ knows nothing of the optimiser: make_pose_graph copies the file's records into a graph
  // (node i = vertex i; the file's information matrices are already in the optimiser's units).
  auto graph = rangenav::make_pose_graph<D>(records);
  const double chi2_file = graph.chi2();
  const auto start = std::chrono::steady_clock::now();
  // Starting values far from the optimum (odometry that drifted around big loops) trap any local
  // method in a wrong minimum: initialize() first solves for the rotations alone (the chordal
  // relaxation), then for the translations, both linear, using the edges only.
  graph.initialize();
  // Levenberg-Marquardt: sparse Cholesky on the normal equations, analytic Jacobians.
  const auto result = graph.optimize();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("%zuD graph: %zu nodes, %zu edges; chi2 %.6g -> %.6g in %d iterations (%s)\n",
              std::size_t(D), graph.node_count(), graph.edge_count(), chi2_file, result.chi2_final,
              result.iterations, rangenav::to_string(result.termination).data());
  for (std::size_t i = 0; i < records.vertices.size(); ++i)
    records.vertices[i].pose = graph.pose(i);
  return {graph.node_count(), graph.edge_count(), chi2_file, result.chi2_final, seconds,
          result.iterations};
}

// Three laps of a 20 m x 10 m block, a pose every metre, with odometry noise; an edge closes a
// loop wherever a pose comes within 0.5 m of one from an earlier lap.
rangenav::io::G2oGraph<2> synthetic_graph(std::vector<rangenav::Transform2d>& truth) {
  using rangenav::Transform2d;
  std::mt19937 rng(2024);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double sigma_xy = 0.05, sigma_theta = 0.01;  // per 1 m step
  for (int lap = 0; lap < 3; ++lap)
    for (const auto& [length, x, y, heading] : {std::tuple{20, 0.0, 0.0, 0.0},
                                                {10, 20.0, 0.0, M_PI / 2},
                                                {20, 20.0, 10.0, M_PI},
                                                {10, 0.0, 10.0, -M_PI / 2}})
      for (int k = 0; k < length; ++k)
        truth.push_back(rangenav::make_transform2(x + k * std::cos(heading),
                                                  y + k * std::sin(heading), heading));
  rangenav::io::G2oGraph<2> g;
  const auto add_edge = [&](std::size_t a, std::size_t b) {
    // The measured relative pose is the true one times a random error drawn from the edge's own
    // covariance, so the information matrix tells the truth about the noise.
    const rangenav::lie::PoseTangent<2> noise(sigma_xy * normal(rng), sigma_xy * normal(rng),
                                              sigma_theta * normal(rng));
    const Transform2d z = truth[a].inverse() * truth[b] * rangenav::lie::se_exp<2>(noise);
    const Eigen::Vector3d sigma(sigma_xy, sigma_xy, sigma_theta);
    g.edges.push_back({a, b, z, sigma.cwiseInverse().cwiseAbs2().asDiagonal()});
  };
  for (std::size_t i = 0; i < truth.size(); ++i) {
    g.vertices.push_back({static_cast<std::int64_t>(i), Transform2d::Identity(), i == 0});
    if (i > 0) add_edge(i - 1, i);
    for (std::size_t j = 0; j + 60 <= i; ++j)  // 60 poses per lap
      if ((truth[i].translation() - truth[j].translation()).norm() < 0.5) add_edge(j, i);
  }
  // The starting values: the odometry edges chained from the first pose.
  for (const auto& e : g.edges)
    if (e.to == e.from + 1) g.vertices[e.to].pose = g.vertices[e.from].pose * e.measurement;
  return g;
}

template <int D>
double rmse_to(const rangenav::io::G2oGraph<D>& g,
               const std::vector<rangenav::Transform<D>>& truth) {
  double sum = 0;
  for (std::size_t i = 0; i < truth.size(); ++i)
    sum += (g.vertices[i].pose.translation() - truth[i].translation()).squaredNorm();
  return std::sqrt(sum / double(truth.size()));
}

}  // namespace

int main(int argc, char** argv) {
  std::filesystem::path input, out_g2o, out_svg;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--out") == 0 && i + 1 < argc)
      out_g2o = argv[++i];
    else if (std::strcmp(argv[i], "--svg") == 0 && i + 1 < argc)
      out_svg = argv[++i];
    else
      input = argv[i];
  }

  rangenav::io::G2oFile file;
  std::vector<rangenav::Transform2d> truth;
  if (input.empty()) {
    std::printf(
        "no g2o file given: a synthetic 2D graph (three laps of a block, noisy odometry)\n");
    file = synthetic_graph(truth);
  } else {
    file = rangenav::io::read_g2o(input);
  }
  const double rmse_before = truth.empty() ? 0 : rmse_to(std::get<0>(file), truth);

  // One call for either dimension: std::visit picks optimize<2> or optimize<3>.
  const Summary s = std::visit([](auto& g) { return optimize(g); }, file);
  if (!truth.empty())
    std::printf("position error against the truth (RMS): %.3f m before, %.3f m after\n",
                rmse_before, rmse_to(std::get<0>(file), truth));

  if (!out_g2o.empty()) {
    std::visit([&](const auto& g) { rangenav::io::write_g2o(out_g2o, g); }, file);
    std::printf("wrote %s\n", out_g2o.string().c_str());
  }
  if (!out_svg.empty()) {
    // The optimised trajectory seen from above (x, y), with the loop closures in grey.
    rangenav::io::SvgDrawing svg;
    std::visit(
        [&](const auto& g) {
          std::vector<rangenav::Point2d> path;
          for (const auto& v : g.vertices)
            path.push_back(v.pose.translation().template head<2>());
          svg.layer("loop closures");
          for (const auto& e : g.edges)
            if (e.to != e.from + 1 && e.from != e.to + 1)
              svg.segment(path[e.from], path[e.to], {.stroke = "#bbbbbb", .stroke_width_px = 0.5});
          svg.layer("trajectory").polyline(path, {.stroke = "#1f77b4", .stroke_width_px = 1.0});
        },
        file);
    svg.save(out_svg);
    std::printf("wrote %s\n", out_svg.string().c_str());
  }
  std::printf(
      "{\"vertices\": %zu, \"edges\": %zu, \"chi2_initial\": %.6f, \"chi2_final\": %.6f, "
      "\"iterations\": %d, \"seconds\": %.6f}\n",
      s.vertices, s.edges, s.chi2_initial, s.chi2_final, s.iterations, s.seconds);
  return 0;
}
