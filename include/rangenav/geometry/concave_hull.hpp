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
// regularised alpha shape make the same choice); its boundary is every Delaunay edge (the dual of
// a Voronoi edge) with a kept face on one side only. The boundary edges are chained into rings,
// interior on the left, and a vertex where two kept parts touch is split so that every ring is
// simple; rings come out counter-clockwise (outer boundaries) or clockwise (holes), and each hole
// goes to the outer ring around it.
//
// Input coordinates are snapped to an integer grid (IntegerGrid, default 1 mm) as Boost.Polygon
// requires; duplicates after snapping count once, and hull vertices are grid points.
//
// Thinning (optional, ConcaveHullParams::thinning; beyond the paper, for speed): the shape's
// detail cannot exceed alpha, yet a dense plane of a range camera puts 10^5 points into the
// triangulation. With thinning = f in (0, 1/2] the plane is covered by square cells of edge
// c = f * alpha. A cell whose 8 neighbours all hold points is interior: its points are replaced by
// one site at the cell's centre; the interior sites form a lattice whose Delaunay faces have
// circumradius c / sqrt 2 <= alpha / (2 sqrt 2), so the interior stays filled. Every other
// occupied cell is on the boundary layer and keeps, for each empty neighbour (corner neighbours:
// see "Boundary corners"), its input point farthest towards that neighbour (its snapped grid
// point, as a site): the outermost points, through which the alpha shape's boundary runs, are
// kept as they are, and an empty circle of radius > alpha >= 2 c, which is what removes faces
// from the shape, is still bounded by them. The outline, holes and pieces come out
// as without thinning up to a fraction of a cell (tested: areas within 0.3 %), with far fewer
// sites (a 1 m^2 plane sampled every 5 mm: 40,000 points, about 1,600 + 300 sites at alpha
// 5 cm). Every input point keeps its piece: a thinned point belongs to a site of its cell.
//
// Boundary corners (ConcaveHullParams::all_corners = false, the default; an approximation, for
// speed): a boundary cell whose empty corner neighbour lies along a straight run of boundary
// cells (of the two edge neighbours next to that corner, one is empty: the outward side, the
// other occupied: the next cell on the run) keeps its extreme towards that corner only where
// the extreme lies strictly outside the chord between the outward extremes of the cell and of the
// next cell on the run; at convex corners and notches (both edge neighbours empty, or both
// occupied) it is always kept. A dropped corner extreme lies on or inside that chord, so the
// outline there moves outwards to the chord, by what the extreme sat inside it. No proof that
// the alpha shape keeps its pieces: measured against the unthinned alpha shape. On the benchmark
// frame's 12 hulls (alpha 5 cm, grid 5 mm) 25 % fewer sites (5,945 -> 4,485), the same pieces
// and holes, the same points in every largest piece (one point of a small second piece joins
// it), the largest pieces' areas within 0.54 % of the unthinned ones (all corners: 0.54 %),
// their sum 0.025 % above it (all corners: 0.044 % below); tested on synthetic shapes against
// the unthinned shape as for thinning. Dropping every corner extreme along straight runs
// (without the chord test) kept 4,403 sites but cut a disc's area by 0.47 %.
//
// Sparse interior (ConcaveHullParams::sparse_interior, with thinning; for speed, the Voronoi
// diagram costs about 7,500 instructions per site): interior cells whose cell coordinates are
// both even keep their centre sites; an interior cell with an odd coordinate drops its site when
// the even-even cells it leans on are interior: its 4 diagonal neighbours when both coordinates
// are odd (its 5 x 5 block of cells is occupied), else its 2 neighbours along the odd axis (a
// 5 x 3 block). The alpha shape is exactly the same. Proof: every point of an occupied cell is
// still within c sqrt 2 of a site: a boundary cell holds sites of its own, a kept interior cell
// its centre, and a point of a removed cell lies within c sqrt 2 of the centre of a diagonal
// neighbour it leans on (the worst place is its centre) or within c sqrt 5 / 2 of one along its
// odd axis; a Delaunay face whose circumcentre lies there has circumradius <= c sqrt 2 < alpha
// and is kept. A face that is not kept (radius R > alpha >= 2 c, empty open disc D) would, if D
// held a removed centre s, also hold a disc E of radius r = c sqrt 2 + epsilon (< R) centred
// within r of s (slide E from s towards D's centre); E's centre lies in s's 3 x 3 block, occupied
// cells (s's cell is interior), so a site is closer to it than r: inside E and D, which is empty.
// So the faces that are not kept are the same with and without the removed sites, the removed
// sites are not on the convex hull, and the kept faces fill the same region: same boundary edges,
// same rings, same pieces (tested against sparse_interior = false). Leaning on even cells that
// may be boundary cells (their sites can be anywhere in them) breaks the first step: removing
// every odd cell whose 3 x 3 block is occupied made that test fail. On the benchmark frame this
// rule keeps 416 sites fewer than requiring the 5 x 5 block of every removed cell.
// Sparser interiors are allowed by the same argument but not used: the proof only needs every
// point near a removed centre within some rho < alpha of a site, so a deep region could use the
// lattice spanned by (3, 0) and (1, 3) cells (acute Delaunay triangles, circumradius 1.90 c <
// 2 c; 1 site per 9 cells instead of 4) where every lattice cell within 3.8 c is interior; but
// typical planes of a depth frame are too small for deep regions, and the bookkeeping costs
// more than the sites it removes. Letting an odd cell lean on one axis neighbour or two
// diagonals (every point within 1.80 c of a site) needs its 5 x 5 block (less the corners)
// occupied, and removes fewer sites than the rule above.

#include <boost/geometry/algorithms/within.hpp>
#include <boost/geometry/geometries/point_xy.hpp>
#include <boost/geometry/geometries/ring.hpp>
#include <boost/geometry/strategies/strategies.hpp>
#include <boost/polygon/voronoi.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <numbers>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/geometry/integer_grid.hpp"
#include "rangenav/geometry/planar_polygon.hpp"

namespace rangenav {

/// Parameters of the alpha-shape hull (see the file comment).
struct ConcaveHullParams {
  /// Largest circumradius (m) of a Delaunay triangle that belongs to the shape. A few times the
  /// point spacing: larger values close gaps and bays, smaller ones split the shape.
  double alpha = 0.05;
  /// Grid the points are snapped to for Boost.Polygon (m).
  double resolution = 0.001;
  /// Drop polygons smaller than this (m^2); 0 keeps every piece.
  double min_area = 0.0;
  /// Thinning cell edge as a fraction of alpha, in [0, 0.5]; 0 = every point is a site (see the
  /// file comment). Cells smaller than 2 grid steps are not thinned.
  double thinning = 0.0;
  /// With thinning: interior cells with an odd cell coordinate drop their site where the even
  /// cells next to them are interior (within the interior, a quarter of the sites are kept); the
  /// alpha shape is the same (see the file comment). false: every interior cell keeps its site.
  bool sparse_interior = true;
  /// With thinning: true keeps a boundary cell's extreme towards every empty neighbour; false
  /// (default) drops a corner extreme along a straight run of boundary cells where it lies on or
  /// inside the chord of the neighbouring outward extremes, a fifth fewer sites; the outline
  /// moves outwards to that chord (see the file comment).
  bool all_corners = false;

  /// Throws invalid_argument for a non-positive alpha or resolution, a negative min_area or a
  /// thinning outside [0, 0.5]; `where` names the caller.
  void validate(std::string_view where) const {
    detail::require_positive(where, "params.alpha", alpha);
    detail::require_positive(where, "params.resolution", resolution);
    detail::require_non_negative(where, "params.min_area", min_area);
    if (!(thinning >= 0 && thinning <= 0.5))
      detail::throw_invalid_argument(where, "params.thinning", thinning, "must be in [0, 0.5]");
  }
};

/// Builds alpha-shape hulls; owns its scratch buffers, so repeated calls allocate little.
class ConcaveHull {
 public:
  /// An integer grid cell.
  using cell_type = IntegerGrid::cell_type;

  /// A hull builder with these parameters; throws invalid_argument for invalid ones.
  explicit ConcaveHull(const ConcaveHullParams& params = {}) : params_(params) {
    params_.validate("ConcaveHull");
  }

  /// The parameters.
  [[nodiscard]] const ConcaveHullParams& params() const { return params_; }

  /// Reserves the per-point scratch for inputs of up to `points` points and touches it, so that
  /// a larger input later neither reallocates it nor faults in fresh pages (see
  /// PlaneExtractor::reserve).
  void reserve(std::size_t points) {
    cell_index_.reserve(points);
    next_in_cell_.reserve(points);
    site_of_point_.reserve(points);
  }

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
    const double inv = 1.0 / grid.resolution;
    // The box of the scaled coordinates, and whether every point is finite and fits the grid;
    // a point snaps to round_half_away of its scaled coordinates, which is monotonic, so the
    // box's corners snap to the box of the grid points. Points are snapped again where needed
    // (select_sites), none is stored. The box is taken of the coordinates and scaled after:
    // a product by inv > 0 is monotonic too, so that is the box of the scaled coordinates.
    Eigen::Array2d lo = Eigen::Array2d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Array2d hi = -lo, nan = Eigen::Array2d::Zero();  // x and y side by side
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Array2d p = traits::point(cloud, i).template cast<double>().array();
      lo = p.min(lo);  // min and max in place (Eigen's operand order)
      hi = p.max(hi);
      nan += p - p;  // stays 0 unless p is NaN or infinite (min and max may skip a NaN)
    }
    lo *= inv;
    hi *= inv;
    const bool fits = (nan == 0).all() && (lo.abs() <= IntegerGrid::limit).all() &&
                      (hi.abs() <= IntegerGrid::limit).all();
    if (!fits)  // NaN or out of range: the first such point, named by the grid in its message
      for (std::size_t i = 0; i < n; ++i)
        (void)grid.snap(traits::point(cloud, i).template cast<double>(), where,
                        "cloud[" + std::to_string(i) + "]");
    if (n > 0) {
      lo_ = {round_half_away(lo.x()), round_half_away(lo.y())};
      hi_ = {round_half_away(hi.x()), round_half_away(hi.y())};
    }
    const auto snap = [&cloud, inv](std::size_t i) -> cell_type {
      // The coordinates read one by one: a copy of the point went through the stack.
      const auto& p = traits::point(cloud, i);
      return {round_half_away(static_cast<double>(p.x()) * inv),
              round_half_away(static_cast<double>(p.y()) * inv)};
    };
    select_sites(n, snap);
    auto result = build(n, grid);
    if (piece_of_point) {  // per site, then per point: a site's own point takes its site's
      piece_of_site_.resize(sites_.size());  // piece, every other point its cell's (thinned)
      for (std::size_t s = 0; s < sites_.size(); ++s) {
        const std::uint32_t root = find(static_cast<std::uint32_t>(s));
        piece_of_site_[s] = root < piece_of_root_.size() ? piece_of_root_[root] : -1;
      }
      piece_of_point->resize(n);
      // A point that is no site (thinned away) takes the site of its cell's representative:
      // an interior cell's first point (or, sparse interior, its even neighbour's), a boundary
      // cell's first extreme. That piece is looked up once per occupied cell (cell_slot_ holds it
      // from here on), not once per point.
      constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();
      if (thinned_) {
        for (const std::uint32_t c : occupied()) {
          const std::uint32_t slot = cell_slot_[c];
          const std::uint32_t rep =
              slot <= boundary_tag_ ? slot : extreme_[(none - 1 - slot) * directions];
          cell_slot_[c] = static_cast<std::uint32_t>(piece_of_site_[site_of_point_[rep]]);
        }
        const std::uint32_t* const slots = cell_slot_.data();
        const std::uint32_t* const cells = cell_index_.data();
        std::int32_t* const piece = piece_of_point->data();
        for (std::size_t i = 0; i < n; ++i)
          piece[i] = static_cast<std::int32_t>(slots[cells[i]]);
      }
      // The points that name a site (all points without thinning) take their site's piece.
      for (const auto& [cell, index] : keyed_)
        (*piece_of_point)[index] = piece_of_site_[site_of_point_[index]];
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

  /// Fills keyed_ with the sites to triangulate from the `n` input points, `snap(i)` being the
  /// grid point of point i (lo_ and hi_ their box); with thinning, cell_index_, cell_slot_,
  /// boundary_tag_ and extreme_ say which site a thinned point belongs to (compute).
  template <class Snap>
  void select_sites(std::size_t n, const Snap& snap) {
    thinned_ = false;
    const auto keep_all = [&] {
      keyed_.resize(n);
      for (std::size_t i = 0; i < n; ++i)
        keyed_[i] = {snap(i), static_cast<std::uint32_t>(i)};
    };
    const double cell_steps = std::floor(params_.thinning * params_.alpha / params_.resolution);
    if (!(cell_steps >= 2) || n < 64) return keep_all();
    const auto k = static_cast<std::int64_t>(std::min(cell_steps, IntegerGrid::limit));
    // Floor division by k through a multiplication by 1 / k (an integer division per point
    // costs more than the rest of the pass), corrected by one step where rounding misses.
    const double inv_k = 1.0 / double(k);
    const auto cell_of = [k, inv_k](std::int32_t v) -> std::int64_t {
      auto q = static_cast<std::int64_t>(std::floor(double(v) * inv_k));
      q += (q + 1) * k <= v ? 1 : 0;
      q -= q * k > v ? 1 : 0;
      return q;
    };
    const std::int32_t gx0 = lo_[0], gy0 = lo_[1], gx1 = hi_[0], gy1 = hi_[1];
    const std::int64_t x0 = cell_of(gx0), x1 = cell_of(gx1);  // floor division is monotonic
    const std::int64_t y0 = cell_of(gy0), y1 = cell_of(gy1);
    // A dense cell array with a margin of one empty cell on each side; skipped (no thinning)
    // when it would be much larger than the input.
    const std::int64_t w = x1 - x0 + 3, h = y1 - y0 + 3;
    if (w * h > std::int64_t(4 * n) + 4096) return keep_all();
    constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();
    const auto uw = static_cast<std::size_t>(w);
    thinned_ = true;
    cell_slot_.assign(static_cast<std::size_t>(w * h), none);  // a point, then slot

    // The cell of every point. Where the box is not much wider than the input is large, by
    // tables of the cell column and row offset of every grid coordinate in it, filled by
    // walking the coordinates (a cell starts every k steps), which costs less than cell_of
    // twice per point; otherwise cell_of per point. Both give cell_of's cells.
    const auto span_x = static_cast<std::size_t>(std::int64_t(gx1) - gx0 + 1);
    const auto span_y = static_cast<std::size_t>(std::int64_t(gy1) - gy0 + 1);
    const bool by_table = span_x + span_y <= 4 * n;
    if (by_table) {
      const auto fill = [&](std::vector<std::uint32_t>& table, std::int32_t from, std::size_t span,
                            std::int64_t first, std::int64_t stride) {
        table.resize(span);
        std::int64_t cell = first;  // cell_of(from)
        std::int64_t next = (cell + 1) * k;
        std::int64_t value = 1 * stride;
        for (std::size_t i = 0; i < span; ++i) {
          if (std::int64_t(from) + std::int64_t(i) == next) {
            ++cell;
            next += k;
            value += stride;
          }
          table[i] = static_cast<std::uint32_t>(value);
        }
      };
      fill(column_of_, gx0, span_x, x0, 1);
      fill(row_of_, gy0, span_y, y0, w);
    }
    // Raw pointers in the loops over the points: the vectors' members would otherwise be
    // reloaded from memory for every point.
    const std::size_t most = std::min(n, static_cast<std::size_t>(w * h));
    if (occupied_.size() < most) occupied_.resize(most);  // never shrunk: no refill per call
    // Every cell's points form a list through next_in_cell_, last point first: cell_slot_ holds
    // its head (the cell's last point), so that the pass over the boundary cells' points below
    // walks their lists and skips the interior points without looking at them.
    std::uint32_t* const slots = cell_slot_.data();
    std::uint32_t* const cells = cell_index_.get(n);
    std::uint32_t* const chain = next_in_cell_.get(n);
    std::uint32_t* const first_seen = occupied_.data();
    std::size_t count = 0;
    const auto bin = [&](std::size_t i, std::size_t c) {
      cells[i] = static_cast<std::uint32_t>(c);
      const std::uint32_t head = slots[c];
      chain[i] = head;
      slots[c] = static_cast<std::uint32_t>(i);
      if (head == none) first_seen[count++] = static_cast<std::uint32_t>(c);
    };
    if (by_table) {
      const cell_type origin{gx0, gy0};
      const std::uint32_t* const columns = column_of_.data();
      const std::uint32_t* const rows = row_of_.data();
      for (std::size_t i = 0; i < n; ++i) {
        const cell_type g = snap(i);
        std::array<std::uint32_t, 2> o;  // offsets into the tables, taken as a pair (in SIMD)
        for (std::size_t a = 0; a < 2; ++a)
          o[a] = static_cast<std::uint32_t>(g[a] - origin[a]);
        bin(i, std::size_t(rows[o[1]]) + columns[o[0]]);
      }
    } else {
      for (std::size_t i = 0; i < n; ++i) {
        const cell_type g = snap(i);
        bin(i, static_cast<std::size_t>((cell_of(g[1]) - y0 + 1) * w + (cell_of(g[0]) - x0 + 1)));
      }
    }
    occupied_count_ = count;
    // The 8 neighbour directions; a boundary cell keeps, for each direction in which its
    // neighbour is empty, its point farthest that way (its extreme towards the empty side).
    static constexpr std::array<std::array<int, 2>, 8> dir{
        {{-1, -1}, {0, -1}, {1, -1}, {-1, 0}, {1, 0}, {-1, 1}, {0, 1}, {1, 1}}};
    const auto offset = [uw](const std::array<int, 2>& d) {
      return static_cast<std::ptrdiff_t>(d[1]) * static_cast<std::ptrdiff_t>(uw) + d[0];
    };
    // Pass over the occupied cells: the mask of empty neighbours, and for boundary cells a block
    // of 8 extreme slots. cell_slot_ then holds a point of the cell (the head of its list) for
    // interior cells, and 'none - 1 - block' for boundary cells (block_head_ the head).
    mask_.clear();
    block_cell_.clear();
    block_head_.clear();
    extreme_.clear();
    for (const std::uint32_t c : occupied()) {
      std::uint8_t mask = 0;
      for (std::size_t d = 0; d < dir.size(); ++d) {
        const std::uint32_t nb =
            cell_slot_[static_cast<std::size_t>(static_cast<std::ptrdiff_t>(c) + offset(dir[d]))];
        if (nb == none) mask = static_cast<std::uint8_t>(mask | (1u << d));
      }
      if (mask == 0) continue;
      const auto block = static_cast<std::uint32_t>(mask_.size());
      mask_.push_back(mask);
      block_cell_.push_back(c);
      block_head_.push_back(cell_slot_[c]);
      extreme_.insert(extreme_.end(), dir.size(), none);
      cell_slot_[c] = none - 1 - block;
    }
    // cell_slot_ values >= boundary_tag are boundary blocks; below are first points.
    const std::uint32_t boundary_tag = none - 1 - static_cast<std::uint32_t>(mask_.size());
    boundary_tag_ = boundary_tag;
    if (params_.sparse_interior) sparsen_interior(uw, x0, y0);
    // Interior cells that keep a site: one at the cell's centre, named by a point of the cell.
    keyed_.clear();
    for (const std::uint32_t c : occupied()) {
      const std::uint32_t slot = cell_slot_[c];
      if (slot > boundary_tag || cell_index_[slot] != c) continue;  // boundary, or sparse
      const auto cx = static_cast<std::int64_t>(c % uw) - 1 + x0;
      const auto cy = static_cast<std::int64_t>(c / uw) - 1 + y0;
      keyed_.push_back({cell_type{static_cast<std::int32_t>(cx * k + k / 2),
                                  static_cast<std::int32_t>(cy * k + k / 2)},
                        slot});
    }
    // The extremes of the boundary cells, by walking their lists of points (the interior points
    // are not visited); a boundary point is snapped again (the same grid point), a slot keeps its
    // extreme's. A list runs from the last point to the first, and a point at least as far as
    // the best so far replaces it: of several farthest points, the first one is the extreme.
    // How far a point is towards dir[d] is its projection on dir[d], compared as integers.
    extreme_at_.resize(extreme_.size());
    for (std::size_t block = 0; block < mask_.size(); ++block) {
      const unsigned mask = mask_[block];
      std::uint32_t* const best = extreme_.data() + block * dir.size();
      cell_type* const at = extreme_at_.data() + block * dir.size();
      std::array<std::int64_t, 8> farthest;
      farthest.fill(std::numeric_limits<std::int64_t>::min());
      for (std::uint32_t i = block_head_[block]; i != none; i = chain[i]) {
        const cell_type g = snap(i);
        const std::int64_t x = g[0], y = g[1];
        const std::array<std::int64_t, 8> towards{-x - y, -y, x - y, -x, x, y - x, y, x + y};
        for (unsigned m = mask; m != 0; m &= m - 1) {
          const auto d = static_cast<std::size_t>(std::countr_zero(m));
          if (towards[d] < farthest[d]) continue;
          farthest[d] = towards[d];
          best[d] = i;
          at[d] = g;
        }
      }
    }
    // The extremes are the boundary sites (all_corners = false: a corner extreme along a straight
    // run only where it lies outside the chord between the edge extremes of its cell and of the
    // next cell on the run, see the file comment); every other point of a boundary cell belongs
    // to the site of its cell's first extreme (compute).
    // The corner directions in dir, the edge directions next to each: sideways (x), outwards (y).
    static constexpr std::array<std::size_t, 4> corners{0, 2, 5, 7}, sides{3, 4, 3, 4},
        outs{1, 1, 6, 6};
    for (std::size_t block = 0; block < mask_.size(); ++block) {
      const unsigned mask = mask_[block];
      const std::size_t at = block * dir.size();
      unsigned keep = mask;
      if (!params_.all_corners)
        for (std::size_t j = 0; j < corners.size(); ++j) {
          const std::size_t d = corners[j], side = sides[j], out = outs[j];
          const unsigned side_empty = (mask >> side) & 1u, out_empty = (mask >> out) & 1u;
          if (((mask >> d) & 1u) == 0 || side_empty == out_empty) continue;  // convex, notch
          // A straight run: `along` to the next cell on it, `normal` out of the occupied cells.
          const std::size_t normal = side_empty != 0 ? side : out;
          const std::size_t along = side_empty != 0 ? out : side;
          const std::size_t next_cell = static_cast<std::size_t>(
              static_cast<std::ptrdiff_t>(block_cell_[block]) + offset(dir[along]));
          const std::size_t next = none - 1 - cell_slot_[next_cell];  // a boundary block
          const cell_type& ua = extreme_at_[at + normal];
          const cell_type& ub = extreme_at_[next * dir.size() + normal];
          const cell_type& e = extreme_at_[at + d];
          // Normal of the chord ua -> ub on the outer side.
          std::int64_t mx = -(std::int64_t(ub[1]) - ua[1]), my = std::int64_t(ub[0]) - ua[0];
          const std::int64_t towards = mx * dir[normal][0] + my * dir[normal][1];
          if (towards == 0) continue;  // degenerate chord: kept
          if (towards < 0) {
            mx = -mx;
            my = -my;
          }
          if (mx * (std::int64_t(e[0]) - ua[0]) + my * (std::int64_t(e[1]) - ua[1]) <= 0)
            keep &= ~(1u << d);
        }
      std::uint32_t first = none;
      for (std::size_t d = 0; d < dir.size(); ++d) {
        if (!(keep & (1u << d))) continue;
        const std::uint32_t e = extreme_[at + d];
        if (first == none) first = e;
        bool seen = false;  // the same point may be extreme in several directions
        for (std::size_t d2 = 0; d2 < d; ++d2)
          seen = seen || ((keep >> d2) & 1u && extreme_[at + d2] == e);
        if (!seen) keyed_.push_back({extreme_at_[at + d], e});
      }
      extreme_[at] = first;  // from here on the block's representative
    }
  }

  /// Sparse interior (see the file comment): an interior cell with an odd (absolute) cell
  /// coordinate gets no site when the even-even cells it leans on are interior (its 4 diagonal
  /// neighbours when both coordinates are odd, else its 2 neighbours along the odd axis); its
  /// points are handed to the site of the one below or left of it (cell_slot_ takes that cell's
  /// first point). Those cells are never removed, so the order of the pass does not matter.
  void sparsen_interior(std::size_t w, std::int64_t x0, std::int64_t y0) {
    const std::uint32_t tag = boundary_tag_;  // at most: interior (a first point)
    const auto interior = [&](std::size_t c) { return cell_slot_[c] <= tag; };
    for (const std::uint32_t c : occupied()) {
      if (!interior(c)) continue;  // its 8 neighbours are occupied, none in the margin
      const std::int64_t ax = static_cast<std::int64_t>(c % w) - 1 + x0;
      const std::int64_t ay = static_cast<std::int64_t>(c / w) - 1 + y0;
      const auto ox = static_cast<std::size_t>(ax & 1), oy = static_cast<std::size_t>(ay & 1);
      if ((ox | oy) == 0) continue;
      const bool leans = ox != 0 && oy != 0
                             ? interior(c - 1 - w) && interior(c + 1 - w) && interior(c - 1 + w) &&
                                   interior(c + 1 + w)
                             : interior(c - ox - oy * w) && interior(c + ox + oy * w);
      if (leans) cell_slot_[c] = cell_slot_[c - ox - oy * w];
    }
  }

  std::vector<Polygon2<double>> build(std::size_t n, const IntegerGrid& grid) {
    namespace bp = boost::polygon;
    // Distinct grid points; site_of_point_ maps the points of keyed_ (every input point without
    // thinning) to their sites.
    std::sort(keyed_.begin(), keyed_.end());
    sites_.clear();
    std::uint32_t* const site_of_point = site_of_point_.get(n);
    for (const auto& [cell, index] : keyed_) {
      if (sites_.empty() || sites_.back() != cell) sites_.push_back(cell);
      site_of_point[index] = static_cast<std::uint32_t>(sites_.size() - 1);
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
    // in grid steps.
    const double alpha = params_.alpha / params_.resolution;
    const double alpha_sq = alpha * alpha;
    const auto& vertices = vd.vertices();
    kept_.resize(vertices.size());
    for (std::size_t i = 0; i < vertices.size(); ++i) {
      const auto& v = vertices[i];
      const cell_type& s0 = sites_[v.incident_edge()->cell()->source_index()];
      const double dx = v.x() - s0[0], dy = v.y() - s0[1];
      kept_[i] = dx * dx + dy * dy <= alpha_sq ? 1 : 0;
    }
    // Every Voronoi edge (a twin pair) is dual to the Delaunay edge between its two cells' sites
    // a and b, and its two vertices are the faces on either side. The Delaunay edge belongs to
    // the shape when a face on either side is kept (a and b are then in one piece), and to the
    // boundary when exactly one is, directed so that the kept face, i.e. its third site c, lies
    // on its left.
    const auto* vertex0 = vertices.data();
    const auto is_kept = [&](const auto* v) {
      return v != nullptr && kept_[static_cast<std::size_t>(v - vertex0)] != 0;
    };
    boundary_.clear();
    const auto& all_edges = vd.edges();
    for (std::size_t k = 0; k + 1 < all_edges.size(); k += 2) {  // twins are stored side by side
      const auto& e = all_edges[k];
      const bool k0 = is_kept(e.vertex0()), k1 = is_kept(e.vertex1());
      if (!k0 && !k1) continue;
      const auto a = static_cast<std::uint32_t>(e.cell()->source_index());
      const auto b = static_cast<std::uint32_t>(e.twin()->cell()->source_index());
      parent_[find(a)] = find(b);
      if (k0 && k1) continue;
      // The next (or previous) edge of a's cell meets e at the kept face's vertex; its twin's
      // cell is a third site of that face.
      const auto* side = k1 ? e.next() : e.prev();
      const auto c = static_cast<std::uint32_t>(side->twin()->cell()->source_index());
      const cell_type &pa = sites_[a], &pb = sites_[b], &pc = sites_[c];
      const double orient = double(pb[0] - pa[0]) * double(pc[1] - pa[1]) -
                            double(pb[1] - pa[1]) * double(pc[0] - pa[0]);
      boundary_.push_back(orient > 0 ? DirectedEdge{a, b} : DirectedEdge{b, a});
    }
    if (boundary_.empty()) return result;
    std::sort(boundary_.begin(), boundary_.end());

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

  /// std::round for |v| <= IntegerGrid::limit, without the library call or a branch (the
  /// fraction's comparisons are random, so a branch is mispredicted half of the time): the
  /// fraction v - t is exact, twice it too, and truncating 2 frac gives -1, 0 or 1 exactly where
  /// std::round rounds away from t (checked against std::round on 62 million values, halves and
  /// their neighbours included).
  static std::int32_t round_half_away(double v) {
    const auto t = static_cast<std::int32_t>(v);  // towards zero
    const double frac = v - double(t);
    return t + static_cast<std::int32_t>(frac + frac);
  }

  /// Union-find root with path halving.
  std::uint32_t find(std::uint32_t i) {
    while (parent_[i] != i)
      i = parent_[i] = parent_[parent_[i]];
    return i;
  }

  static constexpr std::size_t npos = static_cast<std::size_t>(-1);
  static constexpr std::size_t directions = 8;  // extreme_ slots per boundary cell

  /// The unused boundary edge leaving the end of edge `cur`, first clockwise from `cur` reversed.
  std::size_t next_edge(std::size_t cur) const {
    const std::uint32_t v = boundary_[cur].to;
    auto lo = std::lower_bound(boundary_.begin(), boundary_.end(), DirectedEdge{v, 0});
    std::size_t best = npos;
    double best_angle = 0;
    auto end = lo;  // the edges leaving v; with one unused, no angle is needed
    std::size_t unused = 0;
    for (; end != boundary_.end() && end->from == v; ++end)
      unused += used_[static_cast<std::size_t>(end - boundary_.begin())] ? 0 : 1;
    if (unused <= 1) {
      for (auto it = lo; it != end; ++it)
        if (!used_[static_cast<std::size_t>(it - boundary_.begin())])
          return static_cast<std::size_t>(it - boundary_.begin());
      return npos;
    }
    const cell_type& pv = sites_[v];
    const cell_type& pu = sites_[boundary_[cur].from];
    const double back = std::atan2(double(pu[1] - pv[1]), double(pu[0] - pv[0]));
    for (auto it = lo; it != end; ++it) {
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
  cell_type lo_{}, hi_{};                  // bounding box of the input's grid points
  std::uint32_t boundary_tag_ = 0;         // cell_slot_ above it: a boundary block
  bool thinned_ = false;                   // select_sites thinned: cells and slots are valid
  std::vector<std::uint32_t> cell_slot_;   // thinning cells: see select_sites
  std::vector<std::uint8_t> mask_;         // per boundary cell: its empty neighbours
  std::vector<std::uint32_t> block_cell_;  // per boundary cell: its cell
  std::vector<std::uint32_t> extreme_;     // per boundary cell: 8 extreme points
  std::vector<cell_type> extreme_at_;      // their grid points
  /// A per-point scratch array that grows without initialising its elements (a std::vector's
  /// resize would zero every element beyond its size, for each larger input again).
  class Scratch {
   public:
    std::uint32_t* get(std::size_t n) {
      if (n > capacity_) {
        data_ = std::make_unique_for_overwrite<std::uint32_t[]>(n);
        capacity_ = n;
      }
      return data_.get();
    }
    /// Grows to n elements, written once (zeros) so that their pages are mapped in here.
    void reserve(std::size_t n) {
      if (n <= capacity_) return;
      data_ = std::make_unique<std::uint32_t[]>(n);
      capacity_ = n;
    }
    [[nodiscard]] std::uint32_t* data() const { return data_.get(); }
    std::uint32_t& operator[](std::size_t i) { return data_[i]; }

   private:
    std::unique_ptr<std::uint32_t[]> data_;
    std::size_t capacity_ = 0;
  };
  std::vector<std::uint32_t> block_head_;  // per boundary cell: the head of its list of points
  Scratch cell_index_;                     // per input point: its thinning cell
  Scratch next_in_cell_;                   // per input point: the previous point of its cell
  std::vector<std::uint32_t> column_of_;   // per grid x in the box: its cell column + 1
  std::vector<std::uint32_t> row_of_;      // per grid y in the box: (its cell row + 1) * width
  std::vector<std::uint32_t> occupied_;    // the occupied thinning cells, in the order of their
  std::size_t occupied_count_ = 0;         // first points: the first occupied_count_ entries
  [[nodiscard]] std::span<const std::uint32_t> occupied() const {
    return {occupied_.data(), occupied_count_};
  }
  std::vector<std::pair<cell_type, std::uint32_t>> keyed_;  // site grid point, input index
  std::vector<cell_type> sites_;
  Scratch site_of_point_;                    // per point of keyed_: its site
  std::vector<std::uint32_t> parent_;        // union-find over sites
  std::vector<std::int32_t> piece_of_root_;  // union-find root -> polygon index or -1
  std::vector<std::int32_t> piece_of_site_;  // site -> polygon index or -1
  std::vector<std::uint8_t> kept_;  // per Voronoi vertex: its Delaunay face is in the shape
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
