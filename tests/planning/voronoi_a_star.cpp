// VoronoiPathGraph and AStar against ground truth: brute-force clearances on random and real maps,
// the pruning invariants of paper 000 §4, A* against Boost.Graph's Dijkstra, start/goal
// attachment (§4) and re-planning around blocked edges.

#include <algorithm>
#include <boost/graph/adjacency_list.hpp>
#include <boost/graph/dijkstra_shortest_paths.hpp>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>
#include <type_traits>
#include <vector>

#include "rangenav/io/pgm.hpp"
#include "rangenav/planning/a_star.hpp"
#include "rangenav/planning/voronoi_path_graph.hpp"
#include "rangenav/scan/laser_scan.hpp"
#include "test_support.hpp"

using rangenav::AStar;
using rangenav::Point2d;
using rangenav::VoronoiPathGraph;
using rangenav::VoronoiPathGraphParams;
using index_type = VoronoiPathGraph::index_type;

namespace {

double point_segment_distance(const Point2d& p, const Point2d& a, const Point2d& b) {
  const Point2d ab = b - a;
  const double len_sq = ab.squaredNorm();
  const double t = len_sq > 0 ? std::clamp((p - a).dot(ab) / len_sq, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

// min over the edge of the distance to the nearest site = min over sites of the distance to the
// edge (the two minima commute): exact, O(sites) per edge.
double brute_force_clearance(const std::vector<Point2d>& sites, const Point2d& a,
                             const Point2d& b) {
  double best = std::numeric_limits<double>::infinity();
  for (const Point2d& s : sites)
    best = std::min(best, point_segment_distance(s, a, b));
  return best;
}

bool inside_convex_ccw(const std::vector<Point2d>& hull, const Point2d& p, double tol) {
  for (std::size_t i = 0; i + 1 < hull.size(); ++i) {
    const Point2d e = hull[i + 1] - hull[i], d = p - hull[i];
    if (e.x() * d.y() - e.y() * d.x() < -tol * e.norm()) return false;
  }
  return true;
}

std::vector<Point2d> random_points(std::size_t n, double size, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, size);
  std::vector<Point2d> pts(n);
  for (auto& p : pts) {
    const double x = u(rng);  // sequenced: the order of argument evaluation is unspecified
    p = Point2d(x, u(rng));
  }
  return pts;
}

// A square building of rooms x rooms rooms of `room` metres, walls sampled every `step` metres,
// with a 1 m door in the middle of every interior wall: many loops for the planner.
std::vector<Point2d> rooms_map(int rooms, double room, double step) {
  std::vector<Point2d> pts;
  const double size = rooms * room;
  auto door = [&](double along, bool outer) {
    const double in_room = std::fmod(along, room);
    return !outer && std::abs(in_room - room / 2) < 0.5;
  };
  const int samples = static_cast<int>(std::lround(size / step));
  for (int line = 0; line <= rooms; ++line) {
    const double c = line * room;
    const bool outer = line == 0 || line == rooms;
    for (int k = 0; k <= samples; ++k) {
      const double t = k * step;
      if (!door(t, outer)) {
        pts.emplace_back(c, t);
        pts.emplace_back(t, c);
      }
    }
  }
  return pts;
}

void check_clearances_against_brute_force(const VoronoiPathGraph& graph, std::size_t max_checks) {
  const auto& sites = graph.sites();
  const auto& edges = graph.edges();
  const double tol = 1e-6;
  REQUIRE(!edges.empty());
  const std::size_t stride = std::max<std::size_t>(1, edges.size() / max_checks);
  for (std::size_t i = 0; i < edges.size(); i += stride) {
    const auto& e = edges[i];
    const Point2d a = graph.nodes()[e.from].position, b = graph.nodes()[e.to].position;
    REQUIRE(e.clearance == Approx(brute_force_clearance(sites, a, b)).margin(tol));
    REQUIRE(e.length == Approx((b - a).norm()).margin(1e-12));
  }
  const std::size_t node_stride = std::max<std::size_t>(1, graph.node_count() / max_checks);
  for (std::size_t i = 0; i < graph.node_count(); i += node_stride) {
    const auto& n = graph.nodes()[i];
    REQUIRE(n.clearance ==
            Approx(brute_force_clearance(sites, n.position, n.position)).margin(tol));
  }
}

// Boost.Graph's Dijkstra over the traversable edges: the reference for A*.
std::vector<double> dijkstra(const VoronoiPathGraph& graph, index_type from) {
  using G = boost::adjacency_list<boost::vecS, boost::vecS, boost::undirectedS, boost::no_property,
                                  boost::property<boost::edge_weight_t, double>>;
  G g(graph.node_count());
  for (std::size_t i = 0; i < graph.edge_count(); ++i) {
    if (graph.is_blocked(static_cast<index_type>(i))) continue;
    const auto& e = graph.edges()[i];
    boost::add_edge(e.from, e.to, e.length, g);
  }
  std::vector<double> dist(graph.node_count());
  boost::dijkstra_shortest_paths(g, from, boost::distance_map(dist.data()));
  return dist;
}

}  // namespace

TEST_CASE("voronoi graph: edge and node clearances equal brute force on random maps") {
  for (unsigned seed : {1u, 2u, 3u}) {
    const auto pts = random_points(400, 10.0, seed);
    VoronoiPathGraphParams params;
    params.prune_by_clearance = false;
    const VoronoiPathGraph graph(pts, params);
    CHECK(graph.stats().input_points == 400);
    CHECK(graph.stats().sites == 400);
    CHECK(graph.stats().pruned_by_clearance == 0);
    // Euler: a Delaunay triangulation of n points with h on the hull has 2n - 2 - h triangles,
    // i.e. that many Voronoi vertices (in general position).
    const std::size_t h = graph.hull().size() - 1;
    CHECK(graph.stats().diagram_vertices == 2 * 400 - 2 - h);
    check_clearances_against_brute_force(graph, 100000);
  }
}

TEST_CASE("voronoi graph: pruning keeps exactly the clear edges inside the hull") {
  const auto pts = random_points(600, 8.0, 7);
  VoronoiPathGraphParams all;
  all.prune_by_clearance = false;
  all.prune_outside_hull = false;
  const VoronoiPathGraph full(pts, all);
  VoronoiPathGraphParams params;
  params.robot_width = 0.2;
  params.safety_margin = 0.05;
  const double required = params.required_clearance();
  CHECK(required == Approx(0.15));
  const VoronoiPathGraph pruned(pts, params);

  std::size_t expected = 0;
  for (const auto& e : full.edges())
    if (e.clearance >= required &&
        inside_convex_ccw(pruned.hull(), full.nodes()[e.from].position, 1e-9) &&
        inside_convex_ccw(pruned.hull(), full.nodes()[e.to].position, 1e-9))
      ++expected;
  CHECK(pruned.edge_count() == expected);
  CHECK(pruned.edge_count() > 0);
  CHECK(pruned.edge_count() < full.edge_count());
  CHECK(pruned.stats().pruned_by_hull + pruned.stats().pruned_by_clearance + pruned.edge_count() ==
        pruned.stats().diagram_edges);
  for (const auto& e : pruned.edges()) {
    const Point2d a = pruned.nodes()[e.from].position, b = pruned.nodes()[e.to].position;
    REQUIRE(brute_force_clearance(pruned.sites(), a, b) >= required - 1e-9);
    REQUIRE(inside_convex_ccw(pruned.hull(), a, 1e-9));
    REQUIRE(inside_convex_ccw(pruned.hull(), b, 1e-9));
  }
  // Every node keeps an edge.
  for (index_type i = 0; i < pruned.node_count(); ++i)
    REQUIRE(!pruned.incident_edges(i).empty());
  // hull() is the convex hull of all the sites (computed from the sites of unbounded Voronoi
  // cells only): closed, counter-clockwise and convex, its corners are sites, and it contains every
  // site. A convex polygon with those properties is the convex hull.
  const auto& hull = pruned.hull();
  REQUIRE(hull.size() >= 4);
  CHECK(hull.front() == hull.back());
  for (std::size_t i = 0; i + 1 < hull.size(); ++i) {
    CHECK(std::find(pruned.sites().begin(), pruned.sites().end(), hull[i]) != pruned.sites().end());
    const Point2d e = hull[i + 1] - hull[i];
    const Point2d f = hull[(i + 2) % (hull.size() - 1)] - hull[i + 1];
    CHECK(e.x() * f.y() - e.y() * f.x() > 0.0);  // turns left at every corner
  }
  for (const Point2d& site : pruned.sites())
    REQUIRE(inside_convex_ccw(hull, site, 1e-9));
}

TEST_CASE("voronoi graph: real occupancy maps (EVG-THIN test1 / test2)") {
  for (const char* name : {"evg-thin/test1.pgm", "evg-thin/test2.pgm"}) {
    const auto path = rangenav::test::data_file_or_skip(name);
    if (path.empty()) continue;
    const auto image = rangenav::io::read_pgm(path);
    const auto cells = rangenav::io::occupied_cells(image, 0.05);
    REQUIRE(cells.size() == (std::string(name).find("test1") != std::string::npos ? 6532u : 8490u));
    VoronoiPathGraphParams params;
    params.prune_by_clearance = false;
    const VoronoiPathGraph full(cells, params);
    check_clearances_against_brute_force(full, 400);

    const VoronoiPathGraph pruned(cells);  // Kurt3D width, 5 cm margin: 0.215 m
    REQUIRE(pruned.edge_count() > 0);
    CHECK(pruned.edge_count() < full.edge_count());
    // Every edge of the pruned graph keeps the clearance, and its clearance is the distance to
    // the nearest of all sites. Exact: the sites outside the edge's bounding box grown by
    // `reach` are farther than reach, so when one inside lies within reach it is the nearest
    // (the sites are sorted by x to skip the far ones).
    std::vector<Point2d> by_x = pruned.sites();
    std::sort(by_x.begin(), by_x.end(),
              [](const Point2d& p, const Point2d& q) { return p.x() < q.x(); });
    const double required = 0.215, reach = 3.0;
    std::size_t compared = 0;
    for (const auto& e : pruned.edges()) {
      const Point2d a = pruned.nodes()[e.from].position, b = pruned.nodes()[e.to].position;
      const auto lo = std::partition_point(by_x.begin(), by_x.end(), [&](const Point2d& p) {
        return p.x() < std::min(a.x(), b.x()) - reach;
      });
      double nearest = std::numeric_limits<double>::infinity();
      for (auto it = lo; it != by_x.end() && it->x() <= std::max(a.x(), b.x()) + reach; ++it)
        if (it->y() >= std::min(a.y(), b.y()) - reach && it->y() <= std::max(a.y(), b.y()) + reach)
          nearest = std::min(nearest, point_segment_distance(*it, a, b));
      REQUIRE(nearest >= required - 1e-9);
      if (nearest <= reach) {
        REQUIRE(e.clearance == Approx(nearest).margin(1e-6));
        ++compared;
      }
    }
    CHECK(compared > pruned.edge_count() / 2);
  }
}

TEST_CASE("voronoi graph: snapping, duplicates and degenerate input") {
  // Points within the grid resolution collapse into one site.
  std::vector<Point2d> pts{{0, 0}, {0.0002, 0.0001}, {4, 0}, {0, 4}, {4, 4}, {4.0004, 4}};
  const VoronoiPathGraph g(pts, {.resolution = 0.001, .robot_width = 0.0, .safety_margin = 0.0});
  CHECK(g.stats().input_points == 6);
  CHECK(g.stats().sites == 4);
  CHECK(g.sites()[3].x() == Approx(4.0));
  // Four co-circular corners: one Voronoi vertex at the centre; its four edges leave the hull.
  CHECK(g.edge_count() == 0);

  // Collinear points: no vertex, nothing inside the (flat) hull.
  std::vector<Point2d> line{{0, 0}, {1, 0}, {2, 0}};
  CHECK(VoronoiPathGraph(line).edge_count() == 0);
  // A single point is valid input.
  CHECK(VoronoiPathGraph(std::vector<Point2d>{{1, 1}}).node_count() == 0);
  // Float clouds and Eigen matrices work too.
  std::vector<Eigen::Vector2f> fpts;
  for (const auto& p : random_points(50, 5.0, 3))
    fpts.push_back(p.cast<float>());
  CHECK(VoronoiPathGraph(fpts, {.robot_width = 0.0, .safety_margin = 0.0}).edge_count() > 0);
}

TEST_CASE("voronoi graph: the same graph from any 2D PointCloud") {
  // A room seen by a 2D laser in its centre: the scan's valid points, the same points as a
  // std::vector, as an Eigen matrix (one point per column) and as a cloud with a duplicate of every
  // point (the de-duplication must remove them) give one and the same graph.
  const double pi = 3.14159265358979323846;
  rangenav::ScanGeometry<double> geo{-pi, pi / 360, 720, 0.05, 10.0};
  std::vector<double> ranges(720);
  for (std::size_t i = 0; i < ranges.size(); ++i) {
    const double a = geo.angle(i);
    // A 6 m x 4 m room centred on the scanner, and every 40th beam lost (NaN: not a point).
    ranges[i] = i % 40 == 7 ? std::nan("")
                            : std::min(3.0 / std::abs(std::cos(a)), 2.0 / std::abs(std::sin(a)));
  }
  const rangenav::LaserScan<double> scan(geo, ranges);
  REQUIRE(scan.valid_count() == 720 - 18);
  const std::vector<Point2d> points(scan.valid_points().begin(), scan.valid_points().end());
  Eigen::Matrix2Xd matrix(2, static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i)
    matrix.col(static_cast<Eigen::Index>(i)) = points[i];
  std::vector<Point2d> doubled = points;
  doubled.insert(doubled.end(), points.rbegin(), points.rend());

  const VoronoiPathGraph reference(points);
  REQUIRE(reference.edge_count() > 0);
  const auto same = [&](const VoronoiPathGraph& g) {
    REQUIRE(g.sites() == reference.sites());
    REQUIRE(g.node_count() == reference.node_count());
    REQUIRE(g.edge_count() == reference.edge_count());
    for (std::size_t i = 0; i < g.edge_count(); ++i) {
      const auto &e = g.edges()[i], &r = reference.edges()[i];
      REQUIRE(g.nodes()[e.from].position == reference.nodes()[r.from].position);
      REQUIRE(g.nodes()[e.to].position == reference.nodes()[r.to].position);
      REQUIRE(e.clearance == r.clearance);
    }
  };
  same(VoronoiPathGraph(scan));
  same(VoronoiPathGraph(matrix));
  const VoronoiPathGraph dedup(doubled);
  CHECK(dedup.stats().input_points == 2 * points.size());
  CHECK(dedup.stats().sites == points.size());
  same(dedup);
  // Every edge of the room's graph keeps Kurt3D's clearance (0.215 m) from the scanned walls.
  for (const auto& e : reference.edges())
    REQUIRE(brute_force_clearance(points, reference.nodes()[e.from].position,
                                  reference.nodes()[e.to].position) >= 0.215 - 1e-9);
  // Only 2D clouds are accepted.
  static_assert(std::is_constructible_v<VoronoiPathGraph, const rangenav::LaserScan<double>&>);
  static_assert(std::is_constructible_v<VoronoiPathGraph, const Eigen::Matrix2Xf&>);
  static_assert(!std::is_constructible_v<VoronoiPathGraph, const std::vector<rangenav::Point3d>&>);
  static_assert(!std::is_constructible_v<VoronoiPathGraph, const Eigen::Matrix3Xd&>);
}

TEST_CASE("voronoi graph: contracts") {
  using Catch::Matchers::Equals;
  const std::vector<Point2d> empty;
  CHECK_THROWS_WITH(VoronoiPathGraph(empty),
                    Equals("rangenav: VoronoiPathGraph: argument 'cloud' is empty"));
  const std::vector<Point2d> nan{{0, 0}, {1, std::nan("")}};
  CHECK_THROWS_WITH(
      VoronoiPathGraph(nan),
      Equals("rangenav: VoronoiPathGraph: argument 'cloud[1]' = 1 nan must be finite"));
  const std::vector<Point2d> huge{{0, 0}, {3e6, 0}};
  CHECK_THROWS_WITH(
      VoronoiPathGraph(huge),
      Equals("rangenav: VoronoiPathGraph: argument 'cloud[1]' = 3000000 0 does not fit the 32-bit "
             "grid at resolution 0.001"));
  CHECK_THROWS_AS(VoronoiPathGraph(huge, {.resolution = 0.0}), rangenav::invalid_argument);
  CHECK_THROWS_WITH(
      VoronoiPathGraph(nan, {.resolution = -1.0}),
      Equals(
          "rangenav: VoronoiPathGraph: argument 'params.resolution' = -1 must be finite and > 0"));
  CHECK_THROWS_WITH(VoronoiPathGraph(huge, {.robot_width = -0.1}),
                    Equals("rangenav: VoronoiPathGraph: argument 'params.robot_width' = "
                           "-0.10000000000000001 must be finite and >= 0"));
  VoronoiPathGraph g(rooms_map(2, 4.0, 0.1));
  CHECK_THROWS_WITH(g.set_blocked(static_cast<index_type>(g.edge_count())),
                    Equals("rangenav: VoronoiPathGraph::set_blocked: argument 'edge' = " +
                           std::to_string(g.edge_count()) +
                           " must be < edge_count() = " + std::to_string(g.edge_count())));
}

TEST_CASE("a star: optimal against Dijkstra on random maps and rooms") {
  std::mt19937 rng(11);
  for (int map = 0; map < 2; ++map) {
    const auto pts = map == 0 ? random_points(1500, 20.0, 5) : rooms_map(3, 4.0, 0.1);
    VoronoiPathGraph graph(pts, {.robot_width = 0.1, .safety_margin = 0.02});
    REQUIRE(graph.node_count() > 10);
    AStar planner(graph);
    std::uniform_int_distribution<index_type> pick(0,
                                                   static_cast<index_type>(graph.node_count() - 1));
    int reachable = 0;
    for (int q = 0; q < 30; ++q) {
      const index_type from = pick(rng), to = pick(rng);
      const auto reference = dijkstra(graph, from);
      std::vector<index_type> nodes, edges;
      const auto cost = planner.shortest_path(from, to, &nodes, &edges);
      if (std::isinf(reference[to])) {
        REQUIRE(!cost);
        continue;
      }
      ++reachable;
      REQUIRE(cost);
      REQUIRE(*cost == Approx(reference[to]).epsilon(1e-12));
      // The returned path is a chain of edges from `from` to `to` whose lengths sum to the cost.
      REQUIRE(nodes.front() == from);
      REQUIRE(nodes.back() == to);
      REQUIRE(edges.size() + 1 == nodes.size());
      double sum = 0;
      for (std::size_t i = 0; i < edges.size(); ++i) {
        REQUIRE(graph.other_node(edges[i], nodes[i]) == nodes[i + 1]);
        sum += graph.edges()[edges[i]].length;
      }
      REQUIRE(sum == Approx(*cost).epsilon(1e-12));
    }
    CHECK(reachable > 5);
  }
}

TEST_CASE("a star: start and goal attach toward each other in a corridor") {
  // Two walls 2 m apart sampled every 0.2 m: the pruned graph is the centre line, with nodes at
  // x = 0.1, 0.3, ... The start at x = 5.0 lies between two nodes at equal distance.
  std::vector<Point2d> pts;
  for (int k = 0; k <= 100; ++k) {
    pts.emplace_back(0.2 * k, 0.0);
    pts.emplace_back(0.2 * k, 2.0);
  }
  VoronoiPathGraph graph(pts);
  AStar planner(graph);
  AStar paper(graph, {.shortcut_ends = false});  // the attachment of §4 alone
  for (const double goal_x : {18.0, 1.0}) {
    const auto attached = paper.plan({5.0, 1.0}, {goal_x, 1.0});
    REQUIRE(attached.found());
    // The first node is the one toward the goal, so the path never turns back.
    CHECK(attached.path.waypoints[1].x() == Approx(goal_x > 5.0 ? 5.1 : 4.9));
    CHECK(attached.path.length == Approx(std::abs(goal_x - 5.0)).margin(1e-9));
    // shortcut_ends goes straight to the farthest node within shortcut_length (1 m): the same
    // line, fewer nodes at each end.
    const auto result = planner.plan({5.0, 1.0}, {goal_x, 1.0});
    REQUIRE(result.found());
    const auto& wp = result.path.waypoints;
    REQUIRE(wp.size() >= 3);
    CHECK(wp.size() < attached.path.waypoints.size());
    CHECK(wp[1].x() == Approx(goal_x > 5.0 ? 5.9 : 4.1));
    CHECK(result.path.length == Approx(std::abs(goal_x - 5.0)).margin(1e-9));
    for (const Point2d& p : wp)
      CHECK(p.y() == Approx(1.0));
    CHECK(result.path.edges.front() == VoronoiPathGraph::npos);
    CHECK(result.path.edges.back() == VoronoiPathGraph::npos);
    CHECK(result.path.edges.size() + 1 == wp.size());
  }
  // Outside the corridor every straight connection passes within 0.1 m of a wall point.
  CHECK(planner.plan({5.0, -1.0}, {18.0, 1.0}).status == rangenav::PlanStatus::start_not_attached);
  CHECK(planner.plan({5.0, 1.0}, {18.0, 3.0}).status == rangenav::PlanStatus::goal_not_attached);
  CHECK(planner.segment_clearance({5.0, -1.0}, {5.1, 1.0}) < 0.1);

  // Blocking one edge of the centre line disconnects start and goal; unblocking restores it.
  const auto before = planner.plan({5.0, 1.0}, {18.0, 1.0});
  const index_type cut = before.path.edges[before.path.edges.size() / 2];
  graph.set_blocked(cut);
  CHECK(graph.blocked_count() == 1);
  CHECK(planner.plan({5.0, 1.0}, {18.0, 1.0}).status == rangenav::PlanStatus::no_path);
  graph.set_blocked(cut, false);
  CHECK(planner.plan({5.0, 1.0}, {18.0, 1.0}).path.length == Approx(13.0));

  using Catch::Matchers::Equals;
  CHECK_THROWS_WITH(planner.plan({std::nan(""), 0.0}, {1.0, 1.0}),
                    Equals("rangenav: AStar::plan: argument 'start' = nan 0 must be finite"));
  CHECK_THROWS_AS(planner.shortest_path(0, static_cast<index_type>(graph.node_count())),
                  rangenav::invalid_argument);
}

TEST_CASE("a star: shortcut ends never lengthen a path and keep the connection clearance") {
  VoronoiPathGraph graph(rooms_map(3, 4.0, 0.1));
  AStar planner(graph);
  AStar paper(graph, {.shortcut_ends = false});
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> coord(0.5, 11.5);
  int shortened = 0, found = 0;
  for (int q = 0; q < 60; ++q) {
    const Point2d start(coord(rng), coord(rng)), goal(coord(rng), coord(rng));
    const auto a = paper.plan(start, goal), b = planner.plan(start, goal);
    REQUIRE(a.status == b.status);
    if (!b.found()) continue;
    ++found;
    CHECK(b.path.length <= a.path.length + 1e-9);
    shortened += b.path.length < a.path.length - 1e-6 ? 1 : 0;
    const auto& wp = b.path.waypoints;
    for (const auto& [p, q2] : {std::pair{wp[0], wp[1]}, std::pair{wp[wp.size() - 2], wp.back()}})
      CHECK(planner.segment_clearance(p, q2) >=
            std::min({0.215, planner.segment_clearance(start, start),
                      planner.segment_clearance(goal, goal)}) -
                1e-9);
  }
  CHECK(found > 20);
  CHECK(shortened > 0);  // nodes behind the start or beyond the goal were skipped
}

TEST_CASE("a star: re-plans around blocked edges without rebuilding") {
  VoronoiPathGraph graph(rooms_map(3, 4.0, 0.1));
  AStar planner(graph);
  const Point2d start(1.0, 1.0), goal(11.0, 11.0);
  const auto first = planner.plan(start, goal);
  REQUIRE(first.found());
  // Every segment keeps the clearance (graph edges by construction, connections checked).
  for (std::size_t i = 0; i + 1 < first.path.waypoints.size(); ++i)
    REQUIRE(planner.segment_clearance(first.path.waypoints[i], first.path.waypoints[i + 1]) >=
            std::min(0.215, planner.segment_clearance(start, start)) - 1e-9);

  double previous = first.path.length;
  std::vector<index_type> blocked;
  auto path = first.path;
  for (int round = 0; round < 3; ++round) {
    // Block a graph edge in the middle of the current path (as a scan showing an obstacle would).
    std::vector<index_type> graph_edges;
    for (index_type e : path.edges)
      if (e != VoronoiPathGraph::npos) graph_edges.push_back(e);
    REQUIRE(!graph_edges.empty());
    const index_type cut = graph_edges[graph_edges.size() / 2];
    graph.set_blocked(cut);
    blocked.push_back(cut);
    const auto again = planner.plan(start, goal);
    REQUIRE(again.found());
    for (index_type e : again.path.edges)
      for (index_type b : blocked)
        REQUIRE(e != b);
    CHECK(again.path.length >= previous - 1e-9);
    // Optimal on the reduced graph between the same attached nodes.
    const auto reference = dijkstra(graph, again.path.nodes.front());
    double inner = 0;
    for (index_type e : again.path.edges)
      if (e != VoronoiPathGraph::npos) inner += graph.edges()[e].length;
    CHECK(inner == Approx(reference[again.path.nodes.back()]).epsilon(1e-12));
    previous = again.path.length;
    path = again.path;
  }
  graph.clear_blocked();
  CHECK(planner.plan(start, goal).path.length == Approx(first.path.length));
}
