#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <sstream>
#include <string>
#include <variant>

#include "rangenav/core/lie.hpp"
#include "rangenav/io/g2o.hpp"
#include "scratch_dir.hpp"
#include "test_support.hpp"

using namespace rangenav;

namespace {

// The message of the io_error that reading `text` raises ("" when it reads).
std::string read_error(const std::string& text) {
  std::istringstream in(text);
  try {
    (void)io::read_g2o(in, "test.g2o");
  } catch (const io_error& e) {
    return e.what();
  }
  return "";
}

template <int D>
io::G2oGraph<D> read_text(const std::string& text) {
  std::istringstream in(text);
  return std::get<io::G2oGraph<D>>(io::read_g2o(in, "test.g2o"));
}

// A random graph: n vertices with random poses and ids, random edges with random positive
// definite information.
template <int D>
io::G2oGraph<D> random_graph(std::mt19937& rng, std::size_t n) {
  constexpr int k = lie::pose_dof<D>;
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  io::G2oGraph<D> g;
  for (std::size_t i = 0; i < n; ++i) {
    lie::PoseTangent<D> xi;
    for (int c = 0; c < k; ++c)
      xi(c) = u(rng);
    g.vertices.push_back({static_cast<std::int64_t>(10 * i) - 7, lie::se_exp<D>(xi), i == 1});
  }
  for (std::size_t e = 0; e < 2 * n; ++e) {
    const std::size_t a = e % n, b = (e * 7 + 3) % n;
    if (a == b) continue;
    lie::PoseTangent<D> xi;
    lie::PoseMatrix<D> m;
    for (int c = 0; c < k; ++c)
      xi(c) = u(rng);
    for (int c = 0; c < k * k; ++c)
      m(c / k, c % k) = u(rng);
    lie::PoseMatrix<D> information = m * m.transpose() + lie::PoseMatrix<D>::Identity();
    information.template triangularView<Eigen::StrictlyLower>() = information.transpose();
    g.edges.push_back({a, b, lie::se_exp<D>(xi), information});
  }
  return g;
}

template <int D>
void check_round_trip() {
  std::mt19937 rng(D);
  const auto g = random_graph<D>(rng, 12);
  std::ostringstream out;
  io::write_g2o(out, g);
  const auto back = read_text<D>(out.str());
  REQUIRE(back.vertices.size() == g.vertices.size());
  REQUIRE(back.edges.size() == g.edges.size());
  CHECK(back.chained_vertices == 0);
  for (std::size_t i = 0; i < g.vertices.size(); ++i) {
    CHECK(back.vertices[i].id == g.vertices[i].id);
    CHECK(back.vertices[i].fixed == g.vertices[i].fixed);
    CHECK((back.vertices[i].pose.matrix() - g.vertices[i].pose.matrix()).norm() < 1e-14);
  }
  for (std::size_t e = 0; e < g.edges.size(); ++e) {
    CHECK(back.edges[e].from == g.edges[e].from);
    CHECK(back.edges[e].to == g.edges[e].to);
    CHECK((back.edges[e].measurement.matrix() - g.edges[e].measurement.matrix()).norm() < 1e-14);
    CHECK(back.edges[e].information == g.edges[e].information);  // shortest exact digits
  }
}

// Edges only, in the order "odometry i−1 → i, then loop closures into i": every vertex is placed
// by chaining the odometry from the lowest id, which starts at the identity.
template <int D>
void check_chaining() {
  std::mt19937 rng(100 + D);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  constexpr int k = lie::pose_dof<D>;
  std::vector<Transform<D>> odometry;
  std::ostringstream text;
  const auto pose_text = [](const Transform<D>& t) {
    std::ostringstream s;
    s.precision(17);
    for (int i = 0; i < D; ++i)
      s << t.translation()(i) << ' ';
    if constexpr (D == 2) {
      s << rotation_angle(t);
    } else {
      const Eigen::Quaterniond q(Eigen::Matrix3d(t.linear()));
      s << q.x() << ' ' << q.y() << ' ' << q.z() << ' ' << q.w();
    }
    return s.str();
  };
  const std::string info = D == 2 ? " 1 0 0 1 0 1" : " 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1";
  const std::string tag = D == 2 ? "EDGE_SE2 " : "EDGE_SE3:QUAT ";
  for (int i = 1; i <= 8; ++i) {
    lie::PoseTangent<D> xi;
    for (int c = 0; c < k; ++c)
      xi(c) = u(rng);
    odometry.push_back(lie::se_exp<D>(xi));
    text << tag << (i - 1) << ' ' << i << ' ' << pose_text(odometry.back()) << info << '\n';
    // A loop closure from vertex 0 with a wrong measurement: not used for placing.
    if (i >= 3)
      text << tag << 0 << ' ' << i << ' ' << pose_text(Transform<D>::Identity()) << info << '\n';
  }
  const auto g = read_text<D>(text.str());
  REQUIRE(g.vertices.size() == 9);
  CHECK(g.chained_vertices == 9);
  Transform<D> expected = Transform<D>::Identity();
  for (std::size_t i = 0; i < g.vertices.size(); ++i) {
    CHECK(g.vertices[i].id == static_cast<std::int64_t>(i));
    CHECK((g.vertices[i].pose.matrix() - expected.matrix()).norm() < 1e-12);
    if (i < odometry.size()) expected = expected * odometry[i];
  }
}

}  // namespace

TEST_CASE("g2o: write then read reproduces 2D and 3D graphs", "[io][g2o]") {
  check_round_trip<2>();
  check_round_trip<3>();
}

TEST_CASE("g2o: vertices without VERTEX lines are placed by chaining the odometry", "[io][g2o]") {
  check_chaining<2>();
  check_chaining<3>();
}

TEST_CASE("g2o: given vertices anchor the chain; edges may run backwards; FIX marks vertices",
          "[io][g2o]") {
  // Vertex 5 is given; 6 is reached backwards through the edge 6 → 5 (X6 = X5·Z⁻¹); 9 is in a
  // part of its own and starts at the identity.
  const auto g = read_text<2>(
      "# a comment\n"
      "\n"
      "VERTEX_SE2 5 1 2 0.5\n"
      "EDGE_SE2 6 5 1 0 1.5707963267948966 1 0 0 1 0 1\n"
      "EDGE_SE2 9 10 2 0 0 1 0 0 1 0 1\n"
      "FIX 5 10\n");
  REQUIRE(g.vertices.size() == 4);
  CHECK(g.chained_vertices == 3);
  CHECK(g.vertices[0].id == 5);
  CHECK(g.vertices[0].fixed);
  CHECK(g.vertices[3].fixed);
  CHECK_FALSE(g.vertices[1].fixed);
  const Transform2d x6 =
      make_transform2(1.0, 2.0, 0.5) * make_transform2(1.0, 0.0, M_PI / 2).inverse();
  CHECK((g.vertices[1].pose.matrix() - x6.matrix()).norm() < 1e-12);
  CHECK(g.vertices[2].pose.isApprox(Transform2d::Identity()));
  CHECK((g.vertices[3].pose.translation() - Point2d(2, 0)).norm() < 1e-12);
  CHECK(g.edges[0].from == 1);
  CHECK(g.edges[0].to == 0);
  // Angles are normalised; quaternions normalised.
  const auto h = read_text<2>("VERTEX_SE2 0 0 0 7\n");
  CHECK(rotation_angle(h.vertices[0].pose) == Approx(7 - 2 * M_PI));
}

TEST_CASE("g2o: malformed lines raise io_error naming file, line and field", "[io][g2o]") {
  const std::string v = "VERTEX_SE2 0 0 0 0\n";
  const std::string e = "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n";
  CHECK_THAT(read_error(v + "VERTEX_SE2 1 0 0\n"),
             Catch::Contains("test.g2o:2") && Catch::Contains("expected 5 fields, found 4"));
  CHECK_THAT(read_error(v + "VERTEX_SE2 1 0 x 0\n"),
             Catch::Contains("test.g2o:2") && Catch::Contains("field 4 is not a finite number"));
  CHECK_THAT(read_error(v + "VERTEX_SE2 1 0 nan 0\n"), Catch::Contains("field 4"));
  CHECK_THAT(read_error(v + "VERTEX_SE2 1.5 0 0 0\n"),
             Catch::Contains("field 2 is not an integer"));
  CHECK_THAT(read_error(v + v), Catch::Contains("test.g2o:2") && Catch::Contains("defined twice"));
  CHECK_THAT(read_error("EDGE_SE2 3 3 1 0 0 1 0 0 1 0 1\n"), Catch::Contains("to itself"));
  CHECK_THAT(read_error("EDGE_SE2 0 1 1 0 0 1 0 0 -1 0 1\n"),
             Catch::Contains("fields 7-12") && Catch::Contains("not positive semidefinite"));
  CHECK_THAT(read_error(e + "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"),
             Catch::Contains("test.g2o:2") && Catch::Contains("in a 2D file"));
  CHECK_THAT(read_error("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 0.5\n"),
             Catch::Contains("quaternion (fields 6-9) has norm 0.5"));
  CHECK_THAT(read_error("VERTEX_XY 0 1 2\n"), Catch::Contains("unsupported element 'VERTEX_XY'"));
  CHECK_THAT(read_error(v + "FIX 3\n"),
             Catch::Contains("test.g2o:2") && Catch::Contains("FIX names vertex 3"));
  CHECK_THAT(read_error("FIX\n"), Catch::Contains("at least one vertex id"));
  CHECK_THAT(read_error("# nothing\n"), Catch::Contains("no VERTEX_SE2"));
  CHECK_THAT(read_error(v + "VERTEX_SE2 99999999999999999999 0 0 0\n"), Catch::Contains("field 2"));
  CHECK(read_error(v + e) == "");
  // A file that does not exist, and the writer's checks.
  test::ScratchDir dir("g2o");
  CHECK_THROWS_AS(io::read_g2o(dir / "missing.g2o"), io_error);
  io::G2oGraph<2> bad;
  bad.vertices.resize(1);
  bad.edges.push_back({0, 3, Transform2d::Identity(), Eigen::Matrix3d::Identity()});
  std::ostringstream out;
  CHECK_THROWS_AS(io::write_g2o(out, bad), invalid_argument);
}

TEST_CASE("g2o: files round-trip through the file system, and a 3D file is not 2D", "[io][g2o]") {
  test::ScratchDir dir("g2o");
  std::mt19937 rng(5);
  const auto g = random_graph<3>(rng, 5);
  io::write_g2o(dir / "graph.g2o", g);
  const auto back = io::read_g2o_as<3>(dir / "graph.g2o");
  CHECK(back.edges.size() == g.edges.size());
  CHECK_THROWS_AS(io::read_g2o_as<2>(dir / "graph.g2o"), io_error);
}

TEST_CASE("g2o: the benchmark graphs have the sizes PROVENANCE.md lists", "[io][g2o][data]") {
  const struct {
    const char* file;
    int dimension;
    std::size_t vertices, edges, chained;
  } expected[] = {{"intel.g2o", 2, 1728, 2512, 0},          {"MIT.g2o", 2, 808, 827, 0},
                  {"CSAIL.g2o", 2, 1045, 1172, 1045},       {"manhattan.g2o", 2, 3500, 5453, 3500},
                  {"parking-garage.g2o", 3, 1661, 6275, 0}, {"sphere2500.g2o", 3, 2500, 4949, 0}};
  for (const auto& x : expected) {
    const auto path = test::data_file_or_skip(std::string("pose-graphs/") + x.file);
    if (path.empty()) continue;
    const auto file = io::read_g2o(path);
    INFO(x.file);
    CHECK(static_cast<int>(file.index()) + 2 == x.dimension);
    std::visit(
        [&](const auto& g) {
          CHECK(g.vertices.size() == x.vertices);
          CHECK(g.edges.size() == x.edges);
          CHECK(g.chained_vertices == x.chained);
          // Vertex ids 0 … n−1, so index = id.
          CHECK(g.vertices.back().id == static_cast<std::int64_t>(x.vertices - 1));
        },
        file);
  }
}

TEST_CASE("g2o: reader limits bound the records and the line length", "[io][g2o]") {
  io::ReaderLimits limits;
  limits.max_points = 3;
  std::istringstream three("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nFIX 0 1\n");
  CHECK_THROWS_WITH(io::read_g2o(three, "test.g2o", limits),
                    Catch::Contains("test.g2o:3") && Catch::Contains("max_points = 3"));
  limits = {};
  limits.max_line_bytes = 16;
  std::istringstream long_line("VERTEX_SE2 0 0 0 0.000000000001\n");
  CHECK_THROWS_WITH(io::read_g2o(long_line, "test.g2o", limits),
                    Catch::Contains("test.g2o:1") && Catch::Contains("max_line_bytes = 16"));
  test::ScratchDir dir("g2o");
  const auto file = dir.write("long.g2o", std::string(100, 'x'));
  CHECK_THROWS_WITH(io::read_g2o(file, limits), Catch::Contains("max_line_bytes"));
}
