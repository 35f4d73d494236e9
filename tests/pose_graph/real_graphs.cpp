// The standard benchmark graphs of ../shared/data/pose-graphs/ (PROVENANCE.md): rangenav must
// reach a χ² no higher than Ceres 2.1's from the same starting values, and on MIT.g2o, where
// Ceres stalls, a minimum whose χ² fits the graph's degrees of freedom. Times are measured by
// bench_pose_graph, not here. This file also exercises the CHOLMOD backend when rangenav::cholmod
// is found (RANGENAV_HAVE_CHOLMOD): both backends must give the same result.

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "rangenav/io/g2o.hpp"
#include "rangenav/pose_graph/pose_graph.hpp"
#include "test_support.hpp"

using namespace rangenav;

namespace {

struct Reference {
  const char* file;
  double ceres_chi2;  // PROVENANCE.md, printed to 5 significant digits
};

// χ² ≤ the reference to the precision it is printed with (half a unit of its 5th digit).
bool at_most(double chi2, double reference) {
  const double unit = std::pow(10.0, std::floor(std::log10(reference)) - 4);
  return chi2 <= reference + unit / 2;
}

template <int D>
PoseGraphResult<double> solve(const io::G2oGraph<D>& records, SparseBackend backend,
                              std::vector<Transform<D>>& poses) {
  auto graph = make_pose_graph<D>(records);
  PoseGraphOptions<double> options;
  options.backend = backend;
  REQUIRE(graph.initialize(options));
  const auto result = graph.optimize(options);
  poses = graph.poses();
  return result;
}

}  // namespace

TEST_CASE("pose graph: the benchmark graphs reach chi2 <= Ceres 2.1's", "[pose_graph][data]") {
  const Reference references[] = {{"intel.g2o", 45.005},
                                  {"CSAIL.g2o", 40.555},
                                  {"manhattan.g2o", 3549.04},
                                  {"parking-garage.g2o", 1.2390},
                                  {"sphere2500.g2o", 727.15}};
  for (const auto& [file, ceres] : references) {
    const auto path = test::data_file_or_skip(std::string("pose-graphs/") + file);
    if (path.empty()) continue;
    const io::G2oFile records = io::read_g2o(path);
    std::visit(
        [&, file = file, ceres = ceres](const auto& g) {
          constexpr int d = std::decay_t<decltype(g)>::dimension;
          std::vector<Transform<d>> eigen_poses;
          const auto result = solve<d>(g, SparseBackend::eigen, eigen_poses);
          INFO(file << ": chi2 " << result.chi2_final << ", Ceres " << ceres);
          CHECK(result.converged());
          CHECK(at_most(result.chi2_final, ceres));
          if constexpr (have_cholmod) {
            std::vector<Transform<d>> cholmod_poses;
            const auto other = solve<d>(g, SparseBackend::cholmod, cholmod_poses);
            CHECK(other.cholmod);
            CHECK(other.chi2_final == Approx(result.chi2_final).epsilon(1e-9));
            double worst = 0;
            for (std::size_t i = 0; i < eigen_poses.size(); ++i)
              worst = std::max(
                  worst, (eigen_poses[i].translation() - cholmod_poses[i].translation()).norm());
            CHECK(worst < 1e-6);  // RANGENAV_HAVE_CHOLMOD: the backends agree
          }
        },
        records);
  }
}

TEST_CASE("pose graph: MIT.g2o reaches the optimum, not Ceres' local minimum",
          "[pose_graph][data]") {
  const auto path = test::data_file_or_skip("pose-graphs/MIT.g2o");
  if (path.empty()) return;
  const auto records = io::read_g2o_as<2>(path);
  auto graph = make_pose_graph<2>(records);
  REQUIRE(graph.initialize());
  const auto result = graph.optimize();
  CHECK(result.converged());
  // At the optimum of a correctly weighted graph, χ² follows a χ² distribution with
  // 3·(edges − nodes + 1) = 60 degrees of freedom; 30,468 is 500 times that.
  const double dof = 3.0 * (double(graph.edge_count()) - double(graph.node_count() - 1));
  INFO("chi2 " << result.chi2_final << ", degrees of freedom " << dof);
  CHECK(dof == 60);
  CHECK(std::abs(result.chi2_final - dof) < 4 * std::sqrt(2 * dof));
}
