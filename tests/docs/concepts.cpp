// The "write your own" sections of docs/concepts.md, compiled and run: each extension point gets
// a user-written type, a static_assert that it models the concept, and a test that plugs it into
// the library and checks the outcome against ground truth. The regions between
// "// [snippet:NAME]" and "// [snippet-end]" are copied into the Markdown.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

#include "docs_support.hpp"
#include "rangenav/rangenav.hpp"

namespace docs = rangenav::docs_test;

// ---- PointCloud ---------------------------------------------------------------------------

// [snippet:register-point]
// Your own point type becomes usable in any random-access container (std::vector, std::array,
// std::span, ...): register its fields at global scope.
struct LidarPoint {
  float x, y, z;
  float intensity;
};
RANGENAV_REGISTER_POINT_3D(LidarPoint, float, x, y, z);

static_assert(rangenav::PointCloudOf<std::vector<LidarPoint>, 3>);
// [snippet-end]

// [snippet:cloud-access]
// A container that is not a range of points (here a structure of arrays) specialises
// rangenav::traits::cloud_access with its dimension, scalar type, size and i-th point.
struct PlanarScanArrays {
  std::vector<double> xs, ys;
};

template <>
struct rangenav::traits::cloud_access<PlanarScanArrays> {
  static constexpr int dimension = 2;
  using Scalar = double;
  static std::size_t size(const PlanarScanArrays& c) { return c.xs.size(); }
  static rangenav::Point2d point(const PlanarScanArrays& c, std::size_t i) {
    return {c.xs[i], c.ys[i]};
  }
};

static_assert(rangenav::PointCloudOf<PlanarScanArrays, 2>);
// [snippet-end]

TEST_CASE("concepts: your own point type and cloud container work with the library", "[docs]") {
  // [snippet:use-own-cloud]
  const std::vector<LidarPoint> cloud{{1, 0, 0, 10}, {0, 1, 0, 20}, {0, 0, 1, 30}};
  const rangenav::KdTree<3, float> tree(cloud);  // indexes any PointCloud: no copy on your side
  const auto nearest = tree.nearest({0.9f, 0.1f, 0.0f});  // index 0, distance_sq 0.02

  const PlanarScanArrays scan{{1.0, 1.2, 3.0}, {0.0, 0.1, 1.0}};
  const auto thinned = rangenav::voxel_downsample(scan, 1.0);  // {(1.1, 0.05), (3, 1)}
  // [snippet-end]
  REQUIRE(nearest);
  CHECK(nearest->index == 0);
  CHECK(nearest->distance_sq == Approx(0.02f));
  REQUIRE(thinned.size() == 2);
  CHECK(std::count_if(thinned.begin(), thinned.end(),
                      [](const auto& p) { return p.isApprox(rangenav::Point2d(1.1, 0.05)); }) == 1);
}

// ---- NearestNeighborSearch ------------------------------------------------------------------

// [snippet:own-search]
// An exact search over points sorted by x: a query walks outwards from its own x and stops once
// the gap in x alone exceeds the collector's bound. SearchQueries turns this one walk into the
// concept's nearest(), knn() and radius(). Every distance is squared (`*_sq`), every bound strict.
template <int D>
class SortedXSearch : public rangenav::SearchQueries<SortedXSearch<D>, D, double> {
 public:
  static constexpr int dimension = D;
  using scalar_type = double;
  using point_type = rangenav::Point<D, double>;

  explicit SortedXSearch(std::vector<point_type> points) : points_(std::move(points)) {
    std::sort(points_.begin(), points_.end(),
              [](const point_type& a, const point_type& b) { return a.x() < b.x(); });
  }
  std::size_t size() const { return points_.size(); }
  const point_type& point(std::size_t i) const { return points_[i]; }

  // Offers the collector every point that may lie within its bound, c.worstDist(), which shrinks
  // as it fills (the query's own bound_sq is where it starts), nearest x first.
  template <class Collector>
  void collect(Collector& c, const point_type& q, double /*bound_sq*/) const {
    const std::size_t n = points_.size();
    const auto first_not_below =
        std::lower_bound(points_.begin(), points_.end(), q.x(),
                         [](const point_type& p, double x) { return p.x() < x; });
    std::size_t up = static_cast<std::size_t>(first_not_below - points_.begin()), down = up;
    while (up < n || down > 0) {  // points_[up] is the next one above, points_[down - 1] below
      const double gap_up = up < n ? points_[up].x() - q.x() : INFINITY;
      const double gap_down = down > 0 ? q.x() - points_[down - 1].x() : INFINITY;
      const std::size_t i = gap_up <= gap_down ? up++ : --down;
      const double gap = std::min(gap_up, gap_down);
      if (!(gap * gap < c.worstDist())) break;  // every point left is farther in x alone
      c.addPoint((points_[i] - q).squaredNorm(), static_cast<std::uint32_t>(i));
    }
  }

 private:
  std::vector<point_type> points_;
};

static_assert(rangenav::NearestNeighborSearch<SortedXSearch<2>>);
// [snippet-end]

TEST_CASE("concepts: your own search answers as the kd-tree does, and ICP runs on it", "[docs]") {
  const docs::ScanPair scans = docs::apartment_scan_pair(/*with_new_box=*/false);
  const std::vector<rangenav::Point2d> model_points = scans.model.valid_points();

  // [snippet:use-own-search]
  const SortedXSearch<2> model(model_points);
  rangenav::PaperIcp<2> icp;
  const auto result = icp.align(model, scans.data, scans.guess);  // any NearestNeighborSearch
  // [snippet-end]

  // Same answers as the kd-tree on random queries, hence the same alignment.
  const rangenav::KdTree<2, double> tree(model_points);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-6.0, 6.0);
  std::vector<rangenav::Neighbor<double>> mine, theirs;
  for (int q = 0; q < 200; ++q) {
    const rangenav::Point2d p = scans.model.valid_points()[0] + rangenav::Point2d(u(rng), u(rng));
    const auto a = model.nearest(p, 4.0), b = tree.nearest(p, 4.0);
    REQUIRE(a.has_value() == b.has_value());
    if (a) CHECK(a->distance_sq == b->distance_sq);
    model.knn(p, 5, mine);
    tree.knn(p, 5, theirs);
    REQUIRE(mine.size() == theirs.size());
    for (std::size_t i = 0; i < mine.size(); ++i)
      CHECK(mine[i].distance_sq == theirs[i].distance_sq);
    CHECK(model.radius(p, 0.25, mine) == tree.radius(p, 0.25, theirs));
  }
  REQUIRE(result.converged);
  const auto with_tree = rangenav::PaperIcp<2>().align(tree, scans.data, scans.guess);
  CHECK((result.transform.matrix() - with_tree.transform.matrix()).norm() < 1e-9);
  CHECK(rangenav::relative(scans.truth, rangenav::Pose2d::from_isometry(result.transform))
            .position()
            .norm() < 0.01);
}

// ---- CorrespondenceRejector -----------------------------------------------------------------

// [snippet:admits-rejector]
// A rejector may also act before the search: `admits` sees each data point in the model frame
// under the current transform, and a point it refuses is not searched for. Here: 3D points
// below 5 cm (the floor) are left out, so a flat floor cannot pull the alignment along itself.
struct AboveFloorRejector {
  double min_height = 0.05;  // m

  bool admits(const rangenav::IcpContext<3, double>&, const rangenav::Point3d& p) const {
    return p.z() >= min_height;
  }
};
static_assert(rangenav::CorrespondenceRejector<AboveFloorRejector, 3, double>);
// [snippet-end]

TEST_CASE("concepts: a rejector that admits data points before the search", "[docs]") {
  // A floor, two walls from 15 cm up and a table top at 0.8 m, sampled at random; the data is the
  // same points moved by 10 cm. A quarter of the points lie on the floor.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<rangenav::Point3d> model, data;
  for (int i = 0; i < 6000; ++i) {
    const double a = 4 * u(rng), b = 4 * u(rng), c = 0.15 + 2 * u(rng);
    if (i % 4 == 0) model.emplace_back(a, b, 0.0);                  // floor
    if (i % 4 == 1) model.emplace_back(a, 0.0, c);                  // wall y = 0
    if (i % 4 == 2) model.emplace_back(0.0, b, c);                  // wall x = 0
    if (i % 4 == 3) model.emplace_back(1 + a / 4, 1 + b / 4, 0.8);  // table top
  }
  const rangenav::Point3d shift(0.1, -0.05, 0.02);
  for (const auto& p : model)
    data.push_back(p - shift);
  rangenav::Icp<3, double, rangenav::MaxDistanceRejector<double>, AboveFloorRejector> icp;
  icp.rejector<rangenav::MaxDistanceRejector<double>>().max_distance = 0.3;
  const auto result = icp.align(rangenav::KdTree<3, double>(model), data);
  REQUIRE(result.converged);
  CHECK((result.transform.translation() - shift).norm() < 1e-9);
  CHECK(result.data_count == data.size());
  CHECK(result.matched_count == data.size() * 3 / 4);  // the floor was never searched
}

// ---- TransformSolver ----------------------------------------------------------------------

// [snippet:own-solver]
// A solver turns the kept pairs into a transform. When a compass or an IMU gives the heading,
// only a translation is left to estimate: the mean offset between the pairs.
template <int D>
struct TranslationOnlySolver {
  static constexpr std::size_t min_pairs = 1;

  std::optional<rangenav::Transform<D, double>> solve(
      std::span<const rangenav::Correspondence<D, double>> pairs,
      const rangenav::SolveContext<D, double>& /*ctx: ICP's estimate, a prior, threads*/) const {
    if (pairs.size() < min_pairs) return std::nullopt;
    rangenav::Point<D, double> sum = rangenav::Point<D, double>::Zero();
    for (const auto& pair : pairs)
      sum += pair.model - pair.data;  // data points are given in the data frame
    rangenav::Transform<D, double> t = rangenav::Transform<D, double>::Identity();
    t.translation() = sum / static_cast<double>(pairs.size());
    return t;
  }

  // The normal equations of sum |T d - m|^2 at t (for IcpResult::information): the translation
  // rows of the tangent space (rotation rows zero: the solver does not estimate them).
  rangenav::NormalEquations<D, double> linearize(
      std::span<const rangenav::Correspondence<D, double>> pairs,
      const rangenav::Transform<D, double>& t, int /*num_threads*/) const {
    rangenav::NormalEquations<D, double> eq;
    for (const auto& pair : pairs) {
      const rangenav::Point<D, double> r = t.linear().transpose() * (t * pair.data - pair.model);
      eq.hessian.template topLeftCorner<D, D>().diagonal().array() += 1.0;
      eq.gradient.template head<D>() += r;
      eq.cost += r.squaredNorm();
      eq.weighted_sq += r.squaredNorm();
      eq.residuals += D;
      ++eq.pairs;
    }
    return eq;
  }
};
static_assert(rangenav::TransformSolver<TranslationOnlySolver<2>, 2, double>);

// BasicIcp takes the solver first, then any rejectors.
using TranslationIcp = rangenav::BasicIcp<2, double, TranslationOnlySolver<2>,
                                          rangenav::DecayingDistanceRejector<double>>;
// [snippet-end]

TEST_CASE("concepts: your own solver estimates a translation only", "[docs]") {
  // Two scans of the apartment 0.3 m apart along x and y, same heading.
  const rangenav::sim::Scene scene = rangenav::sim::apartment();
  const rangenav::sim::LaserScanner2D laser;
  std::mt19937 rng(11);
  const rangenav::Pose2d moved = rangenav::compose(scene.start, {0.25, 0.1, 0.0});
  const auto model = laser.scan(scene.world, scene.start, rng);
  const auto data = laser.scan(scene.world, moved, rng);
  TranslationIcp icp;
  const auto result = icp.align(rangenav::KdTree<2, double>(model), data);
  REQUIRE(result.converged);
  CHECK(result.transform.linear().isIdentity(1e-12));
  CHECK((result.transform.translation() - rangenav::Point2d(0.25, 0.1)).norm() < 0.01);
}

// ---- VirtualMapPolicy ---------------------------------------------------------------------

// [snippet:own-policy]
// A virtual-map policy decides which readings a bin admits, which of two it keeps, and what an
// empty bin holds. This one keeps the nearest reading within the robot's reach only: a short-range
// obstacle map for a slow robot that must not react to what lies beyond 2 m.
struct NearbyObstaclePolicy {
  double reach = 2.0;                // m
  double z_min = 0.02, z_max = 1.2;  // m, the robot's height band

  bool admits(double range, double z, double max_range) const {
    return range < std::min(reach, max_range) && z >= z_min && z <= z_max;
  }
  bool prefers(double candidate, double kept) const { return candidate <= kept; }  // nearer wins
  double dummy_range(double max_range) const { return max_range; }
};
static_assert(rangenav::VirtualMapPolicy<NearbyObstaclePolicy, double>);
// [snippet-end]

TEST_CASE("concepts: your own virtual-map policy", "[docs]") {
  // [snippet:use-own-policy]
  rangenav::VirtualMap<NearbyObstaclePolicy, double> nearby({}, NearbyObstaclePolicy{.reach = 2.0});
  const std::vector<rangenav::Point3d> readings{
      {1.0, 0.0, 0.3},   // ahead, 1 m: kept
      {1.5, 0.0, 0.3},   // same bearing, farther: the nearer one stays
      {0.0, 3.0, 0.3},   // left, 3 m: beyond reach
      {-1.0, 0.0, 0.0},  // behind, on the floor: below the height band
  };
  nearby.insert(readings);
  // nearby.valid_points() == {(1, 0)}; it is a 2D PointCloud for every scan algorithm
  // [snippet-end]
  REQUIRE(nearby.valid_count() == 1);
  CHECK(nearby.valid_points().front().isApprox(rangenav::Point2d(1.0, 0.0)));
}

// ---- PolygonClipper -----------------------------------------------------------------------

// [snippet:own-clipper]
// A clipper answers two questions about two polygons with holes: do they overlap, and what is
// their union. This one wraps another clipper and counts the calls, e.g. to see how many unions
// a geometric map computes per key frame.
template <class Inner = rangenav::BoostGeometryClipper>
struct CountingClipper {
  Inner inner{};
  mutable std::size_t intersection_tests = 0, unions = 0;

  template <class Scalar>
  bool intersects(const rangenav::Polygon2<Scalar>& a, const rangenav::Polygon2<Scalar>& b) const {
    ++intersection_tests;
    return inner.intersects(a, b);
  }
  template <class Scalar>
  std::vector<rangenav::Polygon2<Scalar>> union_of(const rangenav::Polygon2<Scalar>& a,
                                                   const rangenav::Polygon2<Scalar>& b) const {
    ++unions;
    return inner.union_of(a, b);
  }
};
static_assert(rangenav::PolygonClipper<CountingClipper<>, double>);
// [snippet-end]

TEST_CASE("concepts: your own polygon clipper inside a geometric map", "[docs]") {
  // Two overlapping 1 m squares on the floor plane z = 0: the map merges them into one shape.
  const auto floor_square = [](double x0) {
    rangenav::PlanarPolygon<double> p;
    p.plane = rangenav::Plane3<double>::through({0, 0, 0}, {0, 0, 1});
    p.frame = rangenav::PlaneFrame<double>::of(p.plane);
    for (const rangenav::Point3d& corner :
         {rangenav::Point3d(x0, 0, 0), rangenav::Point3d(x0 + 1, 0, 0),
          rangenav::Point3d(x0 + 1, 1, 0), rangenav::Point3d(x0, 1, 0)})
      p.polygon.outer.push_back(p.frame.to_plane(corner));
    return p;
  };
  // [snippet:use-own-clipper]
  rangenav::GeometricMap<double, CountingClipper<>> map;
  map.insert(floor_square(0.0));
  map.insert(floor_square(0.5));  // overlaps the first: merged by a union
  // map.shapes().size() == 1, map.clipper().unions == 1
  // [snippet-end]
  REQUIRE(map.shapes().size() == 1);
  CHECK(map.shapes().front().surface.area() == Approx(1.5).epsilon(1e-9));
  CHECK(map.clipper().unions == 1);
  CHECK(map.clipper().intersection_tests >= 1);
}

// ---- MotionModel and SensorModel ----------------------------------------------------------

// [snippet:own-models]
// A robot on a 10 m rail measures its distance to the wall at the end. State: its position x.
struct RailMotion {     // MotionModel: where a particle goes for a commanded step u
  double sigma = 0.02;  // m per step
  template <class Engine>
  double sample(double x, double u, Engine& rng) const {
    return x + u + std::normal_distribution<double>(0.0, sigma)(rng);
  }
};
struct WallRange {      // SensorModel: log p(z | x) of a range z to the wall at 10 m
  double sigma = 0.05;  // m
  double log_likelihood(double x, double z) const {
    const double e = (z - (10.0 - x)) / sigma;
    return -0.5 * e * e;  // constants cancel in the normalisation
  }
};
static_assert(rangenav::MotionModel<RailMotion, double, double, std::mt19937>);
static_assert(rangenav::SensorModel<WallRange, double, double>);
// [snippet-end]

TEST_CASE("concepts: your own motion and sensor models in the particle filter", "[docs]") {
  std::mt19937 rng(2);
  double truth = 2.0;
  std::vector<double> start;
  for (int i = 0; i < 1000; ++i)
    start.push_back(10.0 * (i + 0.5) / 1000);  // anywhere on the rail
  std::normal_distribution<double> noise(0.0, 0.05);
  // [snippet:use-own-models]
  rangenav::ParticleFilter<double> filter(start);
  for (int step = 0; step < 20; ++step) {
    truth += 0.2;  // the robot moves 0.2 m per step
    filter.predict(RailMotion{}, 0.2, rng);
    filter.update(WallRange{}, 10.0 - truth + noise(rng));  // the range it measures
    if (filter.effective_sample_size() < 0.5 * static_cast<double>(filter.size()))
      filter.resample(rng);  // low-variance resampling when N_eff falls below N / 2
  }
  double estimate = 0;
  for (const auto& p : filter.particles())
    estimate += p.weight * p.state;
  // [snippet-end]
  CHECK(std::abs(estimate - truth) < 0.05);
}

// ---- Controller ---------------------------------------------------------------------------

// [snippet:own-controller]
// A controller is whatever turns the robot's pose and a goal into a velocity command (v, omega):
// there is no base class to derive from. This one turns towards a point and drives to it.
struct GoToPoint {
  rangenav::Point2d goal;
  double v_max = 0.4, gain = 1.5;  // m/s, 1/s

  std::pair<double, double> command(const rangenav::Pose2d& pose) const {
    const rangenav::Point2d to = goal - pose.position();
    const double heading_error = rangenav::angle_difference(std::atan2(to.y(), to.x()), pose.theta);
    const double v = std::abs(heading_error) > 0.5 ? 0.0 : std::min(v_max, gain * to.norm());
    return {v, std::clamp(2 * gain * heading_error, -1.5, 1.5)};
  }
};
// [snippet-end]

TEST_CASE("concepts: your own controller behind the reactive behaviours", "[docs]") {
  const rangenav::sim::Scene scene = rangenav::sim::apartment();
  rangenav::sim::DifferentialDriveRobot robot({}, scene.start);
  const rangenav::sim::LaserScanner2D laser;
  std::mt19937 rng(5);
  const rangenav::Point2d goal = scene.tour.front();
  std::size_t contacts = 0;
  // [snippet:use-own-controller]
  const GoToPoint controller{goal};
  rangenav::ReactiveBehaviours reactive(  // roadway speed scaling, stop and turn, free space
      {.roadway = {.half_width = 0.3, .dto_min = 0.3, .dto_max = 1.5, .v_max = 0.4}});
  while ((robot.pose().position() - goal).norm() > 0.05 && robot.time() < 60) {
    const auto [v, omega] = controller.command(robot.pose());
    const auto scan = laser.scan(scene.world, robot.pose(), rng);  // robot frame
    const rangenav::ReactiveCommand safe = reactive.apply(v, omega, scan);
    contacts += robot.step(scene.world, safe.v, safe.omega, rng).moved ? 0 : 1;
  }
  // [snippet-end]
  CHECK((robot.pose().position() - goal).norm() <= 0.05);
  CHECK(contacts == 0);
}
