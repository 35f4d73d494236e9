#pragma once
// The geometric-mapping pipeline of paper 004 (Fig. 1, §3.1-3.4):
//   key frames (a KeyFrameSelector on the odometry: only frames taken after the sensor moved
//   enough are processed at all) -> registration by the IncrementalMapper (voxel downsampling,
//   ICP of the downsampled frame against the point map with a DecayingDistanceRejector and a
//   FrustumRejector in model_in_data_frustum mode, so only the part of the map in the sensor's
//   field of view pairs; point-to-plane error against the map's PCA normals (PointToPlaneSolver,
//   beyond the paper's point-to-point: a planar kitchen front filling the view made point-to-
//   point pairs slide along it, 149 mm off on bench_geometric_map's frame); fitness rejection,
//   after which the next frame is tried; the aligned frame joins the SparsePointMap) -> the
//   full-resolution frame, transformed by the registration, is clustered (over image neighbours,
//   organized_euclidean_clusters, when the frame is organised; euclidean_clusters on a KdTree
//   otherwise) and its planes extracted per cluster (PlaneExtractor: iterative RANSAC,
//   least-squares refit, alpha-shape hull).
//   -> the planes are merged into the GeometricMap (mapping/geometric_map.hpp, §3.4).
// The stages are public so that a caller (or a benchmark) can run and time them one by one;
// process() runs them in order.

#include <algorithm>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/euclidean_clustering.hpp"
#include "rangenav/geometry/plane_extraction.hpp"
#include "rangenav/geometry/voxel_grid.hpp"
#include "rangenav/mapping/geometric_map.hpp"
#include "rangenav/mapping/incremental_mapper.hpp"
#include "rangenav/mapping/key_frame.hpp"
#include "rangenav/mapping/sparse_point_map.hpp"
#include "rangenav/registration/frustum.hpp"
#include "rangenav/registration/icp.hpp"
#include "rangenav/registration/point_to_plane_solver.hpp"
#include "rangenav/registration/rejectors.hpp"
#include "rangenav/search/kd_tree.hpp"

namespace rangenav {

/// Parameters of GeometricMapper: paper 004's pipeline from key frames to the geometric map.
struct GeometricMapperParams {
  /// Key-frame selection on the pose guess ("only ... if the robot moved to a certain extent").
  KeyFrameParams<double> key_frames{};
  /// Voxel filter applied to every key frame before registration (m).
  double voxel_leaf = 0.05;
  /// Point map density (eps_D of the sparse map, m).
  double point_map_epsilon = 0.05;
  /// Key frames join the point map voxel-filtered (as in the paper: "downsampling after
  /// registration reduces the size of the point map"): each voxel centroid with no map point
  /// within eps_D; false: the full-resolution frame, thinned at eps_D (300,000 map queries per
  /// 640 x 480 frame instead of a few thousand).
  bool point_map_downsampled = true;
  /// Neighbours of the PCA that gives each point-map point the normal of point-to-plane ICP.
  std::size_t normal_neighbors = 10;
  /// The sensor's range noise sigma (m); 0: not given. The registration adapts to it
  /// (registration_voxel_leaf(), registration_normal_neighbors()): a voxel_leaf voxel filter
  /// does not average noise away once the noise band (+-2.5 sigma) spans several voxel layers.
  /// Each voxel's centroid then stays in its layer and every sparsely hit tail voxel adds a
  /// centroid off the surface, so the point map becomes a thick layer whose PCA normals fail or
  /// tilt, and point-to-plane ICP drifts (measured in example 08 at sigma 0.02 m, 640 x 480:
  /// centroids 26-38 mm RMS off the true planes, 60 % of the map normals rejected, mean
  /// key-frame error 429 mm at seed 42, 473 / 810 mm at seeds 1 / 7; with the adaptation 13-19 mm).
  double range_noise = 0.0;

  /// The voxel leaf used for registration: voxel_leaf, at least 5 range_noise (the noise band
  /// then falls in about one voxel layer).
  [[nodiscard]] double registration_voxel_leaf() const {
    return std::max(voxel_leaf, 5 * range_noise);
  }
  /// The normals' PCA neighbours used for registration: normal_neighbors, and at least 30 above
  /// 1 cm of range noise, so that the PCA spans a surface patch several times wider than the
  /// map's remaining thickness (below 1 cm, 30 neighbours cost accuracy: 2.1 -> 5.0 mm mean
  /// key-frame error at sigma 0 in example 08).
  [[nodiscard]] std::size_t registration_normal_neighbors() const {
    return range_noise > 0.01 ? std::max<std::size_t>(normal_neighbors, 30) : normal_neighbors;
  }
  /// The sensor's field of view in its own frame (x along the optical axis); `frustum.pose` is
  /// ignored (the frame's points are in the sensor frame). Kinect-like by default.
  Frustum<3, double> frustum = [] {
    Frustum<3, double> f;
    f.near = 0.3;
    f.far = 6.0;
    f.horizontal_fov = 57.0 * std::numbers::pi / 180.0;
    f.vertical_fov = 43.0 * std::numbers::pi / 180.0;
    return f;
  }();
  /// The registration's ICP. Coarse-to-fine (IcpParams::coarse_points): the first iterations,
  /// while the pose still moves by centimetres, run on every k-th of the frame's voxel
  /// centroids (about 600 of them), then all centroids to convergence: on the
  /// bench_geometric_map key frame (3,781 centroids) 6,494 instead of 14,262 correspondence
  /// searches, the same pose error.
  /// registration_icp() turns it off above 1 cm of range noise.
  IcpParams<double> icp = [] {
    IcpParams<double> p;
    p.max_iterations = 30;
    p.check_degeneracy = false;
    p.coarse_points = 600;
    return p;
  }();
  /// The ICP parameters used for registration: icp, without the coarse subset above 1 cm of
  /// range noise. There the centroids of the wider registration voxels (registration_voxel_leaf)
  /// are fewer and each one matters: in example 08 at sigma 0.02 m the subset moved the
  /// key-frame poses (mean error 13.0 -> 16.8-18.6 mm at seed 42), at sigma 0 / 0.005 m and
  /// with objects it left them unchanged.
  [[nodiscard]] IcpParams<double> registration_icp() const {
    IcpParams<double> p = icp;
    if (range_noise > 0.01) p.coarse_points = 0;
    return p;
  }
  /// Pair distance threshold of the ICP, decaying per iteration from initial to final (m).
  double initial_match_distance = 0.3;
  double final_match_distance = 0.08;  ///< m, the threshold's final value
  /// Fitness rejection: a frame whose ICP fitness (matched / data points) is below this, or
  /// whose ICP found too few pairs, is not used (the IncrementalMapper's default).
  double min_fitness = 0.3;
  /// Plane extraction runs on the full-resolution aligned frame (0), or on the frame voxel-
  /// filtered at this leaf size (m) to bound its cost.
  double extraction_leaf = 0.0;
  /// Cluster an organised frame over image neighbours (see extract_planes); false: always with
  /// the kd-tree's radius queries.
  bool organized_clustering = true;
  /// Euclidean clustering before plane extraction (paper 004 §3.2).
  EuclideanClusteringParams clustering{0.05, 500, std::numeric_limits<std::size_t>::max()};
  PlaneExtractionParams planes{};  ///< RANSAC planes and their hulls
  /// Aggregation: the similarity thresholds t1, t2 of Eq. (6) and where Eq. (6b) compares the
  /// offsets (at the shapes' centroids by default, at the world origin as in the paper).
  GeometricMapParameters<double> merging{};

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where) const {
    key_frames.validate();
    detail::require_positive(where, "params.voxel_leaf", voxel_leaf);
    detail::require_positive(where, "params.point_map_epsilon", point_map_epsilon);
    detail::require_non_negative(where, "params.range_noise", range_noise);
    if (normal_neighbors < 3)
      detail::throw_invalid_argument(where, "params.normal_neighbors", normal_neighbors,
                                     "must be >= 3");
    frustum.validate();
    icp.validate();
    DecayingDistanceRejector<double>{initial_match_distance, final_match_distance, 0.7}.validate();
    if (!(min_fitness >= 0 && min_fitness <= 1))
      detail::throw_invalid_argument(where, "params.min_fitness", min_fitness, "must be in [0, 1]");
    detail::require_non_negative(where, "params.extraction_leaf", extraction_leaf);
    clustering.validate(where);
    planes.validate(where);
  }
};

/// What happened to one frame.
struct GeometricFrameReport {
  bool key_frame = false;   ///< far enough from the last key frame to be processed
  bool registered = false;  ///< aligned (or the first frame) and passed the fitness test
  Transform3d pose = Transform3d::Identity();  ///< sensor -> world after registration
  std::optional<IcpResult<3, double>> icp;     ///< the alignment (none for the first frame)
  std::size_t downsampled_points = 0;  ///< points the registration saw after the voxel filter
  std::size_t extraction_points = 0;   ///< finite points the plane extraction saw
  std::size_t clusters = 0;            ///< clusters the plane extraction ran on
  std::vector<ExtractedPlane> planes;  ///< in world coordinates
  std::size_t merged = 0;              ///< planes merged into existing map shapes
};

/// Registration and plane extraction of paper 004's pipeline (see the file comment). Owns the
/// point map; one object per sequence and thread.
class GeometricMapper {
 public:
  /// The frustum rejector of the registration.
  using Rejector = FrustumRejector<3, double>;
  /// Point-to-plane ICP against the point map's normals (see the file comment).
  using IcpType = BasicIcp<3, double, PointToPlaneSolver<3, double>,
                           DecayingDistanceRejector<double>, Rejector>;

  /// A mapper with these parameters; throws invalid_argument for invalid ones.
  explicit GeometricMapper(const GeometricMapperParams& params = {})
      : params_(validated(params)),
        selector_(params_.key_frames),
        registration_(registration_params(params_)),
        extractor_(params_.planes),
        map_(params_.merging) {
    auto& icp = registration_.icp;
    icp.params = params_.registration_icp();
    icp.rejector<DecayingDistanceRejector<double>>() = {params_.initial_match_distance,
                                                        params_.final_match_distance, 0.7};
    Frustum<3, double> f = params_.frustum;
    f.pose = Transform3d::Identity();  // the data sensor sits at the data frame's origin
    icp.rejector<Rejector>() = Rejector(f, Rejector::Mode::model_in_data_frustum);
  }

  /// The parameters.
  [[nodiscard]] const GeometricMapperParams& params() const { return params_; }
  /// The point map, in the frame of the first key frame's odometry pose, map_origin().
  [[nodiscard]] const SparsePointMap<3, double>& point_map() const { return registration_.map(); }
  /// The pose of the point map's frame in the world (identity before the first key frame).
  [[nodiscard]] Transform3d map_origin() const { return origin_.value_or(Transform3d::Identity()); }
  /// The geometric map (the editing API of GeometricMap works on it).
  [[nodiscard]] const GeometricMap<double>& map() const { return map_; }
  /// The geometric map, for editing.
  [[nodiscard]] GeometricMap<double>& map() { return map_; }
  /// Key frames registered so far.
  [[nodiscard]] std::size_t key_frames() const { return key_frames_; }

  /// Runs the pipeline on one frame: `cloud` in the sensor frame (NaN points allowed, e.g. an
  /// organised depth image), `odometry` the sensor -> world pose by odometry. Returns the report;
  /// report.planes holds the key frame's planes when it was registered.
  template <PointCloudOf<3> C, class Engine>
  GeometricFrameReport process(const C& cloud, const Transform3d& odometry, Engine& rng) {
    GeometricFrameReport report;
    report.pose = odometry;
    report.key_frame = selector_.is_key_frame(odometry);
    if (!report.key_frame) return report;
    if (!register_frame(cloud, odometry, report)) return report;
    extract_planes(cloud, report, rng);
    merge_planes(report);
    return report;
  }

  /// Stage 1: registration of a key frame (see the file comment); the guess is the last
  /// registered pose composed with the odometry increment. Returns report.registered; a frame
  /// that fails the fitness test is not recorded as a key frame, so the next one is tried.
  template <PointCloudOf<3> C>
  bool register_frame(const C& cloud, const Transform3d& odometry, GeometricFrameReport& report) {
    // The IncrementalMapper's map frame is its first frame's; the odometry is handed to it
    // relative to the first key frame, so that its poses are world poses after `origin_`.
    if (!origin_) origin_ = odometry;
    const Transform3d relative = origin_->inverse(Eigen::Isometry) * odometry;
    const MapperUpdate<3, double> update = registration_.process(cloud, relative);
    report.pose = *origin_ * update.pose;
    report.icp = update.icp;
    report.downsampled_points = update.icp ? update.icp->data_count : 0;
    report.registered = update.registration_accepted;
    if (report.registered) {
      selector_.accept(odometry);
      ++key_frames_;
    }
    return report.registered;
  }

  /// Stage 2: Euclidean clustering and plane extraction on the aligned full-resolution frame
  /// (or its extraction_leaf voxel filter); appends to report.planes. An organised frame (a
  /// `cloud.width` x `cloud.height` image with width * height == size, NaN where no return) is
  /// clustered over image neighbours (organized_euclidean_clusters, one O(n) pass); any other
  /// cloud, and the voxel-filtered frame, by radius queries on a kd-tree (euclidean_clusters).
  template <PointCloudOf<3> C, class Engine>
  void extract_planes(const C& cloud, GeometricFrameReport& report, Engine& rng) {
    const std::size_t n = traits::size(cloud);
    std::size_t width = 0, height = 0;
    if constexpr (requires {
                    { cloud.width } -> std::convertible_to<std::size_t>;
                    { cloud.height } -> std::convertible_to<std::size_t>;
                  }) {
      width = cloud.width;
      height = cloud.height;
    }
    const bool organized = params_.organized_clustering && params_.extraction_leaf == 0 &&
                           height > 1 && width * height == n;
    extractor_.set_viewpoint(Point3d(report.pose.translation()));
    extractor_.reserve(n);  // a cluster holds at most the frame: no regrowth from frame to frame
    if constexpr (requires { std::span<const Point3d>(cloud.points); }) {
      if (organized) {
        // Clustered in the sensor frame (distances do not change under the rigid pose), and
        // each cluster's points transformed as the extractor copies them: the frame is not
        // copied into the world as a whole.
        const std::span<const Point3d> points(cloud.points);
        std::size_t finite = 0;
        const auto clusters =
            organized_euclidean_clusters(points, width, height, params_.clustering, &finite);
        report.extraction_points = finite;
        if (finite < 3) return;
        report.clusters = clusters.size();
        for (const auto& cluster : clusters)
          extractor_.extract(points, cluster, report.pose, rng, report.planes);
        return;
      }
    }
    // The frame in the world: x_w = R x + t. A non-finite coordinate makes every coordinate of
    // R x + t non-finite (inf * 0 is NaN), so the organised frame is transformed as it is, NaN
    // pixels included, and counted by one coordinate.
    const Eigen::Matrix3d rotation = report.pose.linear();
    const Point3d translation = report.pose.translation();
    std::size_t finite = 0;
    if (organized) {
      world_.resize(n);
      for (std::size_t i = 0; i < n; ++i) {
        const Point3d w = rotation * traits::point(cloud, i).template cast<double>() + translation;
        world_[i] = w;
        finite += std::isfinite(w.x()) ? 1 : 0;
      }
    } else {
      world_.clear();
      world_.reserve(n);
      for (std::size_t i = 0; i < n; ++i) {
        const Point3d p = traits::point(cloud, i).template cast<double>();
        if (p.allFinite()) world_.push_back(rotation * p + translation);
      }
      finite = world_.size();
    }
    if (organized) {
      report.extraction_points = finite;
      if (finite < 3) return;
      const std::span<const Point3d> points(world_);
      const auto clusters = organized_euclidean_clusters(points, width, height, params_.clustering);
      report.clusters = clusters.size();
      for (const auto& cluster : clusters)
        extractor_.extract(points, cluster, rng, report.planes);
      return;
    }
    if (params_.extraction_leaf > 0) world_ = voxel_downsample(world_, params_.extraction_leaf);
    report.extraction_points = world_.size();
    if (world_.size() < 3) return;
    const KdTree<3, double> tree(std::move(world_));
    const auto clusters = euclidean_clusters(tree, params_.clustering);
    report.clusters = clusters.size();
    for (const auto& cluster : clusters)
      extractor_.extract(std::span<const Point3d>(tree.points()), cluster, rng, report.planes);
  }

  /// Stage 3: inserts the key frame's planes into the geometric map (Eq. 6-12); sets and
  /// returns report.merged.
  std::size_t merge_planes(GeometricFrameReport& report) {
    report.merged = 0;
    for (const ExtractedPlane& p : report.planes)
      report.merged += map_.insert(p.shape).merged > 0 ? 1 : 0;
    return report.merged;
  }

 private:
  static const GeometricMapperParams& validated(const GeometricMapperParams& p) {
    p.validate("GeometricMapper");
    return p;
  }
  static IncrementalMapperParams<double> registration_params(const GeometricMapperParams& p) {
    IncrementalMapperParams<double> r;
    r.key_frames = {0.0, 0.0};  // every registered key frame joins the point map
    r.map.epsilon_d = p.point_map_epsilon;
    // The point-to-plane normals: PCA of the map points within 4 eps_D.
    r.map.normal_neighbors = p.registration_normal_neighbors();
    r.map.normal_radius = 4 * p.point_map_epsilon;
    r.min_fitness = p.min_fitness;
    r.final_match_distance = p.final_match_distance;
    r.voxel_size = p.registration_voxel_leaf();
    r.insert_downsampled = p.point_map_downsampled;
    // The voxel filter already leaves one point per voxel; thinning those among themselves at
    // eps_D as well would drop about a fifth of them (neighbouring centroids are often closer
    // than eps_D), and the sparser map registered worse in example 08 (mean key-frame error
    // 8.5 mm against 5.7 mm at sigma 0, 8 seeds).
    if (p.point_map_downsampled) r.map.deduplicate_within_scan = false;
    return r;
  }

  GeometricMapperParams params_;
  KeyFrameSelector<3, double> selector_;
  IncrementalMapper<3, double, IcpType> registration_;
  PlaneExtractor extractor_;
  GeometricMap<double> map_;
  std::size_t key_frames_ = 0;
  std::optional<Transform3d> origin_;
  std::vector<Point3d> world_;
};

}  // namespace rangenav
