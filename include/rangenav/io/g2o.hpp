#pragma once
// g2o pose-graph files (Kümmerle et al., "g2o: A General Framework for Graph Optimization", ICRA
// 2011): the format of the standard pose-graph benchmarks (intel, MIT, M3500, sphere2500, ...).
//
//   VERTEX_SE2 id x y θ
//   EDGE_SE2 a b x y θ  I11 I12 I13 I22 I23 I33
//   VERTEX_SE3:QUAT id x y z qx qy qz qw
//   EDGE_SE3:QUAT a b x y z qx qy qz qw  I11 I12 … I16 I22 … I66
//   FIX id [id …]
//
// An edge measures the pose of vertex b in the frame of vertex a; the information matrix is
// given as its upper triangle, row by row, in g2o's error coordinates (2D: x, y, θ; 3D: x, y, z,
// qx, qy, qz). Blank lines and lines starting with '#' are skipped; any other element is an
// error, as is a file that mixes 2D and 3D elements.
//
// Vertices are returned sorted by id and edges refer to them by index. A vertex that appears only
// in edges (CSAIL.g2o and manhattan.g2o have no VERTEX lines) is placed by chaining: from the
// vertex with the next lower id through an edge between the two (the odometry chain), otherwise
// breadth-first from the placed vertices through the edges in file order; a part of the graph
// with no placed vertex starts at the identity. Malformed lines raise io_error naming the file,
// the line and the field; memory grows only with the number of records read, which
// ReaderLimits bounds with the line length (ids go through a hash map, never index an array).

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <istream>
#include <ostream>
#include <string>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <variant>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/lie.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/io/line_reader.hpp"
#include "rangenav/io/reader_limits.hpp"
#include "rangenav/io/trajectory.hpp"

namespace rangenav::io {

/// A g2o vertex: a pose with the file's id.
template <int D>
struct G2oVertex {
  std::int64_t id{0};                                           ///< the id in the file
  Transform<D, double> pose{Transform<D, double>::Identity()};  ///< the pose in the world frame
  bool fixed{false};                                            ///< named by a FIX line
};

/// A g2o edge: the pose of vertex `to` measured in the frame of vertex `from`.
template <int D>
struct G2oEdge {
  std::size_t from{0};  ///< index into G2oGraph::vertices (not the file's id)
  std::size_t to{0};    ///< index into G2oGraph::vertices
  Transform<D, double> measurement{Transform<D, double>::Identity()};  ///< Z
  /// Ω, symmetric positive semidefinite, in g2o's error coordinates (x, y, θ or x, y, z, qx, qy,
  /// qz).
  lie::PoseMatrix<D, double> information{lie::PoseMatrix<D, double>::Identity()};
};

/// The content of a g2o file of one dimension.
template <int D>
struct G2oGraph {
  static constexpr int dimension = D;  ///< 2 or 3
  std::vector<G2oVertex<D>> vertices;  ///< sorted by id
  std::vector<G2oEdge<D>> edges;       ///< in file order
  std::size_t chained_vertices{0};     ///< vertices without a VERTEX line, placed by chaining
};

/// A g2o file: 2D (VERTEX_SE2 / EDGE_SE2) or 3D (VERTEX_SE3:QUAT / EDGE_SE3:QUAT).
using G2oFile = std::variant<G2oGraph<2>, G2oGraph<3>>;

namespace detail {

inline constexpr std::string_view g2o_where = "g2o";

struct G2oRawEdge {
  std::int64_t from;
  std::int64_t to;
  std::size_t line;
};

inline bool parse_id(std::string_view token, std::int64_t& value) {
  const char* first = token.data();
  const char* last = first + token.size();
  const auto [end, ec] = std::from_chars(first, last, value);
  return ec == std::errc() && end == last && first != last;
}

template <class Fail>
std::int64_t g2o_id(std::string_view token, std::size_t field, const Fail& fail) {
  std::int64_t id = 0;
  if (!parse_id(token, id))
    fail("field " + std::to_string(field) + " is not an integer vertex id: '" + std::string(token) +
         "'");
  return id;
}

template <class Fail>
double g2o_number(std::string_view token, std::size_t field, const Fail& fail) {
  double value = 0;
  if (!parse_double(token, value) || !std::isfinite(value))
    fail("field " + std::to_string(field) + " is not a finite number: '" + std::string(token) +
         "'");
  return value;
}

// The pose of tokens[first …]: x y θ (2D) or x y z qx qy qz qw (3D), fields numbered from 1.
template <int D, class Fail>
Transform<D, double> g2o_pose(const std::vector<std::string_view>& tokens, std::size_t first,
                              const Fail& fail) {
  Transform<D, double> pose = Transform<D, double>::Identity();
  if constexpr (D == 2) {
    const double x = g2o_number(tokens[first], first + 1, fail);
    const double y = g2o_number(tokens[first + 1], first + 2, fail);
    const double theta = g2o_number(tokens[first + 2], first + 3, fail);
    pose = make_transform2(x, y, normalize_angle(theta));
  } else {
    double v[7];
    for (std::size_t k = 0; k < 7; ++k)
      v[k] = g2o_number(tokens[first + k], first + k + 1, fail);
    Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);  // Eigen's order is (w, x, y, z)
    const double norm = q.norm();
    // Printed unit quaternions are unit to their precision; anything else is not a rotation.
    if (!(std::abs(norm - 1.0) <= 1e-3))
      fail("quaternion (fields " + std::to_string(first + 4) + "-" + std::to_string(first + 7) +
           ") has norm " + ::rangenav::detail::format_value(norm) + ", not 1");
    q.normalize();
    pose.linear() = q.toRotationMatrix();
    pose.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  }
  return pose;
}

// The information matrix from its upper triangle at tokens[first …].
template <int D, class Fail>
lie::PoseMatrix<D, double> g2o_information(const std::vector<std::string_view>& tokens,
                                           std::size_t first, const Fail& fail) {
  constexpr int k = lie::pose_dof<D>;
  lie::PoseMatrix<D, double> information;
  std::size_t field = first;
  for (int r = 0; r < k; ++r)
    for (int c = r; c < k; ++c, ++field)
      information(r, c) = information(c, r) = g2o_number(tokens[field], field + 1, fail);
  const Eigen::LDLT<lie::PoseMatrix<D, double>> ldlt(information);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive())
    fail("information matrix (fields " + std::to_string(first + 1) + "-" + std::to_string(field) +
         ") is not positive semidefinite");
  return information;
}

template <int D>
struct G2oReader {
  std::vector<std::pair<std::int64_t, Transform<D, double>>> vertices;
  std::vector<std::size_t> vertex_lines;
  std::vector<G2oRawEdge> raw_edges;
  std::vector<G2oEdge<D>> edges;                            // from/to filled in at the end
  std::vector<std::pair<std::int64_t, std::size_t>> fixed;  // id, line
};

// Places every vertex without a VERTEX line by chaining (see the file comment).
template <int D>
void g2o_chain(G2oGraph<D>& graph, const std::vector<bool>& given) {
  const std::size_t n = graph.vertices.size();
  std::vector<bool> placed = given;
  std::vector<std::vector<std::size_t>> incident(n);
  for (std::size_t e = 0; e < graph.edges.size(); ++e) {
    incident[graph.edges[e].from].push_back(e);
    incident[graph.edges[e].to].push_back(e);
  }
  // Places the other end of edge e from its placed end; true if it placed something.
  const auto place_through = [&](std::size_t e, std::size_t from_vertex) {
    const G2oEdge<D>& edge = graph.edges[e];
    const std::size_t other = edge.from == from_vertex ? edge.to : edge.from;
    if (placed[other]) return std::size_t(-1);
    const auto& base = graph.vertices[from_vertex].pose;
    graph.vertices[other].pose = edge.from == from_vertex
                                     ? Transform<D, double>(base * edge.measurement)
                                     : Transform<D, double>(base * edge.measurement.inverse());
    placed[other] = true;
    return other;
  };
  std::size_t next_seed = 0;
  for (;;) {
    // Odometry chain: i from i − 1.
    for (std::size_t i = 1; i < n; ++i) {
      if (placed[i] || !placed[i - 1]) continue;
      for (const std::size_t e : incident[i]) {
        const G2oEdge<D>& edge = graph.edges[e];
        if ((edge.from == i - 1 && edge.to == i) || (edge.from == i && edge.to == i - 1)) {
          place_through(e, i - 1);
          break;
        }
      }
    }
    // Breadth-first from everything placed.
    std::deque<std::size_t> queue;
    for (std::size_t i = 0; i < n; ++i)
      if (placed[i]) queue.push_back(i);
    while (!queue.empty()) {
      const std::size_t u = queue.front();
      queue.pop_front();
      for (const std::size_t e : incident[u]) {
        const std::size_t v = place_through(e, u);
        if (v != std::size_t(-1)) queue.push_back(v);
      }
    }
    while (next_seed < n && placed[next_seed])
      ++next_seed;
    if (next_seed == n) break;
    // A part with no placed vertex: its lowest id starts at the identity.
    graph.vertices[next_seed].pose = Transform<D, double>::Identity();
    placed[next_seed] = true;
  }
}

template <int D>
G2oGraph<D> g2o_finish(G2oReader<D>& reader, std::string_view name) {
  const auto fail_at = [&](std::size_t line, const std::string& message) {
    throw io_error("rangenav: g2o: " + std::string(name) + ":" + std::to_string(line) + ": " +
                   message);
  };
  // Every id in a VERTEX line or an edge, sorted.
  std::unordered_map<std::int64_t, std::size_t> index;
  std::vector<std::int64_t> ids;
  for (const auto& [id, pose] : reader.vertices)
    if (index.emplace(id, 0).second) ids.push_back(id);
  for (const G2oRawEdge& raw : reader.raw_edges)
    for (const std::int64_t id : {raw.from, raw.to})
      if (index.emplace(id, 0).second) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  G2oGraph<D> graph;
  graph.vertices.resize(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    index[ids[i]] = i;
    graph.vertices[i].id = ids[i];
  }
  std::vector<bool> given(ids.size(), false);
  for (std::size_t k = 0; k < reader.vertices.size(); ++k) {
    const auto& [id, pose] = reader.vertices[k];
    const std::size_t i = index[id];
    if (given[i])
      fail_at(reader.vertex_lines[k], "vertex " + std::to_string(id) + " defined twice");
    given[i] = true;
    graph.vertices[i].pose = pose;
  }
  graph.edges = std::move(reader.edges);
  for (std::size_t e = 0; e < graph.edges.size(); ++e) {
    graph.edges[e].from = index[reader.raw_edges[e].from];
    graph.edges[e].to = index[reader.raw_edges[e].to];
  }
  for (const auto& [id, line] : reader.fixed) {
    const auto it = index.find(id);
    if (it == index.end())
      fail_at(line,
              "FIX names vertex " + std::to_string(id) + ", which is in no VERTEX or EDGE line");
    graph.vertices[it->second].fixed = true;
  }
  for (const bool g : given)
    if (!g) ++graph.chained_vertices;
  if (graph.chained_vertices > 0) g2o_chain(graph, given);
  return graph;
}

// Lines of a stream with LineReader's interface (next, line_number, fail_line), each at most
// max_line_bytes long.
class IstreamLines {
 public:
  IstreamLines(std::istream& in, std::string_view name, std::size_t max_line_bytes)
      : in_(in), name_(name), max_line_(max_line_bytes) {}
  bool next(std::string_view& line) {
    bool too_long = false;
    if (!read_bounded_line(in_, text_, max_line_, too_long)) {
      if (in_.bad()) throw io_error("rangenav: g2o: " + name_ + ": read error");
      return false;
    }
    ++line_number_;
    if (too_long)
      fail_line("line longer than ReaderLimits::max_line_bytes = " + std::to_string(max_line_) +
                " bytes");
    if (!text_.empty() && text_.back() == '\r') text_.pop_back();
    line = text_;
    return true;
  }
  [[nodiscard]] std::size_t line_number() const { return line_number_; }
  [[noreturn]] void fail_line(std::string_view message) const {
    throw io_error("rangenav: g2o: " + name_ + ":" + std::to_string(line_number_) + ": " +
                   std::string(message));
  }

 private:
  std::istream& in_;
  std::string name_;
  std::size_t max_line_;
  std::string text_;
  std::size_t line_number_{0};
};

// Reads every line of `lines` (a LineReader or IstreamLines); see read_g2o.
template <class Lines>
G2oFile read_g2o_lines(Lines& lines, std::string_view name, const ReaderLimits& limits) {
  int dimension = 0;
  std::size_t records = 0;
  G2oReader<2> planar;
  G2oReader<3> spatial;
  std::string_view text;
  std::vector<std::string_view> tokens;
  const auto fail = [&lines](std::string_view message) { lines.fail_line(message); };
  while (lines.next(text)) {
    split_whitespace(text, tokens);
    if (tokens.empty() || tokens[0].front() == '#') continue;
    const std::size_t line = lines.line_number();
    const std::string_view tag = tokens[0];
    // Every vertex, edge and fixed id is a record (FIX lines may list many ids).
    records += tag == "FIX" ? std::max<std::size_t>(tokens.size() - 1, 1) : 1;
    if (records > limits.max_points)
      fail(exceeds_limit("record count", records, "max_points", limits.max_points));
    const auto expect = [&](std::size_t count) {
      if (tokens.size() != count)
        fail(std::string(tag) + ": expected " + std::to_string(count) + " fields, found " +
             std::to_string(tokens.size()));
    };
    const auto set_dimension = [&](int d) {
      if (dimension != 0 && dimension != d)
        fail(std::string(tag) + " in a " + std::to_string(dimension) + "D file");
      dimension = d;
    };
    if (tag == "VERTEX_SE2") {
      expect(5);
      set_dimension(2);
      planar.vertices.emplace_back(g2o_id(tokens[1], 2, fail), g2o_pose<2>(tokens, 2, fail));
      planar.vertex_lines.push_back(line);
    } else if (tag == "EDGE_SE2") {
      expect(12);
      set_dimension(2);
      const std::int64_t a = g2o_id(tokens[1], 2, fail), b = g2o_id(tokens[2], 3, fail);
      if (a == b) fail("EDGE_SE2 joins vertex " + std::to_string(a) + " to itself");
      planar.raw_edges.push_back({a, b, line});
      planar.edges.push_back(
          {0, 0, g2o_pose<2>(tokens, 3, fail), g2o_information<2>(tokens, 6, fail)});
    } else if (tag == "VERTEX_SE3:QUAT") {
      expect(9);
      set_dimension(3);
      spatial.vertices.emplace_back(g2o_id(tokens[1], 2, fail), g2o_pose<3>(tokens, 2, fail));
      spatial.vertex_lines.push_back(line);
    } else if (tag == "EDGE_SE3:QUAT") {
      expect(31);
      set_dimension(3);
      const std::int64_t a = g2o_id(tokens[1], 2, fail), b = g2o_id(tokens[2], 3, fail);
      if (a == b) fail("EDGE_SE3:QUAT joins vertex " + std::to_string(a) + " to itself");
      spatial.raw_edges.push_back({a, b, line});
      spatial.edges.push_back(
          {0, 0, g2o_pose<3>(tokens, 3, fail), g2o_information<3>(tokens, 10, fail)});
    } else if (tag == "FIX") {
      if (tokens.size() < 2) fail("FIX: expected at least one vertex id");
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        const std::int64_t id = g2o_id(tokens[k], k + 1, fail);
        planar.fixed.emplace_back(id, line);
        spatial.fixed.emplace_back(id, line);
      }
    } else {
      fail("unsupported element '" + std::string(tag) +
           "' (supported: VERTEX_SE2, EDGE_SE2, VERTEX_SE3:QUAT, EDGE_SE3:QUAT, FIX)");
    }
  }
  if (dimension == 0)
    throw io_error("rangenav: g2o: " + std::string(name) +
                   ": no VERTEX_SE2, EDGE_SE2, VERTEX_SE3:QUAT or EDGE_SE3:QUAT line");
  if (dimension == 2) return g2o_finish(planar, name);
  return g2o_finish(spatial, name);
}

inline void append_g2o_number(std::string& out, double value) {
  char buffer[32];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);  // shortest exact
  out.push_back(' ');
  out.append(buffer, static_cast<std::size_t>(end - buffer));
}

}  // namespace detail

/// Reads a g2o file (plain or gzip); see the file comment. Throws io_error for an unreadable
/// file, a malformed line (naming file, line and field), a line longer than
/// limits.max_line_bytes or more than limits.max_points records (vertices, edges, fixed ids).
inline G2oFile read_g2o(const std::filesystem::path& path, const ReaderLimits& limits = {}) {
  limits.validate(detail::g2o_where);
  LineReader lines(path, detail::g2o_where, limits.max_line_bytes);
  return detail::read_g2o_lines(lines, path.string(), limits);
}

/// Reads g2o text from a stream; `name` stands for the source in error messages.
inline G2oFile read_g2o(std::istream& in, std::string_view name = "<stream>",
                        const ReaderLimits& limits = {}) {
  limits.validate(detail::g2o_where);
  detail::IstreamLines lines(in, name, limits.max_line_bytes);
  return detail::read_g2o_lines(lines, name, limits);
}

/// Reads a g2o file that must hold D-dimensional elements; throws io_error for the other kind.
template <int D>
G2oGraph<D> read_g2o_as(const std::filesystem::path& path, const ReaderLimits& limits = {}) {
  G2oFile file = read_g2o(path, limits);
  if (auto* graph = std::get_if<G2oGraph<D>>(&file)) return std::move(*graph);
  throw io_error("rangenav: g2o: " + path.string() + ": holds " + std::to_string(5 - D) +
                 "D elements, expected " + std::to_string(D) + "D");
}

/// Writes a graph as g2o text: VERTEX lines (sorted as stored), EDGE lines, then one FIX line
/// naming the fixed vertices. Numbers are printed in their shortest exact form, so reading the
/// output gives the same doubles (rotations pass through a quaternion or an angle, exact to
/// rounding). Throws invalid_argument for an edge naming a vertex index out of range or a
/// non-finite value, io_error when the stream fails.
template <int D>
void write_g2o(std::ostream& out, const G2oGraph<D>& graph) {
  constexpr std::string_view where = "write_g2o";
  constexpr int k = lie::pose_dof<D>;
  const auto append_pose = [](std::string& line, const Transform<D, double>& pose) {
    for (int i = 0; i < D; ++i)
      detail::append_g2o_number(line, pose.translation()(i));
    if constexpr (D == 2) {
      detail::append_g2o_number(line, rotation_angle(pose));
    } else {
      const Eigen::Quaterniond q(Eigen::Matrix3d(pose.linear()));
      for (const double v : {q.x(), q.y(), q.z(), q.w()})
        detail::append_g2o_number(line, v);
    }
  };
  std::string line;
  for (std::size_t i = 0; i < graph.vertices.size(); ++i) {
    const auto& v = graph.vertices[i];
    if (!v.pose.matrix().allFinite())
      ::rangenav::detail::throw_invalid_argument(where, "vertex", i, "has a non-finite pose");
    line = D == 2 ? "VERTEX_SE2 " : "VERTEX_SE3:QUAT ";
    line.append(std::to_string(v.id));
    append_pose(line, v.pose);
    line.push_back('\n');
    detail::write_checked(out, line, where);
  }
  for (std::size_t e = 0; e < graph.edges.size(); ++e) {
    const auto& edge = graph.edges[e];
    if (edge.from >= graph.vertices.size() || edge.to >= graph.vertices.size())
      ::rangenav::detail::throw_invalid_argument(where, "edge", e,
                                                 "names a vertex index out of range");
    if (!edge.measurement.matrix().allFinite() || !edge.information.allFinite())
      ::rangenav::detail::throw_invalid_argument(where, "edge", e, "has a non-finite value");
    line = D == 2 ? "EDGE_SE2 " : "EDGE_SE3:QUAT ";
    line.append(std::to_string(graph.vertices[edge.from].id)).push_back(' ');
    line.append(std::to_string(graph.vertices[edge.to].id));
    append_pose(line, edge.measurement);
    for (int r = 0; r < k; ++r)
      for (int c = r; c < k; ++c)
        detail::append_g2o_number(line, edge.information(r, c));
    line.push_back('\n');
    detail::write_checked(out, line, where);
  }
  line = "FIX";
  for (const auto& v : graph.vertices)
    if (v.fixed) line.append(" ").append(std::to_string(v.id));
  if (line.size() > 3) {
    line.push_back('\n');
    detail::write_checked(out, line, where);
  }
}

/// Writes a g2o file; throws io_error when it cannot be written.
template <int D>
void write_g2o(const std::filesystem::path& path, const G2oGraph<D>& graph) {
  detail::write_file(path, "write_g2o", [&](std::ostream& out) { write_g2o(out, graph); });
}

}  // namespace rangenav::io
