#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <vector>

#include "rangenav/geometry/voxel_grid.hpp"
#include "rangenav/io/pcd.hpp"
#include "rangenav/registration/frustum.hpp"
#include "rangenav/registration/gicp_solver.hpp"
#include "rangenav/registration/icp.hpp"
#include "rangenav/registration/normals.hpp"
#include "rangenav/registration/point_to_line_solver.hpp"
#include "rangenav/registration/point_to_plane_solver.hpp"
#include "rangenav/registration/point_to_point_solver.hpp"
#include "rangenav/registration/rejectors.hpp"
#include "rangenav/search/kd_tree.hpp"
#include "registration/kitti_pair.hpp"
#include "registration/scenes.hpp"
#include "test_support.hpp"

using namespace rangenav;
using test::make_transform3;
using test::transform_error;

// ---- static conformance table ----------------------------------------------------------------
static_assert(CorrespondenceRejector<DecayingDistanceRejector<double>, 2, double>);
static_assert(CorrespondenceRejector<DecayingDistanceRejector<float>, 3, float>);
static_assert(CorrespondenceRejector<UniqueModelPointRejector, 3, double>);
static_assert(CorrespondenceRejector<TrimmedRejector<double>, 2, double>);
static_assert(CorrespondenceRejector<MaxDistanceRejector<double>, 3, double>);
static_assert(CorrespondenceRejector<FrustumRejector<2, double>, 2, double>);
static_assert(CorrespondenceRejector<FrustumRejector<3, double>, 3, double>);
static_assert(!CorrespondenceRejector<int, 2, double>);
static_assert(!CorrespondenceRejector<FrustumRejector<3, double>, 2, double>);
static_assert(TransformSolver<PointToPointSolver<2, double>, 2, double>);
static_assert(TransformSolver<PointToPointSolver<3, float>, 3, float>);
static_assert(TransformSolver<PointToLineSolver<double>, 2, double>);
static_assert(TransformSolver<PointToLineSolver<float>, 2, float>);
static_assert(TransformSolver<PointToPlaneSolver<3, double>, 3, double>);
static_assert(TransformSolver<PointToPlaneSolver<3, float>, 3, float>);
static_assert(TransformSolver<GicpSolver<2, double>, 2, double>);
static_assert(TransformSolver<GicpSolver<3, float>, 3, float>);
static_assert(!TransformSolver<PointToPlaneSolver<3, double>, 2, double>);
static_assert(!TransformSolver<int, 2, double>);
static_assert(ModelNormalSolver<PointToLineSolver<double>, 2, double>);
static_assert(ModelNormalSolver<PointToPlaneSolver<3, double>, 3, double>);
static_assert(!ModelNormalSolver<PointToPointSolver<3, double>, 3, double>);
static_assert(!ModelNormalSolver<GicpSolver<3, double>, 3, double>);
static_assert(CovarianceSolver<GicpSolver<2, double>, 2, double>);
static_assert(!CovarianceSolver<PointToPlaneSolver<3, double>, 3, double>);

namespace {

template <int D>
std::vector<Correspondence<D, double>> exact_pairs(const std::vector<Point<D, double>>& data,
                                                   const Transform<D, double>& t) {
  std::vector<Correspondence<D, double>> pairs;
  for (std::size_t i = 0; i < data.size(); ++i)
    pairs.push_back(
        {data[i], t * data[i], 0.0, static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(i)});
  return pairs;
}

/// The context of a solver call that starts at t (no prior, one thread).
template <int D>
SolveContext<D, double> at(const Transform<D, double>& t) {
  return {t, nullptr, 1};
}

std::vector<Eigen::Vector2d> read_csv_2d(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::vector<Eigen::Vector2d> pts;
  std::string line;
  while (std::getline(in, line)) {
    for (auto& ch : line)
      if (ch == ',') ch = ' ';
    std::istringstream s(line);
    double x, y;
    if (s >> x >> y) pts.emplace_back(x, y);
  }
  return pts;
}

}  // namespace

// ---- solvers ---------------------------------------------------------------------------------

TEST_CASE("2D closed-form solver recovers a known transform exactly", "[registration]") {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-5, 5);
  std::vector<Eigen::Vector2d> data(30);
  for (auto& p : data)
    p = {u(rng), u(rng)};
  for (double theta : {0.0, 0.3, -2.5, std::numbers::pi - 1e-9, 3.0}) {
    const auto truth = make_transform2(1.5, -0.7, theta);
    const auto t = PointToPointSolver<2, double>{}.solve(exact_pairs<2>(data, truth));
    REQUIRE(t);
    const auto [et, er] = transform_error<2>(*t, truth);
    CHECK(et < 1e-9);
    CHECK(er < 1e-9);
  }
}

TEST_CASE("point-to-line solver: exact on lines, indifferent to sliding along them",
          "[registration]") {
  // Model: points on the four walls of a 4 m x 3 m room with their wall normals. Data: the
  // same wall points seen through a known transform, each paired with a model point that lies
  // up to 0.3 m away ALONG its wall (what a sparse map gives). Point-to-point is biased by the
  // sliding; point-to-line recovers the transform exactly.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> along(-0.3, 0.3), u(0.0, 1.0);
  std::vector<Eigen::Vector2d> model_points, normals;
  std::vector<Correspondence<2, double>> pairs;
  const auto truth = make_transform2(0.4, -0.25, 0.2);
  const Transform2d to_data = truth.inverse(Eigen::Isometry);
  const Eigen::Vector2d corners[4] = {{-2, -1.5}, {2, -1.5}, {2, 1.5}, {-2, 1.5}};
  for (int wall = 0; wall < 4; ++wall) {
    const Eigen::Vector2d a = corners[wall], b = corners[(wall + 1) % 4];
    const Eigen::Vector2d dir = (b - a).normalized(), normal(-dir.y(), dir.x());
    for (int k = 0; k < 25; ++k) {
      const Eigen::Vector2d on_wall = a + (b - a) * u(rng);
      const Eigen::Vector2d m = on_wall + dir * along(rng);
      const auto index = static_cast<std::uint32_t>(model_points.size());
      model_points.push_back(m);
      normals.push_back(k % 5 == 4 ? Eigen::Vector2d::Zero() : normal);  // some without a line
      pairs.push_back({to_data * on_wall, m, 0.0, index, index});
    }
  }
  PointToLineSolver<double> solver;
  solver.model_normals = normals;
  solver.gauss_newton_steps = 10;
  const Transform2d identity = Transform2d::Identity();
  const auto t = solver.solve(pairs, at<2>(identity));
  REQUIRE(t);
  // The pairs without a normal are left out; those with one fix the pose exactly.
  std::vector<Correspondence<2, double>> lines;
  for (const auto& c : pairs)
    if (normals[c.model_index].squaredNorm() > 0) lines.push_back(c);
  const auto exact = solver.solve(lines, at<2>(identity));
  REQUIRE(exact);
  const auto [et, er] = transform_error<2>(*exact, truth);
  CHECK(et < 1e-9);
  CHECK(er < 1e-9);
  const auto p2p = PointToPointSolver<2, double>{}.solve(lines);
  REQUIRE(p2p);
  CHECK(transform_error<2>(*p2p, truth).first > 1e-3);
  CHECK(t->isApprox(*exact, 1e-12));
  // With every normal zero (or none given) it is the point-to-point solver.
  PointToLineSolver<double> no_normals;
  const auto same = no_normals.solve(lines, at<2>(identity));
  REQUIRE(same);
  CHECK(same->isApprox(*p2p));
  // Too few pairs / identical data points: no transform.
  CHECK_FALSE(solver.solve(std::span(lines).first(2), at<2>(identity)).has_value());
  std::vector<Correspondence<2, double>> identical(5, lines.front());
  CHECK_FALSE(solver.solve(identical, at<2>(identity)).has_value());
  // Along a corridor (two parallel walls) the axis is unconstrained: the truncated step keeps
  // the start's position there and the answer stays finite.
  std::vector<Correspondence<2, double>> corridor;
  for (const auto& c : lines)
    if (std::abs(normals[c.model_index].y()) > 0.5) corridor.push_back(c);
  const auto along_axis = solver.solve(corridor, at<2>(identity));
  REQUIRE(along_axis);
  CHECK(along_axis->matrix().allFinite());
  CHECK(std::abs(along_axis->translation().y() - truth.translation().y()) < 1e-6);
}

TEST_CASE("3D SVD solver recovers rotations and never returns a reflection", "[registration]") {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-5, 5);
  std::vector<Eigen::Vector3d> data(30), planar(30);
  for (auto& p : data)
    p = {u(rng), u(rng), u(rng)};
  for (auto& p : planar)
    p = {u(rng), u(rng), 0.0};  // coplanar: the reflection trap of Arun's SVD
  std::normal_distribution<double> noise(0, 0.01);
  for (const auto& truth :
       {make_transform3(1, 2, 3, 0.1, -0.2, 2.9), make_transform3(-1, 0, 0.5, 3.0, 0.5, -1.0)}) {
    for (const auto* pts : {&data, &planar}) {
      auto pairs = exact_pairs<3>(*pts, truth);
      const auto t = PointToPointSolver<3, double>{}.solve(pairs);
      REQUIRE(t);
      CHECK(transform_error<3>(*t, truth).first < 1e-9);
      CHECK(transform_error<3>(*t, truth).second < 1e-9);
      for (auto& c : pairs)
        c.model += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      const auto noisy = PointToPointSolver<3, double>{}.solve(pairs);
      REQUIRE(noisy);
      CHECK(noisy->linear().determinant() == Approx(1.0));
      CHECK(transform_error<3>(*noisy, truth).second < 0.01);
    }
  }
}

namespace {

/// Points on axis-aligned faces with their unit normals: a 6 x 4 x 3 m room (or only its floor
/// and one wall, x = 3, facing -x: a planar front that fills the view) and a 1 x 0.7 x 0.8 m
/// box on the floor, sampled uniformly.
struct FacedCloud {
  std::vector<Eigen::Vector3d> points, normals;
};

FacedCloud faces_3d(std::mt19937& rng, double density, bool front_only) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  FacedCloud out;
  const auto face = [&](Eigen::Vector3d lo, Eigen::Vector3d hi, int axis, double sign) {
    Eigen::Vector3d size = hi - lo;
    size[axis] = 1;
    const auto n = static_cast<std::size_t>(density * size.prod());
    for (std::size_t i = 0; i < n; ++i) {
      Eigen::Vector3d p;
      for (int k = 0; k < 3; ++k)
        p[k] = lo[k] + (hi[k] - lo[k]) * u(rng);
      out.points.push_back(p);
      out.normals.push_back(sign * Eigen::Vector3d::Unit(axis));
    }
  };
  face({-3, -2, 0}, {3, 2, 0}, 2, 1);  // floor
  face({3, -2, 0}, {3, 2, 3}, 0, -1);  // the front
  if (!front_only) {
    face({-3, -2, 3}, {3, 2, 3}, 2, -1);
    face({-3, -2, 0}, {-3, 2, 3}, 0, 1);
    face({-3, -2, 0}, {3, -2, 3}, 1, 1);
    face({-3, 2, 0}, {3, 2, 3}, 1, -1);
  }
  // The box: its +y / -y sides and top are what pins the motion along the front.
  face({1.5, 0.3, 0.8}, {2.5, 1.0, 0.8}, 2, 1);
  face({1.5, 0.3, 0}, {2.5, 0.3, 0.8}, 1, -1);
  face({1.5, 1.0, 0}, {2.5, 1.0, 0.8}, 1, 1);
  face({1.5, 0.3, 0}, {1.5, 1.0, 0.8}, 0, -1);
  return out;
}

/// The planar-front scene: a floor, a wall facing the sensor (6 x 3 m) and a box; the model a
/// sparse sample with normals (what a point map keeps), the data a denser, different sample seen
/// through the true transform `truth`.
struct PlanarFrontScene {
  FacedCloud model;
  Transform3d truth;
  std::vector<Eigen::Vector3d> data;
};

PlanarFrontScene planar_front_scene() {
  std::mt19937 rng(5);
  PlanarFrontScene s{
      faces_3d(rng, 300.0, true), make_transform3(0.04, -0.05, 0.01, 0.0, 0.01, 0.05), {}};
  const FacedCloud scene = faces_3d(rng, 600.0, true);
  for (const auto& p : scene.points)
    s.data.push_back(s.truth.inverse(Eigen::Isometry) * p);
  return s;
}

}  // namespace

TEST_CASE("point-to-plane solver: exact on planes, indifferent to sliding within them",
          "[registration]") {
  // Data points on the faces of a room seen through a known transform, each paired with a model
  // point up to 0.2 m away WITHIN its face (what a sparse map gives). Point-to-point is biased
  // by the sliding; point-to-plane (Low 2004) recovers the transform, from the point-to-point
  // start or from a current transform 0.2 m / 0.15 rad off.
  std::mt19937 rng(4);
  const FacedCloud room = faces_3d(rng, 4.0, false);
  std::uniform_real_distribution<double> along(-0.2, 0.2);
  const Transform3d truth = make_transform3(0.3, -0.2, 0.1, 0.05, -0.1, 0.6);
  const Transform3d to_data = truth.inverse(Eigen::Isometry);
  std::vector<Correspondence<3, double>> pairs;
  std::vector<Eigen::Vector3d> normals;
  for (std::size_t i = 0; i < room.points.size(); ++i) {
    const Eigen::Vector3d& n = room.normals[i];
    Eigen::Vector3d slide(along(rng), along(rng), along(rng));
    slide -= n * n.dot(slide);
    const auto index = static_cast<std::uint32_t>(i);
    normals.push_back(i % 7 == 6 ? Eigen::Vector3d::Zero() : n);  // some without a plane
    pairs.push_back({to_data * room.points[i], room.points[i] + slide, 0.0, index, index});
  }
  std::vector<Correspondence<3, double>> planar;
  for (const auto& c : pairs)
    if (!normals[c.model_index].isZero(0)) planar.push_back(c);
  PointToPlaneSolver<3, double> solver;
  solver.model_normals = normals;
  solver.gauss_newton_steps = 10;
  const auto p2p = PointToPointSolver<3, double>{}.solve(planar);
  REQUIRE(p2p);
  const auto from_p2p = solver.solve(planar, at<3>(*p2p));
  REQUIRE(from_p2p);
  CHECK(transform_error<3>(*from_p2p, truth).first < 1e-6);
  CHECK(transform_error<3>(*from_p2p, truth).second < 1e-6);
  const Transform3d current = make_transform3(0.1, 0.0, 0.2, 0.0, 0.0, 0.45);
  const auto from_current = solver.solve(planar, at<3>(current));
  REQUIRE(from_current);
  CHECK(transform_error<3>(*from_current, truth).first < 1e-6);
  CHECK(transform_error<3>(*from_current, truth).second < 1e-6);
  CHECK(transform_error<3>(*p2p, truth).first > 1e-3);
  // The pairs without a normal are left out: the same answer with them.
  const auto mixed = solver.solve(pairs, at<3>(current));
  REQUIRE(mixed);
  CHECK(mixed->isApprox(*from_current, 1e-9));
  // No normals at all: the point-to-point solution; too few pairs: none.
  PointToPlaneSolver<3, double> no_normals;
  const auto same = no_normals.solve(planar, at<3>(current));
  REQUIRE(same);
  CHECK(same->isApprox(*p2p));
  CHECK_FALSE(solver.solve(std::span(planar).first(2), at<3>(current)).has_value());
  // Only the floor: x, y and the yaw are unconstrained. From a start off in all six directions,
  // z, roll and pitch come out right and the damping leaves the rest where it was: the floor
  // points' centroid keeps its x and y.
  std::vector<Correspondence<3, double>> floor;
  for (const auto& c : planar)
    if (normals[c.model_index].z() > 0.5 && c.model.z() < 0.01) floor.push_back(c);
  REQUIRE(floor.size() > 50);
  const Transform3d start = make_transform3(0.2, -0.1, 0.05, 0.03, -0.02, 0.1) * truth;
  const auto on_floor = solver.solve(floor, at<3>(start));
  REQUIRE(on_floor);
  Eigen::Vector3d before = Eigen::Vector3d::Zero(), after = Eigen::Vector3d::Zero();
  for (const auto& c : floor) {
    CHECK(std::abs((*on_floor * c.data).z()) < 1e-6);
    before += start * c.data;
    after += *on_floor * c.data;
  }
  CHECK((after - before).head<2>().norm() / static_cast<double>(floor.size()) < 1e-6);
}

TEST_CASE("point-to-plane ICP does not slide along a planar front that fills the view",
          "[registration]") {
  // A floor, a wall facing the sensor (6 x 3 m) and a box: the model is a sparse sample (what a
  // point map keeps), the data a denser, different sample seen through the true transform. The
  // only features along the wall are the box's sides. Ground truth: the transform of the data.
  const PlanarFrontScene front = planar_front_scene();
  const KdTree<3, double> tree(front.model.points);
  BasicIcp<3, double, PointToPlaneSolver<3, double>, DecayingDistanceRejector<double>> icp;
  icp.solver.model_normals = front.model.normals;
  icp.params.max_iterations = 50;
  icp.rejector<DecayingDistanceRejector<double>>() = {0.3, 0.05, 0.7};
  const auto r = icp.align(tree, front.data, Transform3d::Identity());
  CHECK(r.reason == IcpTermination::converged);
  const auto [et, er] = transform_error<3>(r.transform, front.truth);
  CHECK(et < 0.005);
  CHECK(er < 0.002);
  // Without normals the same ICP is point-to-point and lands farther from the truth.
  icp.solver.model_normals = {};
  const auto p2p = icp.align(tree, front.data, Transform3d::Identity());
  CHECK(transform_error<3>(p2p.transform, front.truth).first > et);
}

TEST_CASE("solvers refuse identical, collinear and too few points", "[registration]") {
  const std::vector<Eigen::Vector2d> same2(10, Eigen::Vector2d(1, 1));
  CHECK_FALSE(
      PointToPointSolver<2, double>{}.solve(exact_pairs<2>(same2, make_transform2(1.0, 0.0, 0.0))));
  const std::vector<Eigen::Vector2d> one2 = {{1, 1}};
  CHECK_FALSE(PointToPointSolver<2, double>{}.solve(exact_pairs<2>(one2, Transform2d::Identity())));
  std::vector<Eigen::Vector3d> line3;
  for (int i = 0; i < 10; ++i)
    line3.emplace_back(i, 2.0 * i, -i);
  CHECK_FALSE(
      PointToPointSolver<3, double>{}.solve(exact_pairs<3>(line3, Transform3d::Identity())));
  const std::vector<Eigen::Vector3d> same3(10, Eigen::Vector3d(1, 2, 3));
  CHECK_FALSE(
      PointToPointSolver<3, double>{}.solve(exact_pairs<3>(same3, Transform3d::Identity())));
}

// ---- rejectors ---------------------------------------------------------------------------------

TEST_CASE("DecayingDistanceRejector decays exponentially to its final distance", "[registration]") {
  DecayingDistanceRejector<double> r{2.0, 0.1, 0.5};
  CHECK(r.distance(0) == Approx(2.0));
  CHECK(r.distance(1) == Approx(1.0));
  CHECK(r.distance(3) == Approx(0.25));
  CHECK(r.distance(4) == Approx(0.125));
  CHECK(r.distance(5) == Approx(0.1));
  CHECK(r.distance(50) == Approx(0.1));
  IcpContext<2, double> ctx{3, Transform2d::Identity(), 0, 0};
  CHECK(r.max_distance_sq(ctx) == Approx(0.0625));
  CHECK_FALSE(r.settled(ctx));
  ctx.iteration = 5;
  CHECK(r.settled(ctx));
  CHECK_THROWS_WITH((DecayingDistanceRejector<double>{0.1, 1.0, 0.5}.validate()),
                    "rangenav: DecayingDistanceRejector: argument 'initial_distance' = "
                    "0.10000000000000001 must be >= final_distance");
  CHECK_THROWS_WITH((DecayingDistanceRejector<double>{1.0, 0.1, 1.5}.validate()),
                    "rangenav: DecayingDistanceRejector: argument 'decay' = 1.5 must be in (0, 1]");
  CHECK_THROWS_WITH((DecayingDistanceRejector<double>{1.0, -0.1, 0.5}.validate()),
                    "rangenav: DecayingDistanceRejector: argument 'final_distance' = "
                    "-0.10000000000000001 must be finite and > 0");
}

TEST_CASE("DecayingDistanceRejector skip_when_converged goes straight to the final distance",
          "[registration]") {
  DecayingDistanceRejector<double> r{2.0, 0.1, 0.5};
  IcpContext<2, double> ctx{2, Transform2d::Identity(), 0, 0};
  ctx.converged_unsettled = 1;  // the estimate stopped moving at iteration 1 (threshold 1.0)
  CHECK(r.distance(ctx) == Approx(0.5));  // off: the schedule
  CHECK_FALSE(r.settled(ctx));
  r.skip_when_converged = true;
  CHECK(r.distance(ctx) == Approx(0.1));  // on: the final distance from the next iteration
  CHECK(r.max_distance_sq(ctx) == Approx(0.01));
  CHECK(r.settled(ctx));
  ctx.iteration = 1;
  CHECK(r.distance(ctx) == Approx(1.0));  // the iteration that converged keeps its threshold
  ctx.converged_unsettled = -1;
  ctx.iteration = 2;
  CHECK(r.distance(ctx) == Approx(0.5));  // no convergence yet: the schedule

  // In ICP: the model is the data moved by a known transform (every point a true pair, 0.5 m
  // apart, the offset a few centimetres), so the first solve lands on the truth. The schedule
  // 2.0 * 0.9^k reaches 0.05 m at k = 36; with the skip, the run ends two iterations later.
  std::vector<Eigen::Vector2d> data;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 6; ++j)
      data.emplace_back(0.5 * i + 0.03 * j, 0.5 * j);
  const Transform2d truth = make_transform2(0.04, -0.03, 0.02);
  std::vector<Eigen::Vector2d> model;
  for (const auto& p : data)
    model.push_back(truth * p);
  const KdTree<2, double> tree(model);
  Icp<2, double, DecayingDistanceRejector<double>> icp;
  icp.params.max_iterations = 100;
  icp.rejector<DecayingDistanceRejector<double>>() = {2.0, 0.05, 0.9};
  const auto scheduled = icp.align(tree, data, Transform2d::Identity());
  icp.rejector<DecayingDistanceRejector<double>>().skip_when_converged = true;
  const auto skipped = icp.align(tree, data, Transform2d::Identity());
  for (const auto* run : {&scheduled, &skipped}) {
    CHECK(run->reason == IcpTermination::converged);
    const auto [et, er] = transform_error<2>(run->transform, truth);
    CHECK(et < 1e-9);
    CHECK(er < 1e-9);
    CHECK(run->inlier_count == data.size());
  }
  CHECK(scheduled.iterations >= 36);
  CHECK(skipped.iterations <= 3);
}

TEST_CASE("UniqueModelPointRejector keeps the closest pair per model point", "[registration]") {
  std::vector<Correspondence<2, double>> pairs = {
      {{0, 0}, {0, 0}, 0.5, 0, 7}, {{0, 0}, {0, 0}, 0.1, 1, 7}, {{0, 0}, {0, 0}, 0.3, 2, 3},
      {{0, 0}, {0, 0}, 0.2, 3, 7}, {{0, 0}, {0, 0}, 0.4, 4, 5}, {{0, 0}, {0, 0}, 0.05, 5, 3}};
  UniqueModelPointRejector{}.reject(IcpContext<2, double>{}, pairs);
  REQUIRE(pairs.size() == 3);
  std::sort(pairs.begin(), pairs.end(),
            [](auto& a, auto& b) { return a.data_index < b.data_index; });
  CHECK(pairs[0].data_index == 1);  // model 7
  CHECK(pairs[1].data_index == 4);  // model 5
  CHECK(pairs[2].data_index == 5);  // model 3
}

TEST_CASE("TrimmedRejector keeps the best fraction", "[registration]") {
  std::vector<Correspondence<3, double>> pairs;
  for (std::uint32_t i = 0; i < 10; ++i)
    pairs.push_back({Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), double(9 - i), i, i});
  TrimmedRejector<double>{0.7}.reject(IcpContext<3, double>{}, pairs);
  REQUIRE(pairs.size() == 7);
  for (const auto& c : pairs)
    CHECK(c.distance_sq < 7.0);
  CHECK_THROWS_WITH(TrimmedRejector<double>{0.0}.validate(),
                    "rangenav: TrimmedRejector: argument 'overlap' = 0 must be in (0, 1]");
}

TEST_CASE("Frustum: 2D wedge and 3D pyramid with near and far", "[registration]") {
  Frustum<2, double> wedge;
  wedge.near = 0.5;
  wedge.far = 4.0;
  wedge.angle_min = -0.5;
  wedge.angle_max = 0.5;
  CHECK(wedge.contains({2, 0}));
  CHECK_FALSE(wedge.contains({0.3, 0}));  // nearer than near
  CHECK_FALSE(wedge.contains({4.5, 0}));  // beyond far
  CHECK_FALSE(wedge.contains({1, 1}));    // bearing 0.785 > 0.5
  CHECK(wedge.contains({2, 2 * std::tan(0.45)}));
  wedge.pose = make_transform2(10.0, 0.0, std::numbers::pi / 2);  // sensor at (10, 0) looking +y
  CHECK(wedge.contains({10, 2}));
  CHECK_FALSE(wedge.contains({12, 0}));

  Frustum<3, double> pyramid;
  pyramid.near = 0.3;
  pyramid.far = 5.0;
  pyramid.horizontal_fov = std::numbers::pi / 2;  // |y| <= x
  pyramid.vertical_fov = std::numbers::pi / 3;    // |z| <= x tan(30°)
  CHECK(pyramid.contains({2, 1.9, 1.1}));
  CHECK_FALSE(pyramid.contains({2, 2.1, 0}));
  CHECK_FALSE(pyramid.contains({2, 0, 1.2}));
  CHECK_FALSE(pyramid.contains({0.2, 0, 0}));
  CHECK_FALSE(pyramid.contains({5.1, 0, 0}));
  CHECK_FALSE(pyramid.contains({-2, 0, 0}));
  pyramid.far = 0.2;
  CHECK_THROWS_WITH(pyramid.validate(),
                    "rangenav: Frustum: argument 'far' = 0.20000000000000001 must be > near");
}

// ---- ICP ---------------------------------------------------------------------------------------

TEST_CASE("ICP recovers known 2D transforms forward and inverse", "[registration]") {
  const auto model = test::room_2d();
  const KdTree<2, double> tree(model);
  for (const auto& truth : {make_transform2(0.3, -0.2, 0.15), make_transform2(-0.4, 0.25, -0.2),
                            make_transform2(0.0, 0.0, 0.0)}) {
    for (const auto& t : {truth, Transform2d(truth.inverse(Eigen::Isometry))}) {
      // data = T^-1 * model, so aligning data onto model must give T.
      const auto data = test::transformed<2>(model, t.inverse(Eigen::Isometry));
      PaperIcp<2> icp;
      icp.params.translation_epsilon = icp.params.rotation_epsilon = 1e-9;
      const auto result = icp.align(tree, data);
      INFO(to_string(result.reason) << " after " << result.iterations);
      CHECK(result.converged);
      CHECK(result.reason == IcpTermination::converged);
      const auto [et, er] = transform_error<2>(result.transform, t);
      CHECK(et < 1e-6);
      CHECK(er < 1e-6);
      CHECK(result.rmse < 1e-6);
      CHECK(result.fitness == Approx(1.0));
      CHECK(result.inlier_count == model.size());  // random samples: no two coincide
      REQUIRE(result.smallest_eigenvalue);
      CHECK(*result.smallest_eigenvalue > icp.params.degeneracy_threshold);
    }
  }
}

TEST_CASE("ICP recovers known 3D transforms forward and inverse", "[registration]") {
  std::mt19937 rng(3);
  const auto model = test::room_3d(rng);
  const KdTree<3, double> tree(model);
  const auto truth = make_transform3(0.2, -0.15, 0.1, 0.05, -0.04, 0.12);
  for (const auto& t : {truth, Transform3d(truth.inverse(Eigen::Isometry))}) {
    const auto data = test::transformed<3>(model, t.inverse(Eigen::Isometry));
    PaperIcp<3> icp;
    icp.params.translation_epsilon = icp.params.rotation_epsilon = 1e-7;
    icp.params.max_iterations = 100;
    const auto result = icp.align(tree, data);
    INFO(to_string(result.reason) << " after " << result.iterations);
    CHECK(result.converged);
    const auto [et, er] = transform_error<3>(result.transform, t);
    CHECK(et < 1e-6);
    CHECK(er < 1e-6);
    CHECK(result.fitness == Approx(1.0));
  }
}

TEST_CASE("ICP with noise and outliers stays accurate", "[registration]") {
  std::mt19937 rng(4);
  const auto model = test::room_2d(0.02);
  const KdTree<2, double> tree(model);
  const auto truth = make_transform2(0.25, 0.1, 0.1);
  auto data = test::transformed<2>(test::room_2d(0.03), truth.inverse(Eigen::Isometry));
  test::add_noise<2>(data, 0.01, rng);
  std::uniform_real_distribution<double> u(-3, 5);
  const std::size_t inliers = data.size();
  for (int i = 0; i < 60; ++i)
    data.emplace_back(u(rng), u(rng));  // clutter
  PaperIcp<2> icp;
  icp.rejector<DecayingDistanceRejector<double>>().final_distance = 0.05;
  const auto result = icp.align(tree, data);
  CHECK(result.converged);
  const auto [et, er] = transform_error<2>(result.transform, truth);
  CHECK(et < 0.01);
  CHECK(er < 0.005);
  CHECK(result.rmse < 0.03);
  CHECK(result.inlier_count <= inliers + 10);

  std::mt19937 rng3(5);
  const auto model3 = test::room_3d(rng3, 600);
  const KdTree<3, double> tree3(model3);
  const auto truth3 = make_transform3(0.1, 0.2, -0.05, 0.03, 0.02, -0.1);
  auto data3 = test::transformed<3>(test::room_3d(rng3, 600), truth3.inverse(Eigen::Isometry));
  test::add_noise<3>(data3, 0.005, rng3);
  std::uniform_real_distribution<double> u3(-3, 3);
  for (int i = 0; i < 100; ++i)
    data3.emplace_back(u3(rng3), u3(rng3), u3(rng3) * 0.5 + 1.5);
  Icp<3, double, DecayingDistanceRejector<double>, TrimmedRejector<double>> icp3;
  icp3.rejector<TrimmedRejector<double>>().overlap = 0.85;
  const auto r3 = icp3.align(tree3, data3);
  CHECK(r3.converged);
  CHECK(transform_error<3>(r3.transform, truth3).first < 0.02);
  CHECK(transform_error<3>(r3.transform, truth3).second < 0.01);
}

TEST_CASE("ICP aligns a partially overlapping scan (unique pairs + decaying threshold)",
          "[registration]") {
  const auto model = test::room_2d();
  // The data sees only the part of the room with x > 0.5 (half of it is new to the model).
  std::vector<Eigen::Vector2d> part;
  for (const auto& p : model)
    if (p.x() > 0.5) part.push_back(p);
  std::vector<Eigen::Vector2d> model_part;
  for (const auto& p : model)
    if (p.x() < 3.0) model_part.push_back(p);
  const KdTree<2, double> tree(model_part);
  const auto truth = make_transform2(0.2, -0.1, 0.08);
  const auto data = test::transformed<2>(part, truth.inverse(Eigen::Isometry));
  PaperIcp<2> icp;
  icp.rejector<DecayingDistanceRejector<double>>().final_distance = 0.05;
  const auto result = icp.align(tree, data);
  CHECK(result.converged);
  const auto [et, er] = transform_error<2>(result.transform, truth);
  CHECK(et < 1e-3);
  CHECK(er < 1e-3);
  CHECK(result.fitness < 0.9);  // the non-overlapping part found no partner
  CHECK(result.fitness > 0.3);
  // Without rejection, the non-overlapping points drag the estimate away.
  Icp<2> plain;
  const auto biased = plain.align(tree, data);
  CHECK(transform_error<2>(biased.transform, truth).first > 0.02);
}

TEST_CASE("FrustumRejector culls data outside the model frustum every iteration",
          "[registration]") {
  // Model sensor at the origin looking along +x with a 90° wedge up to 4 m.
  const auto room = test::room_2d();
  Frustum<2, double> fov;
  fov.far = 4.0;
  fov.angle_min = -std::numbers::pi / 4;
  fov.angle_max = std::numbers::pi / 4;
  std::vector<Eigen::Vector2d> model;
  for (const auto& p : room)
    if (fov.contains(p)) model.push_back(p);
  const KdTree<2, double> tree(model);
  const auto truth = make_transform2(0.15, 0.1, 0.05);
  const auto data = test::transformed<2>(room, truth.inverse(Eigen::Isometry));
  Icp<2, double, FrustumRejector<2, double>, MaxDistanceRejector<double>> icp;
  icp.rejector<FrustumRejector<2, double>>().frustum = fov;
  icp.rejector<MaxDistanceRejector<double>>().max_distance = 0.5;
  icp.params.check_degeneracy = false;
  const auto result = icp.align(tree, data);
  CHECK(result.converged);
  CHECK(transform_error<2>(result.transform, truth).first < 1e-4);
  // Every kept pair's data point lies inside the frustum under the final transform.
  for (const auto& c : icp.correspondences())
    CHECK(fov.contains(result.transform * c.data));
  CHECK(result.inlier_count < data.size() / 2);

  // Mode 2 (paper 004): pairs whose model point is outside the data sensor's frustum are dropped.
  FrustumRejector<2, double> r{fov, FrustumRejector<2, double>::Mode::model_in_data_frustum};
  std::vector<Correspondence<2, double>> pairs = {
      {{0, 0}, {2, 0}, 0, 0, 0}, {{0, 0}, {-2, 0}, 0, 1, 1}, {{0, 0}, {12, 0}, 0, 2, 2}};
  IcpContext<2, double> ctx{0, make_transform2(10.0, 0.0, 0.0), 0, 0};  // data sensor at x = 10
  r.reject(ctx, pairs);
  REQUIRE(pairs.size() == 1);
  CHECK(pairs[0].model_index == 2);
}

TEST_CASE("FrustumRejector's 3D test is Frustum::contains", "[registration]") {
  Frustum<3, double> f;
  f.near = 0.3;
  f.far = 6.0;
  f.horizontal_fov = 57.0 * std::numbers::pi / 180;
  f.vertical_fov = 43.0 * std::numbers::pi / 180;
  f.pose = make_transform3(0.5, -0.2, 0.3, 0.1, -0.2, 0.4);
  FrustumRejector<3, double> in_model(f);  // data_in_model_frustum: admits()
  in_model.begin(0, 0);
  FrustumRejector<3, double> in_data(f, FrustumRejector<3, double>::Mode::model_in_data_frustum);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-7.0, 7.0);
  std::vector<Correspondence<3, double>> pairs;
  std::size_t inside = 0;
  for (std::uint32_t i = 0; i < 20000; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng) / 3);
    const bool expected = f.contains(p);
    inside += expected ? 1 : 0;
    CHECK(in_model.admits(IcpContext<3, double>{}, p) == expected);
    pairs.push_back({p, p, 0, i, i});
  }
  REQUIRE(inside > 500);
  // model_in_data_frustum keeps exactly the pairs whose model point is inside (identity
  // estimate: the data sensor's frustum is f itself).
  IcpContext<3, double> ctx{0, Transform3d::Identity(), 0, 0};
  in_data.reject(ctx, pairs);
  CHECK(pairs.size() == inside);
  for (const auto& c : pairs)
    CHECK(f.contains(c.model));
}

TEST_CASE("ICP's neighbour reuse forms the pairs of a search in every iteration",
          "[registration]") {
  // reuse_neighbors skips the search of a data point whose nearest model point is provably
  // unchanged; the reference searches every data point every iteration. Same pairs, so the
  // same transform, bit for bit, with fewer searches.
  const auto same = [](const auto& fast, const auto& reference) {
    CHECK(fast.transform.matrix() == reference.transform.matrix());
    CHECK(fast.iterations == reference.iterations);
    CHECK(fast.matched_count == reference.matched_count);
    CHECK(fast.inlier_count == reference.inlier_count);
    CHECK(fast.reason == reference.reason);
    // At most one search per data point and iteration (fewer when the frustum culls).
    CHECK(reference.neighbor_searches <=
          static_cast<std::size_t>(reference.iterations) * reference.data_count);
    CHECK(fast.neighbor_searches < reference.neighbor_searches * 3 / 4);
  };
  SECTION("2D, decaying threshold and unique pairs") {
    const auto room = test::room_2d();
    const KdTree<2, double> tree(room);
    for (const auto& truth :
         {make_transform2(0.2, -0.1, 0.08), make_transform2(-0.3, 0.2, -0.12)}) {
      const auto data = test::transformed<2>(room, truth.inverse(Eigen::Isometry));
      PaperIcp<2> fast, reference;
      reference.params.reuse_neighbors = false;
      const auto a = fast.align(tree, data), b = reference.align(tree, data);
      same(a, b);
      CHECK(transform_error<2>(a.transform, truth).first < 1e-3);
    }
  }
  SECTION("3D, frustum culling of the data and noise, double and float") {
    std::mt19937 rng(9);
    const auto room = test::room_3d(rng, 1500);
    std::normal_distribution<double> noise(0.0, 0.005);
    const auto truth = make_transform3(0.12, -0.08, 0.05, 0.03, -0.02, 0.1);
    std::vector<Eigen::Vector3d> data = test::transformed<3>(room, truth.inverse(Eigen::Isometry));
    for (auto& p : data)
      p += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    Frustum<3, double> f;
    f.far = 3.5;
    f.horizontal_fov = 2.0;
    f.vertical_fov = 2.0;
    f.pose = make_transform3(-1.0, 0.0, 1.5, 0, 0, 0.3);
    using Culled = Icp<3, double, DecayingDistanceRejector<double>, FrustumRejector<3, double>>;
    Culled fast, reference;
    for (Culled* icp : {&fast, &reference}) {
      icp->rejector<DecayingDistanceRejector<double>>() = {0.5, 0.05, 0.7};
      icp->rejector<FrustumRejector<3, double>>().frustum = f;
    }
    reference.params.reuse_neighbors = false;
    const KdTree<3, double> tree(room);
    const auto a = fast.align(tree, data), b = reference.align(tree, data);
    same(a, b);
    CHECK(transform_error<3>(a.transform, truth).first < 0.01);

    std::vector<Eigen::Vector3f> room_f, data_f;
    for (const auto& p : room)
      room_f.push_back(p.cast<float>());
    for (const auto& p : data)
      data_f.push_back(p.cast<float>());
    const KdTree<3, float> tree_f(room_f);
    PaperIcp<3, float> fast_f, reference_f;
    reference_f.params.reuse_neighbors = false;
    same(fast_f.align(tree_f, data_f), reference_f.align(tree_f, data_f));
  }
  SECTION("3D GICP with the model's neighbour lists, 1 and 2 threads") {
    // BasicIcp::model_neighbors proves a data point's nearest model point among the neighbours
    // of its last one; the reference searches the tree every time.
    std::mt19937 rng(4);
    const auto room = test::room_3d(rng, 1500);
    const auto truth = make_transform3(0.15, -0.1, 0.05, 0.04, -0.03, 0.12);
    const auto data = test::transformed<3>(room, truth.inverse(Eigen::Isometry));
    const KdTree<3, double> tree(room), data_tree(data);
    const NeighborLists<double> lists = neighbor_lists(tree, 10);
    const auto model_cov = estimate_covariances(tree, lists);
    const auto data_cov = estimate_covariances(data_tree, 10);
    for (const int threads : {1, 2}) {
      using Gicp = BasicIcp<3, double, GicpSolver<3, double>, MaxDistanceRejector<double>>;
      Gicp fast, reference;
      for (Gicp* icp : {&fast, &reference}) {
        icp->solver.model_covariances = model_cov;
        icp->solver.data_covariances = data_cov;
        icp->params.reuse_neighbors = false;
        icp->params.num_threads = threads;
        icp->params.translation_epsilon = icp->params.rotation_epsilon = 1e-9;
        icp->rejector<MaxDistanceRejector<double>>().max_distance = 0.5;
      }
      fast.model_neighbors = &lists;
      const auto a = fast.align(tree, data_tree.points()),
                 b = reference.align(tree, data_tree.points());
      same(a, b);
      CHECK(transform_error<3>(a.transform, truth).first < 1e-3);
    }
    Icp<3, double> wrong;
    const NeighborLists<double> other = neighbor_lists(data_tree, 10);
    wrong.model_neighbors = &other;
    const KdTree<3, double> small(std::vector<Eigen::Vector3d>(room.begin(), room.begin() + 100));
    CHECK_THROWS_AS(wrong.align(small, data), invalid_argument);
  }
}

TEST_CASE("ICP that enters a limit cycle ends on the state its iteration budget would",
          "[registration]") {
  // A sparse, noisy model with clutter and a sparse scan, point-to-line: in a few of many
  // random alignments the pairs end up flipping between sets, the transform between states
  // farther apart than the epsilons. IcpParams::skip_cycles jumps to the state the budget ends
  // on; the reference iterates to it. Same transform, pairs and reason bit for bit.
  std::mt19937 model_rng(99);
  std::normal_distribution<double> model_noise(0.0, 0.03);
  std::uniform_real_distribution<double> ux(-3, 5), uy(-2, 3), unit(-1, 1);
  auto model = test::room_2d(0.15);
  for (auto& p : model)
    p += Eigen::Vector2d(model_noise(model_rng), model_noise(model_rng));
  for (int i = 0; i < 60; ++i)
    model.emplace_back(ux(model_rng), uy(model_rng));
  const KdTree<2, double> tree(model);
  const auto normals = estimate_normals(tree, 5);
  using LineIcp =
      BasicIcp<2, double, PointToPlaneSolver<2, double>, DecayingDistanceRejector<double>>;
  int cycled = 0;
  for (int seed = 0; seed < 2000 && cycled < 2; ++seed) {
    std::mt19937 rng(static_cast<unsigned>(seed));
    std::normal_distribution<double> noise(0.0, 0.01);
    const auto truth = make_transform2(0.2 * unit(rng), 0.2 * unit(rng), 0.05 * unit(rng));
    auto data = test::transformed<2>(test::room_2d(0.1), truth.inverse(Eigen::Isometry));
    for (auto& p : data)
      p += Eigen::Vector2d(noise(rng), noise(rng));
    for (int i = 0; i < 60; ++i)
      data.emplace_back(ux(rng), uy(rng));
    LineIcp fast, reference;
    for (LineIcp* icp : {&fast, &reference}) {
      icp->solver.model_normals = normals;
      icp->rejector<DecayingDistanceRejector<double>>() = {0.5, 0.2, 0.8};
    }
    reference.params.skip_cycles = false;
    const auto a = fast.align(tree, data);
    const std::vector<Correspondence<2, double>> pairs(fast.correspondences().begin(),
                                                       fast.correspondences().end());
    const auto b = reference.align(tree, data);
    CHECK(b.cycle_period == 0);
    if (a.cycle_period == 0) continue;
    ++cycled;
    CHECK(a.transform.matrix() == b.transform.matrix());
    CHECK(a.iterations == b.iterations);
    CHECK(a.reason == IcpTermination::max_iterations);
    CHECK(b.reason == IcpTermination::max_iterations);
    CHECK(a.matched_count == b.matched_count);
    CHECK(a.rmse == b.rmse);
    CHECK(a.neighbor_searches <= b.neighbor_searches);
    REQUIRE(pairs.size() == reference.correspondences().size());
    for (std::size_t i = 0; i < pairs.size(); ++i)
      CHECK(pairs[i].model_index == reference.correspondences()[i].model_index);
    CHECK(transform_error<2>(a.transform, truth).first < 0.05);
  }
  CHECK(cycled == 2);
}

TEST_CASE("coarse-to-fine ICP: a data subset first, then all points, to the same pose",
          "[registration]") {
  // The scene of the planar-front test (floor, wall, box; sparse model with normals, denser
  // data through a known transform). IcpParams::coarse_points iterates on every k-th data point
  // (k = n / coarse_points) until that subset converges, then on all points: the result must be the
  // truth's as closely as the all-points ICP's (both converge on the same pairs' minimum), with
  // fewer searches.
  const PlanarFrontScene front = planar_front_scene();
  const KdTree<3, double> tree(front.model.points);
  using PlaneIcp =
      BasicIcp<3, double, PointToPlaneSolver<3, double>, DecayingDistanceRejector<double>>;
  const std::size_t n = front.data.size();
  const auto make = [&](std::size_t stride, bool reuse) {
    PlaneIcp icp;
    icp.solver.model_normals = front.model.normals;
    icp.params.max_iterations = 50;
    icp.params.coarse_points = stride > 1 ? n / stride : 0;  // every stride-th point
    icp.params.reuse_neighbors = reuse;
    icp.params.translation_epsilon = icp.params.rotation_epsilon = 1e-7;
    icp.rejector<DecayingDistanceRejector<double>>() = {0.3, 0.05, 0.7};
    return icp;
  };
  auto all = make(1, false);
  const auto reference = all.align(tree, front.data, Transform3d::Identity());
  REQUIRE(reference.reason == IcpTermination::converged);
  CHECK(reference.coarse_iterations == 0);
  const auto [et_ref, er_ref] = transform_error<3>(reference.transform, front.truth);
  CHECK(et_ref < 0.005);
  for (const std::size_t stride : {2u, 4u, 8u}) {
    INFO("stride " << stride);
    auto coarse = make(stride, false);
    const auto r = coarse.align(tree, front.data, Transform3d::Identity());
    REQUIRE(r.reason == IcpTermination::converged);
    // The subset ran (and converged: the decaying threshold settles after 4 iterations), the
    // last iterations ran on all points.
    CHECK(r.coarse_iterations >= 5);
    CHECK(r.iterations > r.coarse_iterations);
    CHECK(r.matched_count > n * 9 / 10);
    // Without neighbour reuse every visited data point is one search: the coarse iterations
    // visit ceil(n / stride) points, the others n. Fails if the subset is ignored.
    const std::size_t k = n / (n / stride);  // the subset's step
    const std::size_t subset = (n + k - 1) / k;
    CHECK(r.neighbor_searches ==
          static_cast<std::size_t>(r.coarse_iterations) * subset +
              static_cast<std::size_t>(r.iterations - r.coarse_iterations) * n);
    // Same pose as the all-points ICP: both stop at the minimum of the full set's pairs.
    const auto [et, er] = transform_error<3>(r.transform, front.truth);
    CHECK(et < 0.005);
    CHECK(er < 0.002);
    const auto [dt, dr] = transform_error<3>(r.transform, reference.transform);
    CHECK(dt < 1e-4);
    CHECK(dr < 1e-4);
    // With reuse: the same pose again, in fewer searches than the all-points ICP with reuse.
    auto coarse_reuse = make(stride, true);
    auto all_reuse = make(1, true);
    const auto a = coarse_reuse.align(tree, front.data, Transform3d::Identity());
    const auto b = all_reuse.align(tree, front.data, Transform3d::Identity());
    CHECK(a.transform.matrix() == r.transform.matrix());
    CHECK(a.neighbor_searches <= b.neighbor_searches);
  }
  SECTION("a subset with fewer pairs than the solver needs falls back to all points") {
    const std::vector<Eigen::Vector3d> few(front.data.begin(), front.data.begin() + 5);
    Icp<3> icp;  // point-to-point: 3 pairs at least; every 5th of 5 points is 1
    icp.params.coarse_points = 1;
    const auto r = icp.align(tree, few, Transform3d::Identity());
    CHECK(r.coarse_iterations == 0);
    CHECK(r.reason != IcpTermination::too_few_pairs);
    CHECK(r.matched_count == 5);
  }
  SECTION("too few data points for a subset of coarse_points: all points throughout") {
    auto coarse = make(1, false);
    coarse.params.coarse_points = n / 2 + 1;
    const auto r = coarse.align(tree, front.data, Transform3d::Identity());
    CHECK(r.coarse_iterations == 0);
    CHECK(r.transform.matrix() == reference.transform.matrix());
  }
  SECTION("the last iteration of the budget runs on all points") {
    auto coarse = make(4, false);
    coarse.params.max_iterations = 3;
    const auto r = coarse.align(tree, front.data, Transform3d::Identity());
    CHECK(r.iterations == 3);
    CHECK(r.coarse_iterations == 2);
    const std::size_t k = n / (n / 4);
    CHECK(r.neighbor_searches == 2 * ((n + k - 1) / k) + n);
  }
}

TEST_CASE("ICP reports a featureless corridor as degenerate", "[registration]") {
  const auto model = test::corridor_2d();
  const KdTree<2, double> tree(model);
  const auto data = test::transformed<2>(model, make_transform2(-0.3, 0.05, 0.02));
  PaperIcp<2> icp;
  const auto result = icp.align(tree, data);
  CHECK_FALSE(result.converged);
  CHECK(result.reason == IcpTermination::degenerate);
  REQUIRE(result.smallest_eigenvalue);
  CHECK(*result.smallest_eigenvalue < 1e-3);
  REQUIRE(result.weakest_direction);
  CHECK(std::abs((*result.weakest_direction)(0)) > 0.9);  // along the corridor (x)
  CHECK((std::isinf(*result.condition_number) || *result.condition_number > 100.0));
  CHECK(result.transform.matrix().allFinite());
  // The lateral offset and the heading are still recovered.
  CHECK(std::abs(result.transform.translation().y() + 0.05 * 1) < 0.02);
}

TEST_CASE("GICP's degeneracy check takes the normals of its model covariances", "[registration]") {
  SECTION("a featureless 2D corridor is degenerate along its axis") {
    const auto model = test::corridor_2d();
    const KdTree<2, double> tree(model);
    const auto data = test::transformed<2>(model, make_transform2(-0.3, 0.05, 0.02));
    const KdTree<2, double> data_tree(data);
    const auto model_cov = estimate_covariances(tree, 10);
    const auto data_cov = estimate_covariances(data_tree, 10);
    BasicIcp<2, double, GicpSolver<2, double>, MaxDistanceRejector<double>> icp;
    icp.solver.model_covariances = model_cov;
    icp.solver.data_covariances = data_cov;
    const auto result = icp.align(tree, data_tree.points());
    CHECK(result.reason == IcpTermination::degenerate);
    REQUIRE(result.smallest_eigenvalue);
    CHECK(*result.smallest_eigenvalue < 1e-3);
    REQUIRE(result.weakest_direction);
    CHECK(std::abs((*result.weakest_direction)(0)) > 0.9);  // along the corridor (x)
  }
  SECTION("3D: the normals are the covariances', not those of a new neighbour search") {
    // A well-constrained room whose model covariances all claim a floor (normal z): the check
    // sees only z, the tilts about x and y, and reports the rest free.
    std::mt19937 rng(4);
    const auto room = test::room_3d(rng, 1500);
    const KdTree<3, double> tree(room);
    const Eigen::Matrix3d floor =
        Eigen::Matrix3d::Identity() -
        0.999 * Eigen::Vector3d::UnitZ() * Eigen::Vector3d::UnitZ().transpose();
    const std::vector<Eigen::Matrix3d> floors(room.size(), floor);
    BasicIcp<3, double, GicpSolver<3, double>, MaxDistanceRejector<double>> gicp;
    gicp.solver.model_covariances = floors;
    gicp.solver.data_covariances = floors;
    const auto r = gicp.align(tree, room);
    CHECK(r.reason == IcpTermination::degenerate);
    REQUIRE(r.weakest_direction);
    CHECK(std::abs((*r.weakest_direction)(2)) < 1e-6);  // z translation is constrained
    Icp<3, double, MaxDistanceRejector<double>> point;  // the room's own normals
    CHECK(point.align(tree, room).reason != IcpTermination::degenerate);
  }
  SECTION("3D: the same eigenvalues as the normals of k model neighbours") {
    // Noise-free data: both ICPs end at the truth with the same pairs, and the covariances were
    // estimated from the same 10 neighbours the check would search.
    std::mt19937 rng(4);
    const auto room = test::room_3d(rng, 1500);
    const auto truth = make_transform3(0.1, -0.05, 0.03, 0.02, -0.01, 0.05);
    const auto data = test::transformed<3>(room, truth.inverse(Eigen::Isometry));
    const KdTree<3, double> tree(room), data_tree(data);
    BasicIcp<3, double, GicpSolver<3, double>, MaxDistanceRejector<double>> gicp;
    const auto model_cov = estimate_covariances(tree, 10);
    const auto data_cov = estimate_covariances(data_tree, 10);
    gicp.solver.model_covariances = model_cov;
    gicp.solver.data_covariances = data_cov;
    Icp<3, double, MaxDistanceRejector<double>> point;
    for (auto* p : {&gicp.params, &point.params})
      p->translation_epsilon = p->rotation_epsilon = 1e-10;
    const auto a = gicp.align(tree, data_tree.points());
    const auto b = point.align(tree, data_tree.points());
    REQUIRE(transform_error<3>(a.transform, truth).first < 1e-6);
    REQUIRE(transform_error<3>(b.transform, truth).first < 1e-6);
    REQUIRE(a.matched_count == b.matched_count);
    REQUIRE(a.smallest_eigenvalue);
    REQUIRE(b.smallest_eigenvalue);
    CHECK(a.converged);
    CHECK(*a.smallest_eigenvalue > 0.01);
    CHECK(*a.smallest_eigenvalue == Approx(*b.smallest_eigenvalue).epsilon(1e-6));
    CHECK(*a.condition_number == Approx(*b.condition_number).epsilon(1e-6));
  }
}

TEST_CASE("ICP answers bad input clearly, never with NaN", "[registration]") {
  const auto model = test::room_2d();
  const KdTree<2, double> tree(model);
  PaperIcp<2> icp;
  const double nan = std::numeric_limits<double>::quiet_NaN();

  CHECK_THROWS_WITH(icp.align(tree, std::vector<Eigen::Vector2d>{}),
                    "rangenav: Icp::align: argument 'data' is empty (0 points)");
  CHECK_THROWS_WITH(icp.align(KdTree<2, double>(std::vector<Eigen::Vector2d>{}), model),
                    "rangenav: Icp::align: argument 'model' is empty (0 points)");
  Transform2d bad = Transform2d::Identity();
  bad.translation().x() = nan;
  CHECK_THROWS_WITH(icp.align(tree, model, bad),
                    "rangenav: Icp::align: argument 'initial_guess' is not finite");
  Transform2d scaled = Transform2d::Identity();
  scaled.linear() *= 2.0;
  CHECK_THROWS_WITH(icp.align(tree, model, scaled),
                    "rangenav: Icp::align: argument 'initial_guess' is not a rigid transform");
  icp.params.max_iterations = 0;
  CHECK_THROWS_WITH(icp.align(tree, model),
                    "rangenav: IcpParams: argument 'max_iterations' = 0 must be >= 1");
  icp.params.max_iterations = 50;

  // All-NaN data: a result saying why, with the initial guess.
  const std::vector<Eigen::Vector2d> all_nan(100, Eigen::Vector2d(nan, nan));
  const auto guess = make_transform2(1.0, 2.0, 0.5);
  auto r = icp.align(tree, all_nan, guess);
  CHECK(r.reason == IcpTermination::too_few_pairs);
  CHECK_FALSE(r.converged);
  CHECK(r.data_count == 0);
  CHECK(r.transform.isApprox(guess));
  CHECK(r.rmse == 0.0);
  CHECK(r.fitness == 0.0);

  // One point: fewer than the solver needs.
  r = icp.align(tree, std::vector<Eigen::Vector2d>{{0.0, -2.0}});
  CHECK(r.reason == IcpTermination::too_few_pairs);

  // Identical points: the rotation is undetermined (without the unique-pair rejector, which would
  // leave a single pair: too few).
  r = Icp<2>{}.align(tree, std::vector<Eigen::Vector2d>(50, Eigen::Vector2d(0.0, -2.0)));
  CHECK(r.reason == IcpTermination::degenerate);
  CHECK(r.transform.matrix().allFinite());

  // No overlap at all: too few pairs.
  r = icp.align(tree, test::transformed<2>(model, make_transform2(100.0, 0.0, 0.0)));
  CHECK(r.reason == IcpTermination::too_few_pairs);
  CHECK(r.transform.matrix().allFinite());

  // 3D identical points and NaN guess.
  const KdTree<3, double> tree3(
      std::vector<Eigen::Vector3d>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}});
  PaperIcp<3> icp3;
  const auto r3 = Icp<3>{}.align(tree3, std::vector<Eigen::Vector3d>(10, Eigen::Vector3d(0, 0, 0)));
  CHECK(r3.reason == IcpTermination::degenerate);
  Transform3d nan3 = Transform3d::Identity();
  nan3.linear()(0, 0) = nan;
  CHECK_THROWS_WITH(icp3.align(tree3, tree3.points(), nan3),
                    "rangenav: Icp::align: argument 'initial_guess' is not finite");
  icp3.rejector<DecayingDistanceRejector<double>>().decay = 0;
  CHECK_THROWS_WITH(icp3.align(tree3, tree3.points()),
                    "rangenav: DecayingDistanceRejector: argument 'decay' = 0 must be in (0, 1]");
}

TEST_CASE("ICP in float gives the same answer", "[registration]") {
  const auto model = test::room_2d();
  std::vector<Eigen::Vector2f> model_f;
  for (const auto& p : model)
    model_f.push_back(p.cast<float>());
  const KdTree<2, float> tree(model_f);
  const auto truth = make_transform2(0.2f, -0.1f, 0.1f);
  std::vector<Eigen::Vector2f> data;
  for (const auto& p : model_f)
    data.push_back(truth.inverse(Eigen::Isometry) * p);
  PaperIcp<2, float> icp;
  icp.params.translation_epsilon = 1e-5f;
  const auto r = icp.align(tree, data);
  CHECK(r.converged);
  const Transform2f e = r.transform.inverse(Eigen::Isometry) * truth;
  CHECK(e.translation().norm() < 1e-3f);
}

TEST_CASE("ICP on libpointmatcher's 2D box scans", "[registration][data]") {
  const auto one = test::data_file_or_skip("libpointmatcher/2D_oneBox.csv");
  const auto two = test::data_file_or_skip("libpointmatcher/2D_twoBoxes.csv");
  if (one.empty() || two.empty()) return;
  const auto a = read_csv_2d(one), b = read_csv_2d(two);
  REQUIRE(a.size() == 361);
  REQUIRE(b.size() == 361);
  const KdTree<2, double> tree_a(a), tree_b(b);
  // A known transform of a real scan is recovered exactly.
  const auto truth = make_transform2(0.1, 0.05, 0.05);
  PaperIcp<2> icp;
  icp.rejector<DecayingDistanceRejector<double>>().final_distance = 0.05;
  const auto r = icp.align(tree_a, test::transformed<2>(a, truth.inverse(Eigen::Isometry)));
  // (a copy of one scan has the same angular sampling: aliasing limits point-to-point ICP)
  CHECK(transform_error<2>(r.transform, truth).first < 0.01);
  CHECK(transform_error<2>(r.transform, truth).second < 0.01);
  // The two scans of the tutorial: aligning one onto the other and back gives inverse transforms
  // and a tight fit on the common structure.
  const auto ab = icp.align(tree_a, b);
  const auto ba = icp.align(tree_b, a);
  INFO(ab.transform.matrix() << "\nrmse " << ab.rmse << " fitness " << ab.fitness);
  CHECK(ab.rmse < 0.02);
  CHECK(ab.fitness > 0.5);
  const auto [et, er] =
      transform_error<2>(ab.transform, Transform2d(ba.transform.inverse(Eigen::Isometry)));
  CHECK(et < 0.02);
  CHECK(er < 0.01);
}

TEST_CASE("ICP on the KITTI pair of small_gicp against its ground truth", "[registration][data]") {
  const auto pair = test::kitti_pair_or_skip();
  if (!pair) return;
  const Transform3d& truth = pair->truth;
  // The protocol: both clouds voxel-downsampled to 0.25 m, identity guess, 1.0 m.
  const auto source = voxel_downsample(pair->source, 0.25);
  const KdTree<3, double> target(voxel_downsample(pair->target, 0.25));
  Icp<3, double, MaxDistanceRejector<double>> icp;
  icp.params.check_degeneracy = false;
  const auto r = icp.align(target, source);
  INFO(to_string(r.reason) << " after " << r.iterations << ", rmse " << r.rmse);
  CHECK(r.converged);
  const auto [et, er] = transform_error<3>(r.transform, truth);
  CHECK(et < 0.06);  // small_gicp's figure: 0.060 m, 0.32°
  CHECK(er < 0.32 * std::numbers::pi / 180);
}

TEST_CASE("ICP aligns PCL's bunny scans bun4 onto bun0", "[registration][data]") {
  const auto a_path = test::data_file_or_skip("pcl_test/bun0.pcd");
  const auto b_path = test::data_file_or_skip("pcl_test/bun4.pcd");
  if (a_path.empty() || b_path.empty()) return;
  const auto a = io::read_pcd<double>(a_path), b = io::read_pcd<double>(b_path);
  const KdTree<3, double> tree(a);
  PaperIcp<3> icp;
  icp.rejector<DecayingDistanceRejector<double>>().initial_distance = 0.05;  // a 0.15 m bunny
  icp.rejector<DecayingDistanceRejector<double>>().final_distance = 0.005;
  const auto r = icp.align(tree, b);
  CHECK(r.converged);
  CHECK(r.rmse < 0.003);
  // The scans were taken about 35° apart about the bunny's vertical (y) axis (Stanford's
  // bun.conf gives 34.4° for bun045).
  const Eigen::AngleAxisd aa(r.transform.linear());
  CHECK(aa.angle() * 180 / std::numbers::pi == Approx(34.5).margin(1.5));
  CHECK(std::abs(aa.axis().y()) > 0.99);
}
