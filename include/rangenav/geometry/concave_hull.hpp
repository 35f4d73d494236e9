#pragma once
// Concave hulls of planar point sets by alpha shapes (paper 004 §3.3: "a concave hull of the
// projected inliers is constructed using alpha shapes. The hull points are sorted so that it is
// possible to create a polygon").
//
// The Delaunay triangulation is the dual of the Voronoi diagram, which Boost.Polygon builds with
// Fortune's sweep: every Voronoi vertex is the circumcentre of one Delaunay face (a triangle, or a
// convex polygon when four or more sites are cocircular, common on a snapped grid) whose sites are
// the cells around the vertex, and its distance to those sites is the face's circumradius. The
// alpha shape keeps the faces with circumradius <= alpha (PCL's ConcaveHull and CGAL's
// regularised alpha shape make the same choice); its boundary is every directed face edge whose
// reverse is not an edge of a kept face. The boundary edges are chained into rings, interior on
// the left, and a vertex where two kept parts touch is split so that every ring is simple; rings
// come out counter-clockwise (outer boundaries) or clockwise (holes), and each hole goes to the
// outer ring around it.
//
// Input coordinates are snapped to an integer grid (IntegerGrid, default 1 mm) as Boost.Polygon
// requires; duplicates after snapping count once, and hull vertices are grid points.

#include <boost/geometry/algorithms/within.hpp>
#include <boost/geometry/geometries/point_xy.hpp>
#include <boost/geometry/geometries/ring.hpp>
#include <boost/geometry/strategies/strategies.hpp>
#include <boost/polygon/voronoi.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/integer_grid.hpp"
#include "rangenav/geometry/planar_polygon.hpp"

namespace rangenav {

struct ConcaveHullParams {
  /// Largest circumradius (m) of a Delaunay triangle that belongs to the shape. A few times the
  /// point spacing: larger values close gaps and bays, smaller ones split the shape.
  double alpha = 0.05;
  /// Grid the points are snapped to for Boost.Polygon (m).
  double resolution = 0.001;
  /// Drop polygons smaller than this (m^2); 0 keeps every piece.
  double min_area = 0.0;

  void validate(std::string_view where) const {
    detail::require_positive(where, "params.alpha", alpha);
    detail::require_positive(where, "params.resolution", resolution);
    detail::require_non_negative(where, "params.min_area", min_area);
  }
};

/// Builds alpha-shape hulls; owns its scratch buffers, so repeated calls allocate little.
class ConcaveHull {
 public:
  using cell_type = IntegerGrid::cell_type;

  explicit ConcaveHull(const ConcaveHullParams& params = {}) : params_(params) {
    params_.validate("ConcaveHull");
  }

  [[nodiscard]] const ConcaveHullParams& params() const { return params_; }

  /// The alpha shape of the 2D points of `cloud` as simple polygons with holes (outer rings
  /// counter-clockwise, holes clockwise, open rings), largest area first. Empty when no triangle
  /// passes the alpha test (fewer than 3 distinct points, collinear points, alpha too small).
  /// When `piece_of_point` is given it receives, for every input point, the index of the polygon
  /// whose part of the shape the point belongs to, or -1 (a point on no kept triangle, or on a
  /// piece dropped by min_area; pieces touching in one vertex count as the larger one).
  /// Throws invalid_argument for a non-finite point or one that does not fit the grid.
  template <PointCloudOf<2> C>
  [[nodiscard]] std::vector<Polygon2<double>> compute(
      const C& cloud, std::vector<std::int32_t>* piece_of_point = nullptr) {
    constexpr std::string_view where = "ConcaveHull::compute";
    const IntegerGrid grid{params_.resolution};
    const std::size_t n = traits::size(cloud);
    keyed_.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      keyed_[i] = {grid.snap(traits::point(cloud, i).template cast<double>(), where,
                             "cloud[" + std::to_string(i) + "]"),
                   static_cast<std::uint32_t>(i)};
    auto result = build(grid);
    if (piece_of_point) {
      piece_of_point->assign(n, -1);
      for (std::size_t i = 0; i < n; ++i) {
        const std::uint32_t root = find(site_of_point_[i]);
        (*piece_of_point)[i] = root < piece_of_root_.size() ? piece_of_root_[root] : -1;
      }
    }
    return result;
  }

 private:
  struct DirectedEdge {
    std::uint32_t from, to;
    bool operator<(const DirectedEdge& o) const {
      return from < o.from || (from == o.from && to < o.to);
    }
    bool operator==(const DirectedEdge&) const = default;
  };

  std::vector<Polygon2<double>> build(const IntegerGrid& grid) {
    namespace bp = boost::polygon;
    // Distinct grid points; site_of_point_ maps every input point to its site.
    std::sort(keyed_.begin(), keyed_.end());
    sites_.clear();
    site_of_point_.resize(keyed_.size());
    for (const auto& [cell, index] : keyed_) {
      if (sites_.empty() || sites_.back() != cell) sites_.push_back(cell);
      site_of_point_[index] = static_cast<std::uint32_t>(sites_.size() - 1);
    }
    parent_.resize(sites_.size());
    for (std::size_t i = 0; i < parent_.size(); ++i)
      parent_[i] = static_cast<std::uint32_t>(i);
    piece_of_root_.assign(sites_.size(), -1);
    std::vector<Polygon2<double>> result;
    if (sites_.size() < 3) return result;

    bp::voronoi_diagram<double> vd;
    {
      bp::voronoi_builder<std::int32_t> builder;
      for (const cell_type& s : sites_)
        builder.insert_point(s[0], s[1]);
      builder.construct(&vd);
    }

    // Kept Delaunay faces: circumradius (the Voronoi vertex's distance to a site) <= alpha, both
    // in grid steps. Their directed edges, counter-clockwise around each face.
    const double alpha = params_.alpha / params_.resolution;
    const double alpha_sq = alpha * alpha;
    edges_.clear();
    for (const auto& v : vd.vertices()) {
      const auto* start = v.incident_edge();
      const cell_type& s0 = sites_[start->cell()->source_index()];
      const double dx = v.x() - s0[0], dy = v.y() - s0[1];
      if (dx * dx + dy * dy > alpha_sq) continue;
      face_.clear();
      const auto* e = start;
      do {  // rot_next turns counter-clockwise around the vertex; each edge's cell is on its left
        face_.push_back(static_cast<std::uint32_t>(e->cell()->source_index()));
        e = e->rot_next();
      } while (e != start);
      if (signed_area2(face_) < 0) std::reverse(face_.begin(), face_.end());
      for (std::size_t k = 0; k < face_.size(); ++k) {
        edges_.push_back({face_[k], face_[(k + 1) % face_.size()]});
        parent_[find(face_[k])] = find(face_[0]);  // the face's sites form one piece
      }
    }
    std::sort(edges_.begin(), edges_.end());

    // Boundary: directed edges without their reverse.
    boundary_.clear();
    for (const DirectedEdge& de : edges_)
      if (!std::binary_search(edges_.begin(), edges_.end(), DirectedEdge{de.to, de.from}))
        boundary_.push_back(de);
    if (boundary_.empty()) return result;  // sorted by `from` already

    // Chain into rings. At a vertex with several outgoing boundary edges take the first one
    // clockwise from the edge we came along, which closes the tightest loop and keeps rings
    // simple where two parts of the shape touch in one point.
    used_.assign(boundary_.size(), 0);
    std::vector<std::vector<std::uint32_t>> rings;
    for (std::size_t first = 0; first < boundary_.size(); ++first) {
      if (used_[first]) continue;
      std::vector<std::uint32_t> ring;
      std::size_t cur = first;
      while (!used_[cur]) {
        used_[cur] = 1;
        ring.push_back(boundary_[cur].from);
        cur = next_edge(cur);
        if (cur == npos) break;
      }
      if (ring.size() >= 3) rings.push_back(std::move(ring));
    }

    // Outer rings (counter-clockwise) and holes (clockwise), holes assigned to the smallest outer
    // ring that contains one of their vertices strictly.
    std::vector<std::size_t> outers, holes;
    std::vector<double> areas(rings.size());
    for (std::size_t r = 0; r < rings.size(); ++r) {
      areas[r] = signed_area2(rings[r]);
      if (areas[r] > 0)
        outers.push_back(r);
      else if (areas[r] < 0)
        holes.push_back(r);
    }
    std::vector<std::vector<std::size_t>> holes_of(rings.size());
    for (const std::size_t h : holes) {
      std::size_t best = npos;
      for (const std::size_t o : outers)
        if (ring_contains(rings[o], rings[h]) && (best == npos || areas[o] < areas[best])) best = o;
      if (best != npos) holes_of[best].push_back(h);
    }
    const double area_scale = params_.resolution * params_.resolution / 2;
    std::vector<std::pair<Polygon2<double>, std::uint32_t>> pieces;  // polygon, union-find root
    for (const std::size_t o : outers) {
      double area = areas[o];
      for (const std::size_t h : holes_of[o])
        area += areas[h];
      if (area * area_scale < params_.min_area) continue;
      Polygon2<double> poly;
      for (const std::uint32_t s : rings[o])
        poly.outer.push_back(grid.to_point(sites_[s]));
      for (const std::size_t h : holes_of[o]) {
        std::vector<Point2d> ring;
        for (const std::uint32_t s : rings[h])
          ring.push_back(grid.to_point(sites_[s]));
        poly.holes.push_back(std::move(ring));
      }
      pieces.emplace_back(std::move(poly), find(rings[o].front()));
    }
    std::stable_sort(pieces.begin(), pieces.end(),
                     [](const auto& a, const auto& b) { return a.first.area() > b.first.area(); });
    for (std::size_t k = 0; k < pieces.size(); ++k) {
      if (piece_of_root_[pieces[k].second] < 0)
        piece_of_root_[pieces[k].second] = static_cast<std::int32_t>(k);
      result.push_back(std::move(pieces[k].first));
    }
    return result;
  }

  /// Union-find root with path halving.
  std::uint32_t find(std::uint32_t i) {
    while (parent_[i] != i)
      i = parent_[i] = parent_[parent_[i]];
    return i;
  }

  static constexpr std::size_t npos = static_cast<std::size_t>(-1);

  /// The unused boundary edge leaving the end of edge `cur`, first clockwise from `cur` reversed.
  std::size_t next_edge(std::size_t cur) const {
    const std::uint32_t v = boundary_[cur].to;
    auto lo = std::lower_bound(boundary_.begin(), boundary_.end(), DirectedEdge{v, 0});
    std::size_t best = npos;
    double best_angle = 0;
    const cell_type& pv = sites_[v];
    const cell_type& pu = sites_[boundary_[cur].from];
    const double back = std::atan2(double(pu[1] - pv[1]), double(pu[0] - pv[0]));
    for (auto it = lo; it != boundary_.end() && it->from == v; ++it) {
      const auto k = static_cast<std::size_t>(it - boundary_.begin());
      if (used_[k]) continue;
      const cell_type& pw = sites_[it->to];
      const double out = std::atan2(double(pw[1] - pv[1]), double(pw[0] - pv[0]));
      double cw = back - out;  // clockwise angle from `back` to `out`, in (0, 2 pi]
      while (cw <= 0)
        cw += 2 * std::numbers::pi;
      while (cw > 2 * std::numbers::pi)
        cw -= 2 * std::numbers::pi;
      if (best == npos || cw < best_angle) {
        best = k;
        best_angle = cw;
      }
    }
    return best;
  }

  /// Twice the signed area of a ring of site indices, in grid steps squared.
  double signed_area2(const std::vector<std::uint32_t>& ring) const {
    double s = 0;
    for (std::size_t i = 0, n = ring.size(); i < n; ++i) {
      const cell_type& p = sites_[ring[i]];
      const cell_type& q = sites_[ring[(i + 1) % n]];
      s += double(p[0]) * double(q[1]) - double(q[0]) * double(p[1]);
    }
    return s;
  }

  /// True when some vertex of `inner` not on `outer` lies inside it; the rings of one alpha
  /// shape never cross, so one such vertex decides.
  bool ring_contains(const std::vector<std::uint32_t>& outer,
                     const std::vector<std::uint32_t>& inner) const {
    namespace bg = boost::geometry;
    using point = bg::model::d2::point_xy<double>;
    bg::model::ring<point, false, false> ring;  // counter-clockwise, open
    for (const std::uint32_t t : outer)
      ring.emplace_back(double(sites_[t][0]), double(sites_[t][1]));
    for (const std::uint32_t s : inner) {
      if (std::find(outer.begin(), outer.end(), s) != outer.end()) continue;
      return bg::within(point(double(sites_[s][0]), double(sites_[s][1])), ring);
    }
    return false;
  }

  ConcaveHullParams params_;
  std::vector<std::pair<cell_type, std::uint32_t>> keyed_;  // snapped point, input index
  std::vector<cell_type> sites_;
  std::vector<std::uint32_t> site_of_point_;
  std::vector<std::uint32_t> parent_;        // union-find over sites
  std::vector<std::int32_t> piece_of_root_;  // union-find root -> polygon index or -1
  std::vector<std::uint32_t> face_;
  std::vector<DirectedEdge> edges_;
  std::vector<DirectedEdge> boundary_;
  std::vector<std::uint8_t> used_;
};

/// The alpha-shape hulls of a 2D point set (see ConcaveHull::compute).
template <PointCloudOf<2> C>
[[nodiscard]] std::vector<Polygon2<double>> concave_hull(const C& cloud,
                                                         const ConcaveHullParams& params = {}) {
  return ConcaveHull(params).compute(cloud);
}

}  // namespace rangenav
