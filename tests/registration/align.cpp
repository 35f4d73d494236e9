// align(), the three solvers (point-to-point, point-to-plane, GICP) in 2D and 3D against ground
// truth, robust kernels, the pose prior and the information matrix, threads, and a user's own
// solver, rejector and search plugged into ICP.

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <optional>
#include <random>
#include <span>
#include <vector>

#include "rangenav/geometry/voxel_grid.hpp"
#include "rangenav/registration/align.hpp"
#include "rangenav/registration/gauss_newton_solver.hpp"
#include "rangenav/registration/gicp_solver.hpp"
#include "rangenav/registration/icp.hpp"
#include "rangenav/registration/normals.hpp"
#include "rangenav/registration/point_to_plane_solver.hpp"
#include "rangenav/registration/point_to_point_solver.hpp"
#include "rangenav/registration/transform_solver.hpp"
#include "rangenav/search/kd_tree.hpp"
#include "registration/kitti_pair.hpp"
#include "registration/scenes.hpp"
#include "test_support.hpp"

using namespace rangenav;
using test::make_transform3;
using test::transform_error;

namespace {

constexpr RegistrationMethod methods[] = {RegistrationMethod::point_to_point,
                                          RegistrationMethod::point_to_plane,
                                          RegistrationMethod::gicp};

/// A random rigid motion: translation up to `t` per axis, rotation up to `r` rad (about a random
/// axis in 3D).
template <int D>
Transform<D, double> random_motion(std::mt19937& rng, double t, double r) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Transform<D, double> m = Transform<D, double>::Identity();
  for (int d = 0; d < D; ++d)
    m.translation()[d] = t * u(rng);
  if constexpr (D == 2) {
    m.linear() = Eigen::Rotation2D<double>(r * u(rng)).toRotationMatrix();
  } else {
    const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    m.linear() = Eigen::AngleAxisd(r * u(rng), axis).toRotationMatrix();
  }
  return m;
}

/// The room of scenes.hpp sampled twice (independent samples of the same surfaces); in 3D
/// `per_face` points per 12 m^2 of surface.
template <int D>
std::pair<std::vector<Point<D, double>>, std::vector<Point<D, double>>> two_samples(
    std::mt19937& rng, std::size_t per_face = 300) {
  if constexpr (D == 2) {
    return {test::room_2d(0.05), test::room_2d(0.047)};
  } else {
    auto a = test::room_3d(rng, per_face);
    auto b = test::room_3d(rng, per_face);
    return {a, b};
  }
}

template <int D>
AlignSettings<double> settings_for(RegistrationMethod method) {
  AlignSettings<double> s;
  s.method = method;
  s.max_correspondence_distance = 0.5;
  return s;
}

}  // namespace

TEST_CASE("align: every method recovers random rigid motions with noise, forward and inverse",
          "[registration]") {
  // Target and source are two independent samples of the same room (scenes.hpp), the source
  // seen through a known motion, both with 5 mm Gaussian noise. Each method must recover the
  // motion (align(target, source) = truth) and its inverse (align(source, target)).
  const auto run = [](auto dim) {
    constexpr int D = decltype(dim)::value;
    std::mt19937 rng(11 + D);
    for (int trial = 0; trial < 4; ++trial) {
      auto [target, sample] = two_samples<D>(rng);
      const Transform<D, double> truth = random_motion<D>(rng, 0.2, 0.12);
      auto source = test::transformed<D>(sample, truth.inverse(Eigen::Isometry));
      test::add_noise<D>(target, 0.005, rng);
      test::add_noise<D>(source, 0.005, rng);
      for (const RegistrationMethod method : methods) {
        INFO("D = " << D << ", trial " << trial << ", " << to_string(method));
        const auto s = settings_for<D>(method);
        // Point-to-point pairs independent samples point by point: their spacing biases it.
        const double max_m = method == RegistrationMethod::point_to_point ? 0.02 : 0.01;
        const double max_rad = method == RegistrationMethod::point_to_point ? 0.01 : 0.005;
        const auto forward = align(target, source, Transform<D, double>::Identity(), s);
        CHECK(forward.converged);
        const auto [et, er] = transform_error<D>(forward.transform, truth);
        CHECK(et < max_m);
        CHECK(er < max_rad);
        const auto inverse = align(source, target, Transform<D, double>::Identity(), s);
        CHECK(inverse.converged);
        const auto [it, ir] = transform_error<D>(
            inverse.transform, Transform<D, double>(truth.inverse(Eigen::Isometry)));
        CHECK(it < max_m);
        CHECK(ir < max_rad);
        CHECK(forward.fitness > 0.9);
        REQUIRE(forward.information);
        CHECK(forward.information->allFinite());
      }
    }
  };
  run(std::integral_constant<int, 2>{});
  run(std::integral_constant<int, 3>{});
}

TEST_CASE("a cloud far from the origin converges as it does at the origin", "[registration]") {
  // The room with its centroid at the origin, and the same clouds moved to UTM-like coordinates
  // (5e5, 5e6, 0). ICP's translation test measures an update at the data's centroid when the
  // frame's origin lies far outside the data (detail::convergence_probe), which here is the
  // point it measures at the origin too, so both take the same iterations to the same answer.
  // Measured at the far origin, a turn of 1e-9 rad would move it by 5 mm, and the test would
  // wait for rotations far below what the data resolve (the KITTI pair: 7 GICP iterations
  // instead of 4, 21 point-to-point ones instead of 17).
  std::mt19937 rng(21);
  auto [target, sample] = two_samples<3>(rng);
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : sample)
    centroid += p;
  centroid /= static_cast<double>(sample.size());
  const Transform3d truth = make_transform3(0.15, -0.1, 0.05, 0.04, -0.03, 0.08);
  auto source = test::transformed<3>(sample, truth.inverse(Eigen::Isometry));
  test::add_noise<3>(target, 0.005, rng);
  test::add_noise<3>(source, 0.005, rng);
  const auto translation = [](const Eigen::Vector3d& by) {
    return Transform3d(Eigen::Translation3d(by));
  };
  const Eigen::Vector3d far(5e5, 5e6, 0.0);
  for (const RegistrationMethod method : methods) {
    INFO(to_string(method));
    const auto s = settings_for<3>(method);
    const auto near =
        align(test::transformed<3>(target, translation(-centroid)),
              test::transformed<3>(source, translation(-centroid)), Transform3d::Identity(), s);
    const auto away = align(test::transformed<3>(target, translation(far - centroid)),
                            test::transformed<3>(source, translation(far - centroid)),
                            Transform3d::Identity(), s);
    REQUIRE(near.converged);
    REQUIRE(away.converged);
    CHECK(away.iterations == near.iterations);
    // Clouds moved by o are registered by S(o) T S(-o), S(o) the translation by o.
    const Transform3d a = translation(centroid) * near.transform * translation(-centroid);
    const Transform3d b =
        translation(centroid - far) * away.transform * translation(far - centroid);
    CHECK(transform_error<3>(a, b).first < 1e-6);
    CHECK(transform_error<3>(b, truth).first < 0.02);
  }
}

TEST_CASE("solvers are exact on exact pairs (closed-form case)", "[registration]") {
  // Pairs m_i = T d_i for a known T: every solver's minimum is T with zero residual. GICP with
  // any covariances, point-to-plane with any normals that span the space.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-3, 3);
  const Transform3d truth = make_transform3(0.4, -0.3, 0.2, 0.1, -0.05, 0.3);
  std::vector<Correspondence<3, double>> pairs;
  std::vector<Eigen::Vector3d> normals;
  std::vector<Eigen::Matrix3d> covariances;
  for (std::uint32_t i = 0; i < 200; ++i) {
    const Eigen::Vector3d d(u(rng), u(rng), u(rng));
    pairs.push_back({d, truth * d, 0.0, i, i});
    normals.push_back(Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized());
    const Eigen::Matrix3d a = Eigen::Matrix3d::Random();
    covariances.push_back(a * a.transpose() + 0.01 * Eigen::Matrix3d::Identity());
  }
  const SolveContext<3, double> ctx{Transform3d::Identity(), nullptr, 1};
  PointToPlaneSolver<3, double> plane;
  plane.model_normals = normals;
  plane.gauss_newton_steps = 20;
  GicpSolver<3, double> gicp;
  gicp.model_covariances = covariances;
  gicp.data_covariances = covariances;
  gicp.gauss_newton_steps = 20;
  for (const auto& t : {PointToPointSolver<3, double>{}.solve(pairs, ctx), plane.solve(pairs, ctx),
                        gicp.solve(pairs, ctx)}) {
    REQUIRE(t);
    CHECK(transform_error<3>(*t, truth).first < 1e-9);
    // The rotation matrices, not the angle: acos near 1 resolves only ~1e-8 rad.
    CHECK((t->linear() - truth.linear()).norm() < 1e-9);
  }
  // At the truth every objective is zero and its gradient vanishes.
  for (const auto& eq : {PointToPointSolver<3, double>{}.linearize(pairs, truth, 1),
                         plane.linearize(pairs, truth, 1), gicp.linearize(pairs, truth, 1)}) {
    CHECK(eq.pairs == pairs.size());
    CHECK(eq.cost < 1e-20);
    CHECK(eq.gradient.norm() < 1e-9);
    CHECK(eq.hessian.allFinite());
  }
}

TEST_CASE("robust kernels survive 30 % outliers", "[registration]") {
  // 30 % of the source are outliers: a displaced copy of part of the scene (a moving object, a
  // reflection), 0.2 m off along x and y, within the correspondence distance. The inliers are
  // the target's points seen through the motion with 3 mm noise. Least squares is dragged
  // towards the outliers; each kernel, started from the same guess, is not.
  const auto run = [](auto dim) {
    constexpr int D = decltype(dim)::value;
    std::mt19937 rng(5);
    const auto target = two_samples<D>(rng).first;
    const auto& sample = target;
    const Transform<D, double> truth = random_motion<D>(rng, 0.1, 0.05);
    std::vector<Point<D, double>> source;
    const std::size_t outliers = sample.size() * 3 / 7;  // 30 % of the source
    Point<D, double> offset = Point<D, double>::Zero();
    offset.x() = 0.2;
    offset.y() = 0.2;
    for (std::size_t i = 0; i < sample.size() + outliers; ++i) {
      const Point<D, double> p = i < sample.size() ? sample[i] : sample[i % sample.size()] + offset;
      source.push_back(truth.inverse(Eigen::Isometry) * p);
    }
    test::add_noise<D>(source, 0.003, rng);
    for (const RegistrationMethod method : methods) {
      INFO("D = " << D << ", " << to_string(method));
      auto s = settings_for<D>(method);
      const auto plain = align(target, source, Transform<D, double>::Identity(), s);
      const double plain_error = transform_error<D>(plain.transform, truth).first;
      CHECK(plain_error > 0.02);
      for (const auto kernel :
           {RobustKernel<double>::huber(0.05), RobustKernel<double>::cauchy(0.05),
            RobustKernel<double>::geman_mcclure(0.05)}) {
        INFO(to_string(kernel.type));
        s.kernel = kernel;
        const auto robust = align(target, source, Transform<D, double>::Identity(), s);
        const auto [et, er] = transform_error<D>(robust.transform, truth);
        // Huber is convex: each outlier still pulls with a bounded force (delta), so it only
        // beats least squares. Cauchy's influence r / (1 + r^2 / delta^2) decays but does not
        // vanish: 30 % outliers 0.2 m off pull by (3/7) 0.2 / 17 ~ 5 mm per axis. Geman-McClure's
        // redescends as r^-3 and lets go of them.
        const double bound = kernel.type == RobustKernelType::huber    ? plain_error
                             : kernel.type == RobustKernelType::cauchy ? 0.02
                                                                       : 0.01;
        CHECK(et < bound);
        CHECK(er < 0.01);
      }
    }
  };
  run(std::integral_constant<int, 2>{});
  run(std::integral_constant<int, 3>{});
}

TEST_CASE("1 and 2 threads give the same transform bit for bit", "[registration]") {
  // Every stage runs in blocks of a size that does not depend on the thread count, each block in
  // order, the blocks combined in order (core/parallel.hpp): the bits must agree. Without OpenMP
  // the threads run serially and the test holds trivially.
  INFO("OpenMP enabled: " << parallel_enabled);
  std::mt19937 rng(9);
  // Large enough for several blocks of every reduction and a kd-tree cut into parts.
  auto [target, sample] = two_samples<3>(rng, 800);
  REQUIRE(target.size() > 4 * detail::reduction_block);
  REQUIRE(sample.size() > 4 * detail::closed_form_block);
  REQUIRE(target.size() >= 2 * KdTree<3, double>::part_size);
  const Transform3d truth = random_motion<3>(rng, 0.2, 0.1);
  auto source = test::transformed<3>(sample, truth.inverse(Eigen::Isometry));
  test::add_noise<3>(source, 0.01, rng);
  for (const RegistrationMethod method : methods) {
    for (const double voxel : {0.0, 0.1}) {
      INFO(to_string(method) << ", voxel " << voxel);
      auto s = settings_for<3>(method);
      s.voxel_size = voxel;
      s.check_degeneracy = true;
      s.kernel = RobustKernel<double>::cauchy(0.05);
      const auto one = align(target, source, Transform3d::Identity(), s);
      for (const int threads : {2, 3}) {
        s.num_threads = threads;
        const auto many = align(target, source, Transform3d::Identity(), s);
        CHECK(many.transform.matrix() == one.transform.matrix());
        CHECK(many.iterations == one.iterations);
        CHECK(many.neighbor_searches == one.neighbor_searches);
        REQUIRE(many.information);
        CHECK(*many.information == *one.information);
        CHECK(many.smallest_eigenvalue == one.smallest_eigenvalue);
      }
    }
  }
  const KdTree<3, double> tree(target);
  CHECK(estimate_covariances(tree, 10, 2) == estimate_covariances(tree, 10, 1));
  CHECK(estimate_normals(tree, 10, 3) == estimate_normals(tree, 10, 1));
}

namespace {

/// A corridor 2 m wide and 40 m long along x (2D: two walls; 3D: walls, floor and ceiling):
/// nothing constrains the motion along x.
template <int D>
std::vector<Point<D, double>> corridor(std::mt19937& rng) {
  if constexpr (D == 2) {
    auto pts = test::corridor_2d(0.05);
    test::add_noise<2>(pts, 0.005, rng);
    return pts;
  } else {
    std::uniform_real_distribution<double> along(-20, 20), across(-1, 1), up(0, 2.5);
    std::normal_distribution<double> noise(0, 0.005);
    std::vector<Eigen::Vector3d> pts;
    for (int i = 0; i < 6000; ++i) {
      const double x = along(rng);
      switch (i % 4) {
        case 0:
          pts.emplace_back(x, -1 + noise(rng), up(rng));
          break;
        case 1:
          pts.emplace_back(x, 1 + noise(rng), up(rng));
          break;
        case 2:
          pts.emplace_back(x, across(rng), noise(rng));
          break;
        default:
          pts.emplace_back(x, across(rng), 2.5 + noise(rng));
          break;
      }
    }
    return pts;
  }
}

}  // namespace

TEST_CASE(
    "a pose prior carries the directions a corridor leaves free; the information's null "
    "space is the corridor's axis",
    "[registration]") {
  const auto run = [](auto dim, RegistrationMethod method) {
    constexpr int D = decltype(dim)::value;
    constexpr int dof = pose_dof<D>;
    INFO("D = " << D << ", " << to_string(method));
    std::mt19937 rng(21);
    const auto target = corridor<D>(rng);
    // The truth moves the source 0.1 m across and a little in heading / attitude; along the
    // axis it moves 0.5 m, which nothing in a corridor can see.
    Transform<D, double> truth = Transform<D, double>::Identity();
    if constexpr (D == 2) {
      truth = make_transform2(0.5, 0.1, 0.02);
    } else {
      truth = make_transform3(0.5, 0.1, 0.05, 0.01, -0.01, 0.02);
    }
    auto source = test::transformed<D>(corridor<D>(rng), truth.inverse(Eigen::Isometry));
    // The guess is 0.3 m off along the axis, the prior 0.1 m (and right in the other directions).
    Point<D, double> along = Point<D, double>::Zero();
    along.x() = 1;
    Transform<D, double> guess = truth, prior_mean = truth;
    guess.translation() += 0.3 * along;
    prior_mean.translation() += 0.1 * along;
    PosePrior<D, double> prior{prior_mean, PoseMatrix<D, double>::Identity() / (0.2 * 0.2)};
    auto s = settings_for<D>(method);
    s.max_correspondence_distance = 0.3;

    const auto without = align(target, source, guess, s);
    const auto with = align(target, source, guess, s, prior);
    const Point<D, double> error_without = without.transform.translation() - truth.translation();
    const Point<D, double> error_with = with.transform.translation() - truth.translation();
    // With the prior, the error along the axis is the prior's; across it, small.
    CHECK(error_with.x() == Approx(0.1).margin(0.01));
    CHECK(std::abs(error_with.y()) < 0.01);
    // Without it, the axis keeps whatever the start had (here the guess's 0.3 m): not the prior's.
    CHECK(std::abs(error_without.x() - 0.1) > 0.1);
    CHECK(std::abs(error_without.y()) < 0.01);
    // The scan match's information (the prior not included) has the axis as its null space.
    REQUIRE(with.information);
    const Eigen::SelfAdjointEigenSolver<PoseMatrix<D, double>> eig(*with.information);
    const auto v = eig.eigenvectors().col(0);
    // (What the normals' errors or GICP's eps-level weight along the surfaces would put there is
    // below IcpParams::degeneracy_ratio of the strongest direction, and reported as nothing.)
    CHECK(std::abs(eig.eigenvalues()(0)) < 1e-9 * eig.eigenvalues()(dof - 1));
    CHECK(std::abs(v(0)) > 0.99);  // the translation along x (data frame ~ model frame here)
  };
  run(std::integral_constant<int, 2>{}, RegistrationMethod::point_to_plane);
  run(std::integral_constant<int, 2>{}, RegistrationMethod::gicp);
  run(std::integral_constant<int, 3>{}, RegistrationMethod::gicp);
  // Not 3D point-to-plane: the PCA normals of points near the corridor's edges (their k
  // neighbours on two surfaces) tilt along the axis and constrain it falsely, 1.6 % of the
  // strongest direction here, above the 1 % degeneracy ratio (docs/registration.md, pitfalls).
}

TEST_CASE("the inverse of the information matrix predicts the spread of the estimate",
          "[registration]") {
  // Monte Carlo: a noise-free model (a map) and a scan of the same room with fresh 1 cm noise,
  // 40 times. The sample covariance of the errors (in the tangent space of transform_solver.hpp)
  // must match the mean predicted covariance (the information's inverse) within a factor of 2.5
  // along every principal direction of the prediction. (With a noisy model the residuals of
  // pairs that share model points are correlated and the prediction is optimistic: Censi 2007.)
  const auto run = [](auto dim, RegistrationMethod method) {
    constexpr int D = decltype(dim)::value;
    constexpr int dof = pose_dof<D>;
    INFO("D = " << D << ", " << to_string(method));
    std::mt19937 rng(31);
    // (dense enough in 3D that few neighbourhoods of the normals straddle an edge of the room)
    auto [clean_target, clean_sample] = two_samples<D>(rng, 1500);
    const Transform<D, double> truth = random_motion<D>(rng, 0.05, 0.03);
    const auto clean_source = test::transformed<D>(clean_sample, truth.inverse(Eigen::Isometry));
    const int trials = 40;
    std::vector<PoseTangent<D, double>> errors;
    PoseMatrix<D, double> predicted = PoseMatrix<D, double>::Zero();
    for (int k = 0; k < trials; ++k) {
      const auto& target = clean_target;
      auto source = clean_source;
      test::add_noise<D>(source, 0.01, rng);
      const auto r =
          align(target, source, Transform<D, double>::Identity(), settings_for<D>(method));
      REQUIRE(r.information);
      errors.push_back(local_coordinates<D, double>(r.transform, truth));
      predicted += r.information->inverse() / trials;
    }
    PoseTangent<D, double> mean = PoseTangent<D, double>::Zero();
    for (const auto& e : errors)
      mean += e / trials;
    PoseMatrix<D, double> sample = PoseMatrix<D, double>::Zero();
    for (const auto& e : errors)
      sample += (e - mean) * (e - mean).transpose() / (trials - 1);
    const Eigen::SelfAdjointEigenSolver<PoseMatrix<D, double>> eig(predicted);
    for (int k = 0; k < dof; ++k) {
      const auto v = eig.eigenvectors().col(k);
      const double ratio = v.dot(sample * v) / eig.eigenvalues()(k);
      INFO("direction " << v.transpose() << ": sample / predicted variance " << ratio);
      CHECK(ratio > 0.4);
      CHECK(ratio < 2.5);
    }
  };
  run(std::integral_constant<int, 2>{}, RegistrationMethod::point_to_plane);
  run(std::integral_constant<int, 3>{}, RegistrationMethod::point_to_plane);
  run(std::integral_constant<int, 3>{}, RegistrationMethod::gicp);
}

namespace {

// ---- a user's own search, rejector and solver ----------------------------------------------

/// A search structure written from scratch: brute force over a list (NearestNeighborSearch).
struct ListSearch {
  static constexpr int dimension = 2;
  using scalar_type = double;
  std::vector<Eigen::Vector2d> points;
  mutable int queries = 0;

  [[nodiscard]] std::size_t size() const { return points.size(); }
  [[nodiscard]] const Eigen::Vector2d& point(std::size_t i) const { return points[i]; }
  [[nodiscard]] std::optional<Neighbor<double>> nearest(
      const Eigen::Vector2d& q, double bound_sq = unbounded_sq<double>) const {
    ++queries;
    std::optional<Neighbor<double>> best;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const double d = (points[i] - q).squaredNorm();
      if (d < bound_sq && (!best || d < best->distance_sq))
        best = Neighbor<double>{static_cast<std::uint32_t>(i), d};
    }
    return best;
  }
  std::size_t knn(const Eigen::Vector2d& q, std::size_t k, std::vector<Neighbor<double>>& out,
                  double bound_sq = unbounded_sq<double>) const {
    radius(q, bound_sq, out);
    if (out.size() > k) out.resize(k);
    return out.size();
  }
  std::size_t radius(const Eigen::Vector2d& q, double radius_sq,
                     std::vector<Neighbor<double>>& out) const {
    ++queries;
    out.clear();
    for (std::size_t i = 0; i < points.size(); ++i) {
      const double d = (points[i] - q).squaredNorm();
      if (d < radius_sq) out.push_back({static_cast<std::uint32_t>(i), d});
    }
    std::sort(out.begin(), out.end(),
              [](const auto& a, const auto& b) { return a.distance_sq < b.distance_sq; });
    return out.size();
  }
};

/// A rejector that drops the pairs of data points left of x = 0 (a blind sector of the sensor).
struct BlindSectorRejector {
  void reject(const IcpContext<2, double>&, std::vector<Correspondence<2, double>>& pairs) const {
    std::erase_if(pairs, [](const auto& c) { return c.data.x() < 0; });
  }
};

/// A solver for a robot that cannot turn: the translation-only least-squares solution
/// t = mean(m_i - d_i), with its own normal equations (the x and y rows; no rotation).
struct TranslationSolver {
  static constexpr std::size_t min_pairs = 1;
  [[nodiscard]] std::optional<Transform2d> solve(std::span<const Correspondence<2, double>> pairs,
                                                 const SolveContext<2, double>&) const {
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    for (const auto& c : pairs)
      sum += c.model - c.data;
    Transform2d t = Transform2d::Identity();
    t.translation() = sum / static_cast<double>(pairs.size());
    return t;
  }
  [[nodiscard]] NormalEquations<2, double> linearize(
      std::span<const Correspondence<2, double>> pairs, const Transform2d& t, int) const {
    NormalEquations<2, double> eq;
    for (const auto& c : pairs) {
      const Eigen::Vector2d r = t * c.data - c.model;
      eq.hessian.topLeftCorner<2, 2>() += Eigen::Matrix2d::Identity();
      eq.gradient.head<2>() += r;
      eq.cost += r.squaredNorm();
      eq.weighted_sq += r.squaredNorm();
      eq.residuals += 2;
      ++eq.pairs;
    }
    return eq;
  }
};

/// A least-squares solver of a user's own on GaussNewtonSolver: point-to-point written out by
/// hand in the tangent space of transform_solver.hpp (r = R^T (T d - m), J = [I | S(d)]).
/// `skip_all` leaves every pair out, so solve() must fall back to the point-to-point solution.
struct HandWrittenSolver : GaussNewtonSolver<HandWrittenSolver, 2, double, 3> {
  static constexpr std::size_t min_pairs = 3;
  bool skip_all = false;
  struct Residual {
    const HandWrittenSolver* solver;
    template <class Apply>
    bool operator()(const Correspondence<2, double>& pr, const Apply& apply,
                    const Eigen::Matrix2d& rt, NormalEquations<2, double>& eq) const {
      if (solver->skip_all) return false;
      const Eigen::Vector2d r = rt * (apply(pr.data) - pr.model);
      Eigen::Matrix<double, 2, 3> j;
      j << 1, 0, -pr.data.y(), 0, 1, pr.data.x();
      eq.hessian += j.transpose() * j;
      eq.gradient += j.transpose() * r;
      eq.cost += r.squaredNorm();
      eq.weighted_sq += r.squaredNorm();
      eq.residuals += 2;
      ++eq.pairs;
      return true;
    }
  };
};

}  // namespace

static_assert(NearestNeighborSearch<ListSearch>);
static_assert(CorrespondenceRejector<BlindSectorRejector, 2, double>);
static_assert(TransformSolver<TranslationSolver, 2, double>);
static_assert(!ModelNormalSolver<TranslationSolver, 2, double>);

TEST_CASE("a user's own solver, rejector and search plug into ICP", "[registration]") {
  const auto model = test::room_2d(0.1);
  const Transform2d truth = make_transform2(0.15, -0.1, 0.0);
  const auto data = test::transformed<2>(model, truth.inverse(Eigen::Isometry));
  BasicIcp<2, double, TranslationSolver, BlindSectorRejector, MaxDistanceRejector<double>> icp;
  icp.rejector<MaxDistanceRejector<double>>().max_distance = 0.5;
  icp.params.check_degeneracy = false;
  const ListSearch search{model};
  const auto r = icp.align(search, data);
  CHECK(r.converged);
  CHECK(search.queries > 0);
  CHECK(transform_error<2>(r.transform, truth).first < 1e-3);
  CHECK(r.transform.linear().isIdentity(0.0));  // the solver never turns
  for (const auto& c : icp.correspondences())
    CHECK(c.data.x() >= 0);  // the rejector ran
  // The information comes from the user's normal equations: no rotation row.
  REQUIRE(r.information);
  CHECK((*r.information)(0, 0) > 0.0);
  CHECK(std::abs((*r.information)(2, 2)) < 1e-9 * (*r.information)(0, 0));
}

TEST_CASE("a user's Gauss-Newton solver needs only its residual", "[registration]") {
  const auto model = test::room_2d(0.1);
  const Transform2d truth = make_transform2(0.2, -0.1, 0.08);
  const auto data = test::transformed<2>(model, truth.inverse(Eigen::Isometry));
  static_assert(TransformSolver<HandWrittenSolver, 2, double>);
  for (const bool skip_all : {false, true}) {
    CAPTURE(skip_all);
    BasicIcp<2, double, HandWrittenSolver, MaxDistanceRejector<double>> icp;
    icp.rejector<MaxDistanceRejector<double>>().max_distance = 0.5;
    icp.solver.skip_all = skip_all;  // true: every step falls back to point-to-point
    const KdTree<2, double> tree(model);
    const auto r = icp.align(tree, data);
    CHECK(r.converged);
    const auto [dt, dr] = transform_error<2>(r.transform, truth);
    CHECK(dt < 1e-4);
    CHECK(dr < 1e-4);
    if (!skip_all) {
      // The information comes from the hand-written normal equations, which constrain the
      // translation and the rotation.
      REQUIRE(r.information);
      CHECK((*r.information)(0, 0) > 0.0);
      CHECK((*r.information)(2, 2) > 0.0);
    }
  }
}

TEST_CASE("align answers bad input clearly", "[registration]") {
  const auto room = test::room_2d(0.1);
  AlignSettings<double> s;
  CHECK_THROWS_WITH(align(std::vector<Eigen::Vector2d>{}, room),
                    "rangenav: align: argument 'target' is empty (0 points)");
  CHECK_THROWS_WITH(align(room, std::vector<Eigen::Vector2d>{}),
                    "rangenav: align: argument 'source' is empty (0 points)");
  s.max_correspondence_distance = 0;
  CHECK_THROWS_AS(align(room, room, Transform2d::Identity(), s), invalid_argument);
  s = {};
  s.num_threads = 0;
  CHECK_THROWS_WITH(align(room, room, Transform2d::Identity(), s),
                    "rangenav: AlignSettings: argument 'num_threads' = 0 must be >= 1");
  s = {};
  s.kernel = RobustKernel<double>::huber(-1.0);
  CHECK_THROWS_AS(align(room, room, Transform2d::Identity(), s), invalid_argument);
  s = {};
  PosePrior<2, double> prior;
  prior.information(0, 0) = -1;
  CHECK_THROWS_AS(align(room, room, Transform2d::Identity(), s, prior), invalid_argument);
  prior.information(0, 0) = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_WITH(align(room, room, Transform2d::Identity(), s, prior),
                    "rangenav: align: argument 'prior.information' is not finite");
  // All-NaN source: nothing to pair, reported, not thrown.
  const std::vector<Eigen::Vector2d> nan(10, Eigen::Vector2d::Constant(std::nan("")));
  const auto r = align(room, nan);
  CHECK(r.reason == IcpTermination::too_few_pairs);
  CHECK(r.transform.matrix().allFinite());
}

TEST_CASE("align on the KITTI pair of small_gicp against its ground truth",
          "[registration][data]") {
  const auto pair = test::kitti_pair_or_skip();
  if (!pair) return;
  const auto& [source, target, truth] = *pair;
  // The protocol: 0.25 m voxels, identity guess, 1.0 m correspondence distance.
  AlignSettings<double> s;
  s.voxel_size = 0.25;
  s.max_correspondence_distance = 1.0;
  // Bounds with a margin over bench_icp's figures (GICP 0.007 m / 0.32 deg; point-to-plane
  // 0.018 m / 0.21 deg; point-to-point 0.033 m / 0.23 deg).
  const std::pair<double, double> bounds[] = {{0.05, 0.4}, {0.03, 0.4}, {0.012, 0.4}};
  for (int k = 0; k < 3; ++k) {
    s.method = methods[k];
    const auto r = align(target, source, Transform3d::Identity(), s);
    INFO(to_string(s.method) << ": " << to_string(r.reason) << " after " << r.iterations);
    CHECK(r.converged);
    const auto [et, er] = transform_error<3>(r.transform, truth);
    CHECK(et < bounds[k].first);
    CHECK(er < bounds[k].second * std::numbers::pi / 180);
  }
}
