// The snippets of docs/pose_graph.md, compiled and run; each test checks what the page says the
// snippet does.

#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

#include "io/scratch_dir.hpp"
#include "rangenav/core/lie.hpp"
#include "rangenav/io/g2o.hpp"
#include "rangenav/pose_graph/pose_graph.hpp"

TEST_CASE("pose_graph: a graph of two poses", "[docs]") {
  // [snippet:pose-graph]
  rangenav::PoseGraph2d graph;
  const auto a = graph.add_node(rangenav::make_transform2(0.0, 0.0, 0.0), /*fixed=*/true);
  const auto b = graph.add_node(rangenav::make_transform2(1.1, 0.1, 0.0));  // a rough guess
  // Odometry: b seen from a, 1 m ahead, with sigma = 5 cm, 5 cm, 0.01 rad.
  const Eigen::Vector3d sigma(0.05, 0.05, 0.01);
  const Eigen::Matrix3d covariance = sigma.cwiseAbs2().asDiagonal();
  graph.add_edge(a, b, rangenav::make_transform2(1.0, 0.0, 0.0),
                 rangenav::information_from_covariance<2, double>(covariance));
  // A loop closure gets a loss that rejects it if it is false:
  //   graph.add_edge(i, j, z, information, rangenav::DynamicCovarianceScaling<double>{1.0});
  const auto result = graph.optimize();  // from the current poses
  // result.converged(), result.chi2_final = 0, graph.pose(b) = (1, 0, 0)
  // [snippet-end]
  CHECK(result.converged());
  CHECK(result.chi2_final < 1e-20);
  CHECK(graph.pose(b).translation().isApprox(rangenav::Point2d(1, 0)));
}

TEST_CASE("pose_graph: optimising a g2o file", "[docs]") {
  // A 3D ring of 12 poses whose edges are the true relative poses; the file's vertices are off.
  rangenav::test::ScratchDir dir("docs_pose_graph");
  const auto input = dir / "ring.g2o", output = dir / "ring-optimised.g2o";
  std::vector<rangenav::Transform3d> truth;
  rangenav::io::G2oGraph<3> ring;
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (int i = 0; i < 12; ++i) {
    const double angle = 2 * std::numbers::pi * i / 12;
    rangenav::Transform3d t = rangenav::Transform3d::Identity();
    t.translation() = rangenav::Point3d(4 * std::cos(angle), 4 * std::sin(angle), 0.1 * i);
    t.linear() = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    truth.push_back(t);
    rangenav::lie::PoseTangent<3> off;
    for (int k = 0; k < 6; ++k)
      off(k) = i == 0 ? 0.0 : noise(rng);
    ring.vertices.push_back({i, t * rangenav::lie::se_exp<3>(off), false});
  }
  for (std::size_t i = 0; i < 12; ++i)
    ring.edges.push_back({i, (i + 1) % 12, truth[i].inverse() * truth[(i + 1) % 12],
                          rangenav::lie::PoseMatrix<3>::Identity()});
  rangenav::io::write_g2o(input, ring);

  // [snippet:g2o]
  auto records = rangenav::io::read_g2o_as<3>(input);  // a 3D g2o file
  auto graph = rangenav::make_pose_graph<3>(records);
  graph.initialize();  // rotations, then translations, from the edges alone
  const auto result = graph.optimize();
  for (std::size_t i = 0; i < records.vertices.size(); ++i)
    records.vertices[i].pose = graph.pose(i);
  rangenav::io::write_g2o(output, records);
  // [snippet-end]
  CHECK(result.chi2_final < 1e-16);
  const auto back = rangenav::io::read_g2o_as<3>(output);
  for (std::size_t i = 0; i < truth.size(); ++i)
    CHECK((back.vertices[i].pose.translation() - truth[i].translation()).norm() < 1e-6);
}
