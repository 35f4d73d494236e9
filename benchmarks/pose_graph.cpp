// Pose-graph optimisation on the standard benchmark graphs in ../shared/data/pose-graphs/ (every
// *.g2o file there, 2D and 3D), by rangenav and, when Ceres is found, by Ceres 2.1 on the same
// graph in the same run.
//
//   bench_pose_graph [--benchmark_filter=intel]
//
// BM_pose_graph/<graph> runs rangenav with the default settings (PoseGraph::initialize() +
// optimize(); the automatic sparse backend: CHOLMOD's supernodal Cholesky for graphs whose fill
// makes it pay when rangenav::cholmod is found, i.e. RANGENAV_HAVE_CHOLMOD is defined, Eigen's
// SimplicialLDLT otherwise); BM_pose_graph_eigen/<graph> forces the header-only Eigen backend.
// Each iteration runs rangenav and then Ceres (Levenberg-Marquardt, SPARSE_NORMAL_CHOLESKY, one
// thread, otherwise Ceres' defaults), both from the file's initial values (or the odometry chain
// where the file has no VERTEX lines, as io::read_g2o places them), both minimising g2o's error
// (2D: t2v(Z⁻¹·Xa⁻¹·Xb); 3D: translation and quaternion vector part, w ≥ 0, of Z⁻¹·Xa⁻¹·Xb) with
// the first vertex held fixed. Building the problem is not timed; the solver's own set-up
// (ordering, symbolic analysis) is. The benchmark's time is rangenav's; counters:
//   chi2_initial                             g2o's χ² = Σ eᵀΩe at the initial values
//   chi2_final, iterations, cholmod          rangenav (cholmod = 1 when CHOLMOD factored)
//   ceres_chi2, ceres_iterations, ceres_s    Ceres (iterations as Ceres counts them)
//   time_ratio                               rangenav's time / Ceres' time, per iteration, averaged
// On a shared machine trust the ratio (both run alternately under the same load) more than the
// absolute times.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <string>
#include <variant>
#include <vector>

#include "rangenav/io/g2o.hpp"
#include "rangenav/pose_graph/pose_graph.hpp"

#ifdef RANGENAV_HAVE_CERES
#include <ceres/ceres.h>
#include <ceres/rotation.h>
#endif

namespace {

const std::filesystem::path data_dir = RANGENAV_BENCH_DATA_DIR;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

#ifdef RANGENAV_HAVE_CERES

// r = Lᵀ·e with Ω = L·Lᵀ, so that rᵀr = eᵀΩe.
template <int K>
Eigen::Matrix<double, K, K> sqrt_information(const Eigen::Matrix<double, K, K>& information) {
  return information.llt().matrixU();
}

// g2o's EDGE_SE2 error for parameters (x, y, θ) of a and b.
struct Se2Error {
  Eigen::Vector3d z;  // x, y, θ of the measurement
  Eigen::Matrix3d sqrt_info;

  template <class T>
  bool operator()(const T* a, const T* b, T* residual) const {
    using std::cos, std::sin;
    const T ca = cos(a[2]), sa = sin(a[2]);
    const T dx = b[0] - a[0], dy = b[1] - a[1];
    const T lx = ca * dx + sa * dy, ly = -sa * dx + ca * dy;  // Xa⁻¹·Xb
    const double cz = std::cos(z(2)), sz = std::sin(z(2));
    Eigen::Matrix<T, 3, 1> e;
    e(0) = cz * (lx - z(0)) + sz * (ly - z(1));  // Z⁻¹·(…)
    e(1) = -sz * (lx - z(0)) + cz * (ly - z(1));
    const T angle = b[2] - a[2] - z(2);
    e(2) = angle - T(2 * M_PI) * ceres::floor((angle + T(M_PI)) / T(2 * M_PI));
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residual);
    r = sqrt_info.cast<T>() * e;
    return true;
  }
};

// g2o's EDGE_SE3:QUAT error for parameters (t, q) of a and b, q as Eigen stores it (x, y, z, w).
struct Se3Error {
  Eigen::Vector3d z_t;
  Eigen::Quaterniond z_q;
  Eigen::Matrix<double, 6, 6> sqrt_info;

  template <class T>
  bool operator()(const T* ta, const T* qa, const T* tb, const T* qb, T* residual) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> pa(ta), pb(tb);
    const Eigen::Map<const Eigen::Quaternion<T>> ra(qa), rb(qb);
    const Eigen::Quaternion<T> ra_inv = ra.conjugate();
    const Eigen::Quaternion<T> zq_inv = z_q.conjugate().template cast<T>();
    const Eigen::Matrix<T, 3, 1> t_ab = ra_inv * (pb - pa);
    Eigen::Quaternion<T> q_e = zq_inv * (ra_inv * rb);
    if (q_e.w() < T(0)) q_e.coeffs() = -q_e.coeffs();
    Eigen::Matrix<T, 6, 1> e;
    e.template head<3>() = zq_inv * (t_ab - z_t.cast<T>());
    e.template tail<3>() = q_e.vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = sqrt_info.cast<T>() * e;
    return true;
  }
};

struct CeresRun {
  double chi2{0};
  int iterations{0};
  double seconds{0};
};

ceres::Solver::Options ceres_options() {
  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.num_threads = 1;
  options.max_num_iterations = 100;
  options.logging_type = ceres::SILENT;
  return options;
}

CeresRun run_ceres(const rangenav::io::G2oGraph<2>& g) {
  std::vector<Eigen::Vector3d> x(g.vertices.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    const auto& p = g.vertices[i].pose;
    x[i] = {p.translation().x(), p.translation().y(), rangenav::rotation_angle(p)};
  }
  ceres::Problem problem;
  for (const auto& e : g.edges) {
    const Eigen::Vector3d z(e.measurement.translation().x(), e.measurement.translation().y(),
                            rangenav::rotation_angle(e.measurement));
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Se2Error, 3, 3, 3>(
                                 new Se2Error{z, sqrt_information<3>(e.information)}),
                             nullptr, x[e.from].data(), x[e.to].data());
  }
  problem.SetParameterBlockConstant(x[0].data());
  ceres::Solver::Summary summary;
  const auto start = std::chrono::steady_clock::now();
  ceres::Solve(ceres_options(), &problem, &summary);
  const double seconds = seconds_since(start);
  // Ceres' cost is ½·Σ rᵀr.
  return {2 * summary.final_cost,
          static_cast<int>(summary.num_successful_steps + summary.num_unsuccessful_steps), seconds};
}

CeresRun run_ceres(const rangenav::io::G2oGraph<3>& g) {
  std::vector<Eigen::Vector3d> t(g.vertices.size());
  std::vector<Eigen::Quaterniond> q(g.vertices.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    t[i] = g.vertices[i].pose.translation();
    q[i] = Eigen::Quaterniond(Eigen::Matrix3d(g.vertices[i].pose.linear()));
  }
  ceres::Problem problem;
  for (const auto& e : g.edges) {
    const Eigen::Quaterniond zq(Eigen::Matrix3d(e.measurement.linear()));
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<Se3Error, 6, 3, 4, 3, 4>(
            new Se3Error{e.measurement.translation(), zq, sqrt_information<6>(e.information)}),
        nullptr, t[e.from].data(), q[e.from].coeffs().data(), t[e.to].data(),
        q[e.to].coeffs().data());
  }
  for (auto& quaternion : q)
    problem.SetManifold(quaternion.coeffs().data(), new ceres::EigenQuaternionManifold);
  problem.SetParameterBlockConstant(t[0].data());
  problem.SetParameterBlockConstant(q[0].coeffs().data());
  ceres::Solver::Summary summary;
  const auto start = std::chrono::steady_clock::now();
  ceres::Solve(ceres_options(), &problem, &summary);
  const double seconds = seconds_since(start);
  return {2 * summary.final_cost,
          static_cast<int>(summary.num_successful_steps + summary.num_unsuccessful_steps), seconds};
}

#endif  // RANGENAV_HAVE_CERES

template <int D>
void run(benchmark::State& state, const rangenav::io::G2oGraph<D>& records,
         rangenav::SparseBackend backend) {
  rangenav::PoseGraphOptions<double> options;
  options.backend = backend;
  rangenav::PoseGraphResult<double> result;
  double chi2_initial = 0;
  [[maybe_unused]] double ratio_sum = 0, ceres_seconds = 0;
  [[maybe_unused]] double ceres_chi2 = 0;
  [[maybe_unused]] int ceres_iterations = 0;
  for (auto _ : state) {
    auto graph = rangenav::make_pose_graph<D>(records);
    chi2_initial = graph.chi2();
    const auto start = std::chrono::steady_clock::now();
    graph.initialize(options);
    result = graph.optimize(options);
    const double seconds = seconds_since(start);
    state.SetIterationTime(seconds);
#ifdef RANGENAV_HAVE_CERES
    const CeresRun peer = run_ceres(records);
    ceres_chi2 = peer.chi2;
    ceres_iterations = peer.iterations;
    ceres_seconds += peer.seconds;
    ratio_sum += seconds / peer.seconds;
#endif
  }
  state.counters["vertices"] = static_cast<double>(records.vertices.size());
  state.counters["edges"] = static_cast<double>(records.edges.size());
  state.counters["chi2_initial"] = chi2_initial;
  state.counters["chi2_final"] = result.chi2_final;
  state.counters["iterations"] = result.iterations;
  state.counters["cholmod"] = result.cholmod ? 1 : 0;
#ifdef RANGENAV_HAVE_CERES
  const auto n = static_cast<double>(state.iterations());
  state.counters["ceres_chi2"] = ceres_chi2;
  state.counters["ceres_iterations"] = ceres_iterations;
  state.counters["ceres_s"] = ceres_seconds / n;
  state.counters["time_ratio"] = ratio_sum / n;
#endif
}

}  // namespace

int main(int argc, char** argv) {
  const auto dir = data_dir / "pose-graphs";
  std::vector<std::filesystem::path> files;
  if (std::filesystem::is_directory(dir))
    for (const auto& entry : std::filesystem::directory_iterator(dir))
      if (entry.path().extension() == ".g2o") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  if (files.empty()) {
    benchmark::RegisterBenchmark("BM_pose_graph/no_data", [dir](benchmark::State& state) {
      for (auto _ : state) {
      }
      state.SkipWithError(("no *.g2o file in " + dir.string()).c_str());
    });
  }
  // The graphs are read once, before timing; each benchmark copies them into a PoseGraph.
  std::vector<rangenav::io::G2oFile> graphs;
  graphs.reserve(files.size());
  for (const auto& file : files) {
    graphs.push_back(rangenav::io::read_g2o(file));
    const auto& g = graphs.back();
    for (const auto& [prefix, backend] :
         {std::pair{"BM_pose_graph/", rangenav::SparseBackend::automatic},
          std::pair{"BM_pose_graph_eigen/", rangenav::SparseBackend::eigen}}) {
#ifndef RANGENAV_HAVE_CHOLMOD
      if (backend == rangenav::SparseBackend::eigen) continue;  // the same as automatic here
#endif
      benchmark::RegisterBenchmark(
          (prefix + file.stem().string()).c_str(),
          [&g, backend = backend](benchmark::State& state) {
            std::visit([&](const auto& records) { run(state, records, backend); }, g);
          })
          ->UseManualTime()
          ->Unit(benchmark::kMillisecond)
          ->MinTime(1.0);
    }
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
