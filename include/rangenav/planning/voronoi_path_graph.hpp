#pragma once
// The Voronoi path graph of paper 000 §4: the Voronoi diagram of the map points, built with
// Fortune's sweep (Boost.Polygon's voronoi_builder), pruned (1) of every edge that lies outside of
// or crosses the convex hull of the map points (Boost.Geometry convex_hull) and (2) of every edge
// whose clearance is below half the robot's width plus a safety margin (5 cm in the paper).
//
// Nodes are the Voronoi vertices that keep at least one edge; every edge knows its length and its
// clearance, the smallest distance from any point of the edge to the nearest map point. For point
// sites an edge lies on the bisector of its two generating sites p, q, so that distance is
// sqrt(dist(m, edge)^2 + |p - q|^2 / 4) with m the midpoint of p and q.
//
// Edges can be marked blocked (e.g. a scan shows an obstacle on them) and a planner re-plans
// without rebuilding the diagram; revision() changes whenever the blocked set does.
//
// Boost.Polygon works on 32-bit integer coordinates: the input is snapped to a grid of settable
// resolution (default 1 mm) and duplicate grid points are removed; sites() returns the snapped
// points, and every distance is measured against them.

#include <algorithm>
#include <array>
#include <boost/geometry/algorithms/convex_hull.hpp>
#include <boost/geometry/algorithms/covered_by.hpp>
#include <boost/geometry/geometries/multi_point.hpp>
#include <boost/geometry/geometries/point_xy.hpp>
#include <boost/geometry/geometries/polygon.hpp>
#include <boost/geometry/strategies/strategies.hpp>
#include <boost/polygon/voronoi.hpp>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/integer_grid.hpp"

namespace rangenav {

/// Parameters of VoronoiPathGraph; the defaults are paper 000's.
struct VoronoiPathGraphParams {
  /// Grid the input is snapped to before Fortune's sweep (m); Boost.Polygon needs integers.
  double resolution = 0.001;
  /// Full width of the robot (m); Kurt3D's 33 cm (paper 003 §1.2) by default.
  double robot_width = 0.33;
  /// Safety distance added to half the robot width ("e.g. 5 cm", paper 000 §4).
  double safety_margin = 0.05;
  /// Pruning step 1: drop edges outside of or crossing the convex hull of the map points.
  bool prune_outside_hull = true;
  /// Pruning step 2: drop edges whose clearance is below required_clearance().
  bool prune_by_clearance = true;

  /// Half the robot width plus the safety margin (m).
  [[nodiscard]] double required_clearance() const { return robot_width / 2 + safety_margin; }

  /// Throws invalid_argument naming the first invalid parameter; `where` names the caller.
  void validate(std::string_view where) const {
    detail::require_positive(where, "params.resolution", resolution);
    detail::require_non_negative(where, "params.robot_width", robot_width);
    detail::require_non_negative(where, "params.safety_margin", safety_margin);
  }
};

/// Counts of what the construction kept and dropped.
struct VoronoiPathGraphStats {
  std::size_t input_points{0};      ///< points handed in
  std::size_t sites{0};             ///< distinct grid points after snapping
  std::size_t diagram_vertices{0};  ///< vertices of the full Voronoi diagram
  std::size_t diagram_edges{0};     ///< edges (twin pairs) of the full diagram, infinite included
  std::size_t pruned_by_hull{0};    ///< edges dropped by pruning step 1 (infinite ones included)
  std::size_t pruned_by_clearance{0};  ///< edges dropped by pruning step 2
};

/// The Voronoi diagram of a 2D point map, pruned to the edges a robot fits through (paper 000
/// §4): nodes are Voronoi vertices, edges carry their length and clearance.
class VoronoiPathGraph {
 public:
  /// A node or edge index.
  using index_type = std::uint32_t;
  /// "No node / no edge".
  static constexpr index_type npos = std::numeric_limits<index_type>::max();

  /// A graph node: a Voronoi vertex.
  struct Node {
    Point2d position;  ///< the Voronoi vertex (m)
    double clearance;  ///< distance to the nearest site (m)
  };

  /// A graph edge: a pruned Voronoi edge between two vertices.
  struct Edge {
    index_type from;    ///< node index
    index_type to;      ///< node index
    double length;      ///< |to - from| (m)
    double clearance;   ///< smallest distance from the edge to the nearest site (m)
    index_type site_a;  ///< one of the two sites the edge bisects (an index into sites())
    index_type site_b;  ///< the other site
  };

  VoronoiPathGraph() = default;

  /// Builds the pruned graph of the 2D points of `cloud` (any PointCloud of dimension 2).
  /// Throws invalid_argument for an empty cloud, a non-finite point, a point that does not fit the
  /// 32-bit grid at params.resolution, or bad parameters.
  template <PointCloudOf<2> C>
  explicit VoronoiPathGraph(const C& cloud, const VoronoiPathGraphParams& params = {})
      : params_(params) {
    constexpr std::string_view where = "VoronoiPathGraph";
    params_.validate(where);
    const std::size_t n = traits::size(cloud);
    if (n == 0) detail::throw_invalid(where, "argument 'cloud' is empty");
    stats_.input_points = n;
    const IntegerGrid snapper{params_.resolution};
    std::vector<std::array<std::int32_t, 2>> grid(n);
    for (std::size_t i = 0; i < n; ++i)
      grid[i] = snapper.snap(traits::point(cloud, i).template cast<double>(), where,
                             "cloud[" + std::to_string(i) + "]");
    std::sort(grid.begin(), grid.end());
    grid.erase(std::unique(grid.begin(), grid.end()), grid.end());
    build(grid);
  }

  /// The parameters.
  [[nodiscard]] const VoronoiPathGraphParams& params() const { return params_; }
  /// What the build did (points, sites, edges pruned).
  [[nodiscard]] const VoronoiPathGraphStats& stats() const { return stats_; }
  /// The snapped, de-duplicated map points (m), in lexicographic order.
  [[nodiscard]] const std::vector<Point2d>& sites() const { return sites_; }
  /// The convex hull of the sites (m), counter-clockwise, closed (first point repeated).
  [[nodiscard]] const std::vector<Point2d>& hull() const { return hull_; }
  /// The graph's nodes.
  [[nodiscard]] const std::vector<Node>& nodes() const { return nodes_; }
  /// The graph's edges (undirected).
  [[nodiscard]] const std::vector<Edge>& edges() const { return edges_; }
  /// Number of nodes.
  [[nodiscard]] std::size_t node_count() const { return nodes_.size(); }
  /// Number of edges.
  [[nodiscard]] std::size_t edge_count() const { return edges_.size(); }
  /// True when no edge survived the pruning.
  [[nodiscard]] bool empty() const { return edges_.empty(); }

  /// The edges incident to `node` (indices into edges()).
  [[nodiscard]] std::span<const index_type> incident_edges(index_type node) const {
    return {incident_.data() + offsets_[node], incident_.data() + offsets_[node + 1]};
  }
  /// The node at the other end of `edge` from `node`.
  [[nodiscard]] index_type other_node(index_type edge, index_type node) const {
    const Edge& e = edges_[edge];
    return e.from == node ? e.to : e.from;
  }

  /// Marks an edge not traversable (or traversable again). Throws invalid_argument for an index
  /// out of range.
  void set_blocked(index_type edge, bool blocked = true) {
    if (edge >= edges_.size())
      detail::throw_invalid_argument("VoronoiPathGraph::set_blocked", "edge", edge,
                                     "must be < edge_count() = " + std::to_string(edges_.size()));
    if ((blocked_[edge] != 0) != blocked) {
      blocked_[edge] = blocked ? 1 : 0;
      blocked_count_ += blocked ? 1 : std::size_t(-1);
      ++revision_;
    }
  }
  /// Makes every edge traversable again.
  void clear_blocked() {
    if (blocked_count_ == 0) return;
    std::fill(blocked_.begin(), blocked_.end(), 0);
    blocked_count_ = 0;
    ++revision_;
  }
  /// True when `edge` is marked blocked.
  [[nodiscard]] bool is_blocked(index_type edge) const { return blocked_[edge] != 0; }
  /// Number of blocked edges.
  [[nodiscard]] std::size_t blocked_count() const { return blocked_count_; }
  /// Changes whenever the set of blocked edges changes (planners cache per revision).
  [[nodiscard]] std::uint64_t revision() const { return revision_; }

 private:
  using grid_point = std::array<std::int32_t, 2>;
  using hull_point = boost::geometry::model::d2::point_xy<double>;
  using hull_polygon = boost::geometry::model::polygon<hull_point, false, true>;  // ccw, closed

  void build(const std::vector<grid_point>& grid) {
    namespace bp = boost::polygon;
    namespace bg = boost::geometry;
    const double res = params_.resolution;
    stats_.sites = grid.size();
    sites_.resize(grid.size());
    for (std::size_t i = 0; i < grid.size(); ++i)
      sites_[i] = Point2d(grid[i][0] * res, grid[i][1] * res);

    // Fortune's sweep (paper 000 §4, [3]) on the integer grid.
    bp::voronoi_builder<std::int32_t> builder;
    for (const grid_point& g : grid)
      builder.insert_point(g[0], g[1]);
    bp::voronoi_diagram<double> vd;
    builder.construct(&vd);
    stats_.diagram_vertices = vd.num_vertices();
    stats_.diagram_edges = vd.num_edges() / 2;

    // Convex hull of the sites (grid units) with Boost.Geometry's convex_hull (Graham / Andrew).
    // A site lies on the hull iff its Voronoi cell is unbounded, so only the sites of infinite
    // edges are handed in: the same hull, without sorting all n points a second time.
    hull_polygon hull;
    {
      std::vector<std::uint8_t> on_hull(grid.size(), grid.size() < 3 ? 1 : 0);
      for (std::size_t k = 0; k + 1 < vd.edges().size(); k += 2) {
        const auto& e = vd.edges()[k];
        if (e.is_infinite()) {
          on_hull[e.cell()->source_index()] = 1;
          on_hull[e.twin()->cell()->source_index()] = 1;
        }
      }
      bg::model::multi_point<hull_point> mp;
      for (std::size_t i = 0; i < grid.size(); ++i)
        if (on_hull[i]) mp.emplace_back(double(grid[i][0]), double(grid[i][1]));
      bg::convex_hull(mp, hull);
    }
    hull_.clear();
    for (const hull_point& p : hull.outer())
      hull_.emplace_back(p.x() * res, p.y() * res);
    // A hull with fewer than 3 distinct corners has no interior: nothing lies inside it.
    const bool hull_has_area = hull.outer().size() >= 4;

    // Which Voronoi vertices lie inside (or on) the hull; edges between two such vertices lie
    // inside too, because the hull is convex, and edges with an outside end cross or leave it.
    const auto& vertices = vd.vertices();
    std::vector<index_type> node_of(vertices.size(), npos);
    std::vector<std::uint8_t> inside(vertices.size(), 1);
    if (params_.prune_outside_hull)
      for (std::size_t i = 0; i < vertices.size(); ++i)
        inside[i] =
            hull_has_area && bg::covered_by(hull_point(vertices[i].x(), vertices[i].y()), hull);

    const double required = params_.prune_by_clearance ? params_.required_clearance() / res : 0.0;
    const double required_sq = required * required;
    const auto* vertex0 = vertices.data();
    const auto& all_edges = vd.edges();
    nodes_.clear();
    edges_.clear();
    for (std::size_t k = 0; k + 1 < all_edges.size(); k += 2) {  // twins are stored side by side
      const auto& e = all_edges[k];
      const auto* va = e.vertex0();
      const auto* vb = e.vertex1();
      if (va == nullptr || vb == nullptr) {  // infinite edges leave every hull
        ++stats_.pruned_by_hull;
        continue;
      }
      const auto ia = static_cast<std::size_t>(va - vertex0);
      const auto ib = static_cast<std::size_t>(vb - vertex0);
      if (!inside[ia] || !inside[ib]) {
        ++stats_.pruned_by_hull;
        continue;
      }
      const auto sa = static_cast<index_type>(e.cell()->source_index());
      const auto sb = static_cast<index_type>(e.twin()->cell()->source_index());
      const Eigen::Vector2d a(va->x(), va->y()), b(vb->x(), vb->y());
      const Eigen::Vector2d p(grid[sa][0], grid[sa][1]), q(grid[sb][0], grid[sb][1]);
      const double clearance_sq =
          segment_point_distance_sq(a, b, (p + q) / 2) + (p - q).squaredNorm() / 4;
      if (clearance_sq < required_sq) {
        ++stats_.pruned_by_clearance;
        continue;
      }
      const index_type na = node_for(node_of, ia, a, p, res);
      const index_type nb = node_for(node_of, ib, b, p, res);
      edges_.push_back({na, nb, (b - a).norm() * res, std::sqrt(clearance_sq) * res, sa, sb});
    }

    // Compressed adjacency: incident_edges(n) = incident_[offsets_[n] .. offsets_[n + 1]).
    offsets_.assign(nodes_.size() + 1, 0);
    for (const Edge& e : edges_) {
      ++offsets_[e.from + 1];
      ++offsets_[e.to + 1];
    }
    for (std::size_t i = 1; i < offsets_.size(); ++i)
      offsets_[i] += offsets_[i - 1];
    incident_.resize(offsets_.back());
    std::vector<index_type> fill(offsets_.begin(), offsets_.end() - 1);
    for (std::size_t i = 0; i < edges_.size(); ++i) {
      incident_[fill[edges_[i].from]++] = static_cast<index_type>(i);
      incident_[fill[edges_[i].to]++] = static_cast<index_type>(i);
    }
    blocked_.assign(edges_.size(), 0);
    blocked_count_ = 0;
  }

  index_type node_for(std::vector<index_type>& node_of, std::size_t vertex,
                      const Eigen::Vector2d& position, const Eigen::Vector2d& site, double res) {
    if (node_of[vertex] == npos) {
      node_of[vertex] = static_cast<index_type>(nodes_.size());
      nodes_.push_back({position * res, (position - site).norm() * res});
    }
    return node_of[vertex];
  }

  static double segment_point_distance_sq(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                          const Eigen::Vector2d& m) {
    const Eigen::Vector2d ab = b - a;
    const double len_sq = ab.squaredNorm();
    const double t = len_sq > 0 ? std::clamp((m - a).dot(ab) / len_sq, 0.0, 1.0) : 0.0;
    return (a + t * ab - m).squaredNorm();
  }

  VoronoiPathGraphParams params_{};
  VoronoiPathGraphStats stats_{};
  std::vector<Point2d> sites_;
  std::vector<Point2d> hull_;
  std::vector<Node> nodes_;
  std::vector<Edge> edges_;
  std::vector<index_type> offsets_{0};
  std::vector<index_type> incident_;
  std::vector<std::uint8_t> blocked_;
  std::size_t blocked_count_{0};
  std::uint64_t revision_{0};
};

}  // namespace rangenav
