#pragma once
// A* path planning on a VoronoiPathGraph (paper 000 §4).
//
// The cost of a path through node n is f(n) = g(n) + h(n) with g the travelled length and h the
// Euclidean distance to the goal (Eq. 6 of paper 000); the heuristic is admissible (edges are
// straight), so A* returns a shortest path on the graph. Blocked edges are skipped, so marking an
// edge blocked and planning again re-plans without rebuilding the diagram.
//
// The true start and goal are attached to graph nodes: the closest nodes reachable by a straight
// segment that keeps the required clearance (or, if the endpoint itself is closer to an obstacle,
// that clearance), and "in cases where multiple nodes have similar distances to the true poses,
// we prefer the nodes in the direction of the other true pose" (§4). Among the candidates, the
// first start/goal pair in one connected component of the traversable graph is used.
//
// AStar keeps its search buffers between queries: after the first query on a graph a query
// allocates only the returned path. One AStar must not be used from two threads at once.

#include <algorithm>
#include <boost/geometry/algorithms/distance.hpp>
#include <boost/geometry/geometries/point_xy.hpp>
#include <boost/geometry/geometries/segment.hpp>
#include <boost/geometry/index/rtree.hpp>
#include <boost/geometry/strategies/strategies.hpp>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <iterator>
#include <limits>
#include <numeric>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/planning/voronoi_path_graph.hpp"

namespace rangenav {

/// Parameters of AStar's start / goal attachment.
struct AStarParams {
  /// Nodes whose distance to the true pose is within this much of the closest one count as "at
  /// similar distance"; among them the one in the direction of the other pose wins (m).
  double similar_distance = 0.25;
  /// How many nearest nodes are considered when attaching start and goal.
  std::size_t attach_candidates = 16;
  /// Clearance the straight connecting segments must keep (m); negative: the graph's
  /// required_clearance().
  double connection_clearance = -1.0;
  /// Drop the first (last) graph nodes of a path while the start (goal) reaches the next
  /// (previous) node by a straight segment that keeps the connection clearance and is at most
  /// shortcut_length long: the attachment rule may pick a node behind the start or beyond the
  /// goal, and the path would double back. The limit keeps graph edges (which can be marked
  /// blocked) from being replaced by long connections (which cannot).
  bool shortcut_ends = true;
  double shortcut_length = 1.0;  ///< m
};

/// Why plan() did or did not find a path.
enum class PlanStatus {
  found,               ///< path holds the plan
  start_not_attached,  ///< no graph node is reachable from the start by a clear straight segment
  goal_not_attached,   ///< no graph node is reachable from the goal by a clear straight segment
  no_path,             ///< start and goal nodes lie in different components of the free graph
};

/// A planned path: straight segments between waypoints, start first, goal last.
struct PlannedPath {
  std::vector<Point2d> waypoints;  ///< start, the Voronoi vertices, goal (m)
  /// One entry per segment (waypoints.size() - 1): the graph edge it follows, or
  /// VoronoiPathGraph::npos for the straight connections of start and goal.
  std::vector<VoronoiPathGraph::index_type> edges;
  /// The graph nodes visited, in order.
  std::vector<VoronoiPathGraph::index_type> nodes;
  double length{0.0};  ///< total length (m)
};

/// The outcome of a query: why it ended, and the path when one was found.
struct PlanResult {
  PlanStatus status{PlanStatus::no_path};  ///< found, or why not
  PlannedPath path;                        ///< the path (empty unless found)
  std::size_t expanded{0};                 ///< nodes expanded by the graph search
  /// True when a path was found.
  [[nodiscard]] bool found() const { return status == PlanStatus::found; }
};

/// A* on a VoronoiPathGraph (paper 000 §4, Eq. 6): attaches start and goal to the graph, skips
/// blocked edges, and keeps its buffers between queries.
class AStar {
 public:
  /// A node or edge index.
  using index_type = VoronoiPathGraph::index_type;
  /// "No node / no edge".
  static constexpr index_type npos = VoronoiPathGraph::npos;

  /// Plans on `graph`, which must outlive this object (blocked edges are read at query time).
  explicit AStar(const VoronoiPathGraph& graph, const AStarParams& params = {})
      : graph_(&graph), params_(params) {
    if (params_.attach_candidates == 0)
      detail::throw_invalid_argument("AStar", "params.attach_candidates", 0, "must be > 0");
    detail::require_non_negative("AStar", "params.similar_distance", params_.similar_distance);
    detail::require_non_negative("AStar", "params.shortcut_length", params_.shortcut_length);
    if (!std::isfinite(params_.connection_clearance))
      detail::throw_invalid_argument("AStar", "params.connection_clearance",
                                     params_.connection_clearance, "must be finite");
    std::vector<bg_point> sites;
    sites.reserve(graph.sites().size());
    for (const Point2d& s : graph.sites())
      sites.emplace_back(s.x(), s.y());
    sites_ = site_tree(sites.begin(), sites.end());
    std::vector<node_value> nodes;
    nodes.reserve(graph.node_count());
    for (std::size_t i = 0; i < graph.node_count(); ++i) {
      const Point2d& p = graph.nodes()[i].position;
      nodes.emplace_back(bg_point(p.x(), p.y()), static_cast<index_type>(i));
    }
    nodes_ = node_tree(nodes.begin(), nodes.end());
  }

  /// The parameters.
  [[nodiscard]] const AStarParams& params() const { return params_; }

  /// Distance from the straight segment a-b to the nearest map point (m).
  [[nodiscard]] double segment_clearance(const Point2d& a, const Point2d& b) const {
    if (sites_.empty()) return std::numeric_limits<double>::infinity();
    const bg_segment s(bg_point(a.x(), a.y()), bg_point(b.x(), b.y()));
    for (auto it = sites_.qbegin(boost::geometry::index::nearest(s, 1)); it != sites_.qend(); ++it)
      return boost::geometry::distance(s, *it);
    return std::numeric_limits<double>::infinity();
  }

  /// The largest coordinate magnitude plan() accepts (m): every distance it computes, squared
  /// and summed, stays finite.
  static constexpr double max_coordinate = 1e150;

  /// Plans from `start` to `goal` (m). Throws invalid_argument for a coordinate that is not
  /// finite or exceeds max_coordinate.
  [[nodiscard]] PlanResult plan(const Point2d& start, const Point2d& goal) {
    const auto check = [](const char* name, const Point2d& p) {
      if (!p.allFinite())
        detail::throw_invalid_argument("AStar::plan", name, format_point(p), "must be finite");
      if (!(p.cwiseAbs().maxCoeff() <= max_coordinate))
        detail::throw_invalid_argument("AStar::plan", name, format_point(p),
                                       "exceeds AStar::max_coordinate = 1e150 m");
    };
    check("start", start);
    check("goal", goal);
    PlanResult result;
    const std::vector<index_type> starts = attach_candidates(start, goal);
    if (starts.empty()) {
      result.status = PlanStatus::start_not_attached;
      return result;
    }
    const std::vector<index_type> goals = attach_candidates(goal, start);
    if (goals.empty()) {
      result.status = PlanStatus::goal_not_attached;
      return result;
    }
    update_components();
    for (index_type s : starts)
      for (index_type g : goals) {
        if (component_[s] != component_[g]) continue;
        std::vector<index_type> edges;
        const auto cost = shortest_path(s, g, &result.path.nodes, &edges, &result.expanded);
        if (!cost) continue;  // cannot happen within one component; kept for safety
        if (params_.shortcut_ends) {
          shortcut(start, goal, result.path.nodes, edges);
          // The rule of shortcut() for the goal itself: within reach of the start by a clear
          // segment, no node is needed (start == goal gives a path of length 0).
          if ((goal - start).norm() <= params_.shortcut_length &&
              segment_clearance(start, goal) >=
                  std::min(connection_required(start), connection_required(goal))) {
            result.path.nodes.clear();
            edges.clear();
          }
        }
        PlannedPath& path = result.path;
        path.waypoints.clear();
        path.edges.clear();
        path.length = 0.0;
        auto append = [&](const Point2d& p, index_type edge) {
          if (!path.waypoints.empty()) {
            const double step = (p - path.waypoints.back()).norm();
            if (step == 0.0) return;  // an endpoint on a node: no zero-length segment
            path.edges.push_back(edge);
            path.length += step;
          }
          path.waypoints.push_back(p);
        };
        append(start, npos);
        for (std::size_t i = 0; i < path.nodes.size(); ++i)
          append(graph_->nodes()[path.nodes[i]].position, i == 0 ? npos : edges[i - 1]);
        append(goal, npos);
        result.status = PlanStatus::found;
        return result;
      }
    result.status = PlanStatus::no_path;
    return result;
  }

  /// A* from node `from` to node `to` over the traversable edges with the Euclidean heuristic
  /// (Eq. 6). Returns the path length, or nothing when `to` is unreachable. When given, `nodes`
  /// receives the visited nodes (from ... to) and `edges` the edges between them.
  std::optional<double> shortest_path(index_type from, index_type to,
                                      std::vector<index_type>* nodes = nullptr,
                                      std::vector<index_type>* edges = nullptr,
                                      std::size_t* expanded = nullptr) {
    const std::size_t n = graph_->node_count();
    if (from >= n)
      detail::throw_invalid_argument("AStar::shortest_path", "from", from,
                                     "must be < node_count() = " + std::to_string(n));
    if (to >= n)
      detail::throw_invalid_argument("AStar::shortest_path", "to", to,
                                     "must be < node_count() = " + std::to_string(n));
    if (g_.size() != n) {
      g_.assign(n, inf);
      parent_edge_.assign(n, npos);
      closed_.assign(n, 0);
      touched_.clear();
    }
    for (index_type t : touched_) {  // reset only what the previous query touched
      g_[t] = inf;
      parent_edge_[t] = npos;
      closed_[t] = 0;
    }
    touched_.clear();
    open_.clear();
    const auto& nd = graph_->nodes();
    const Point2d target = nd[to].position;
    auto heuristic = [&](index_type i) { return (target - nd[i].position).norm(); };  // Eq. 6
    g_[from] = 0.0;
    touched_.push_back(from);
    push_open({heuristic(from), from});
    std::size_t count = 0;
    bool reached = false;
    while (!open_.empty()) {
      std::pop_heap(open_.begin(), open_.end(), std::greater<>{});
      const index_type u = open_.back().second;
      open_.pop_back();
      if (closed_[u]) continue;
      closed_[u] = 1;
      ++count;
      if (u == to) {
        reached = true;
        break;
      }
      for (index_type e : graph_->incident_edges(u)) {
        if (graph_->is_blocked(e)) continue;
        const index_type v = graph_->other_node(e, u);
        if (closed_[v]) continue;
        const double g = g_[u] + graph_->edges()[e].length;
        if (g < g_[v]) {
          if (g_[v] == inf) touched_.push_back(v);
          g_[v] = g;
          parent_edge_[v] = e;
          push_open({g + heuristic(v), v});
        }
      }
    }
    if (expanded) *expanded += count;
    if (!reached) return std::nullopt;
    if (nodes || edges) {
      std::vector<index_type> node_list{to}, edge_list;
      for (index_type v = to; v != from;) {
        const index_type e = parent_edge_[v];
        edge_list.push_back(e);
        v = graph_->other_node(e, v);
        node_list.push_back(v);
      }
      std::reverse(node_list.begin(), node_list.end());
      std::reverse(edge_list.begin(), edge_list.end());
      if (nodes) *nodes = std::move(node_list);
      if (edges) *edges = std::move(edge_list);
    }
    return g_[to];
  }

 private:
  using bg_point = boost::geometry::model::d2::point_xy<double>;
  using bg_segment = boost::geometry::model::segment<bg_point>;
  using node_value = std::pair<bg_point, index_type>;
  using site_tree = boost::geometry::index::rtree<bg_point, boost::geometry::index::rstar<16>>;
  using node_tree = boost::geometry::index::rtree<node_value, boost::geometry::index::rstar<16>>;
  using queue_entry = std::pair<double, index_type>;
  static constexpr double inf = std::numeric_limits<double>::infinity();

  void push_open(const queue_entry& entry) {
    open_.push_back(entry);
    std::push_heap(open_.begin(), open_.end(), std::greater<>{});
  }

  static std::string format_point(const Point2d& p) {
    return detail::format_value(p.x()) + " " + detail::format_value(p.y());
  }

  /// The nodes `pose` may attach to, best first (§4): reachable by a clear straight segment, and
  /// among those within similar_distance of the closest, the one toward `other` first.
  std::vector<index_type> attach_candidates(const Point2d& pose, const Point2d& other) const {
    std::vector<node_value> near;
    // At most the node count (a larger count must not wrap in the conversion to unsigned).
    const std::size_t k = std::clamp<std::size_t>(params_.attach_candidates, 1,
                                                  std::max<std::size_t>(graph_->node_count(), 1));
    nodes_.query(
        boost::geometry::index::nearest(bg_point(pose.x(), pose.y()), static_cast<unsigned>(k)),
        std::back_inserter(near));
    // An endpoint already closer to an obstacle than wanted may still leave along a segment that
    // comes no closer than it already is.
    const double required = connection_required(pose);
    struct Candidate {
      index_type node;
      double distance;
      double alignment;  // cosine between (node - pose) and (other - pose)
    };
    std::vector<Candidate> ok;
    const Point2d towards = other - pose;
    for (const node_value& v : near) {
      const Point2d p = graph_->nodes()[v.second].position;
      if (graph_->incident_edges(v.second).empty()) continue;
      if (segment_clearance(pose, p) < required) continue;
      const Point2d d = p - pose;
      const double dn = d.norm(), tn = towards.norm();
      ok.push_back({v.second, dn, dn > 0 && tn > 0 ? d.dot(towards) / (dn * tn) : 1.0});
    }
    std::sort(ok.begin(), ok.end(),
              [](const Candidate& a, const Candidate& b) { return a.distance < b.distance; });
    if (!ok.empty()) {
      const double similar = ok.front().distance + params_.similar_distance;
      const auto end_similar = std::find_if(
          ok.begin(), ok.end(), [&](const Candidate& c) { return c.distance > similar; });
      std::stable_sort(ok.begin(), end_similar, [](const Candidate& a, const Candidate& b) {
        return a.alignment > b.alignment;
      });
    }
    std::vector<index_type> out;
    out.reserve(ok.size());
    for (const Candidate& c : ok)
      out.push_back(c.node);
    return out;
  }

  /// The clearance a straight connection from `p` must keep: connection_clearance, or less when
  /// p itself is closer to an obstacle.
  double connection_required(const Point2d& p) const {
    const double wanted = params_.connection_clearance >= 0.0
                              ? params_.connection_clearance
                              : graph_->params().required_clearance();
    return std::min(wanted, segment_clearance(p, p)) - 1e-9;
  }

  /// shortcut_ends: drops the end nodes the start / goal can skip with a clear straight segment.
  void shortcut(const Point2d& start, const Point2d& goal, std::vector<index_type>& nodes,
                std::vector<index_type>& edges) const {
    const auto& nd = graph_->nodes();
    const double at_start = connection_required(start), at_goal = connection_required(goal);
    std::size_t first = 0, last = nodes.size() - 1;
    const double reach = params_.shortcut_length;
    const auto skips = [&](const Point2d& end, index_type node, double required) {
      const Point2d& p = nd[node].position;
      return (p - end).norm() <= reach && segment_clearance(end, p) >= required;
    };
    while (first < last && skips(start, nodes[first + 1], at_start))
      ++first;
    while (last > first && skips(goal, nodes[last - 1], at_goal))
      --last;
    if (first == 0 && last + 1 == nodes.size()) return;
    nodes = std::vector<index_type>(nodes.begin() + static_cast<std::ptrdiff_t>(first),
                                    nodes.begin() + static_cast<std::ptrdiff_t>(last) + 1);
    edges = std::vector<index_type>(edges.begin() + static_cast<std::ptrdiff_t>(first),
                                    edges.begin() + static_cast<std::ptrdiff_t>(last));
  }

  /// Connected components of the traversable graph, recomputed when the blocked set changed.
  void update_components() {
    if (components_valid_ && components_revision_ == graph_->revision()) return;
    const std::size_t n = graph_->node_count();
    std::vector<index_type> parent(n);
    std::iota(parent.begin(), parent.end(), index_type{0});
    auto find = [&](index_type x) {
      while (parent[x] != x)
        x = parent[x] = parent[parent[x]];
      return x;
    };
    for (std::size_t e = 0; e < graph_->edge_count(); ++e) {
      if (graph_->is_blocked(static_cast<index_type>(e))) continue;
      const auto& edge = graph_->edges()[e];
      const index_type a = find(edge.from), b = find(edge.to);
      if (a != b) parent[a] = b;
    }
    component_.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      component_[i] = find(static_cast<index_type>(i));
    components_valid_ = true;
    components_revision_ = graph_->revision();
  }

  const VoronoiPathGraph* graph_;
  AStarParams params_;
  site_tree sites_;
  node_tree nodes_;
  std::vector<double> g_;
  std::vector<index_type> parent_edge_;
  std::vector<std::uint8_t> closed_;
  std::vector<index_type> touched_;
  std::vector<queue_entry> open_;  // binary min-heap on f
  std::vector<index_type> component_;
  bool components_valid_{false};
  std::uint64_t components_revision_{0};
};

}  // namespace rangenav
