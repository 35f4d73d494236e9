// Writes the seed corpus of every harness in tests/fuzz: small files made by the library's own
// writers (PCD, PLY, TUM, x-y-theta, g2o, world files) and, for the formats rangenav only reads,
// files laid out as their specifications say (CARMEN logs with each record type and a saturation
// value, PGM images, relations, MRPT pose matrices), plain and gzip-compressed where the reader
// takes both. Usage: make_seeds OUTPUT_DIR (creates OUTPUT_DIR/<harness>/...).
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "rangenav/io/g2o.hpp"
#include "rangenav/io/pcd.hpp"
#include "rangenav/io/ply.hpp"
#include "rangenav/io/trajectory.hpp"
#include "rangenav/sim/world_file.hpp"

#ifdef RANGENAV_HAVE_ZLIB
#include <zlib.h>
#endif

namespace fs = std::filesystem;
using namespace rangenav;

namespace {

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

// A gzip copy next to `path` (name + ".gz") when zlib is there.
void write_gzip_copy(const fs::path& path, const std::string& text) {
#ifdef RANGENAV_HAVE_ZLIB
  const fs::path gz_path = path.string() + ".gz";
  gzFile gz = gzopen(gz_path.c_str(), "wb9");
  if (gz == nullptr) throw std::runtime_error("cannot write " + gz_path.string());
  gzwrite(gz, text.data(), static_cast<unsigned>(text.size()));
  gzclose(gz);
#else
  (void)path;
  (void)text;
#endif
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

template <class Scalar>
Cloud<3, Scalar> small_cloud(bool attributes, bool organized) {
  Cloud<3, Scalar> c;
  const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
  using P = typename Cloud<3, Scalar>::point_type;
  c.points = {P::Zero(), P(Scalar(1.5), Scalar(-2), Scalar(0.25)), P::Constant(nan),
              P(Scalar(1e3), Scalar(2e-3), Scalar(-7))};
  if (attributes) {
    c.intensities = {0.f, 0.5f, 1.f, 100.f};
    c.colors = {Rgba{255, 0, 0, 255}, Rgba{0, 255, 0, 128}, Rgba{0, 0, 255, 0}, Rgba{1, 2, 3, 4}};
    c.normals = {{0, 0, 1}, {1, 0, 0}, {nan, nan, nan}, {0, 1, 0}};
  }
  c.width = organized ? 2 : 4;
  c.height = organized ? 2 : 1;
  return c;
}

void pcd_seeds(const fs::path& dir) {
  int k = 0;
  for (const auto format :
       {io::PcdFormat::ascii, io::PcdFormat::binary, io::PcdFormat::binary_compressed})
    for (const bool attributes : {false, true})
      for (const bool organized : {false, true}) {
        io::write_pcd(dir / ("d" + std::to_string(k++) + ".pcd"),
                      small_cloud<double>(attributes, organized), format);
        io::write_pcd(dir / ("f" + std::to_string(k++) + ".pcd"),
                      small_cloud<float>(attributes, organized), format);
      }
  // PCL's own layout: a padding field, COUNT > 1 and a float-encoded rgb.
  write_text(dir / "pcl.pcd",
             "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z _ rgb descriptor\nSIZE 4 4 4 1 4 2\n"
             "TYPE F F F U F I\nCOUNT 1 1 1 4 1 3\nWIDTH 2\nHEIGHT 1\n"
             "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n"
             "1 2 3 0 0 0 0 4.2108e+06 1 2 3\n-1 0.5 2 1 2 3 4 255 -4 5 6\n");
}

void ply_seeds(const fs::path& dir) {
  int k = 0;
  for (const auto format : {io::PlyFormat::ascii, io::PlyFormat::binary_little_endian})
    for (const bool attributes : {false, true})
      for (const bool organized : {false, true}) {
        io::write_ply(dir / ("d" + std::to_string(k++) + ".ply"),
                      small_cloud<double>(attributes, organized), format);
        io::write_ply(dir / ("f" + std::to_string(k++) + ".ply"),
                      small_cloud<float>(attributes, organized), format);
      }
  // A mesh: a face element with a list property after the vertices.
  write_text(dir / "mesh.ply",
             "ply\nformat ascii 1.0\ncomment mesh\nelement vertex 3\nproperty float x\n"
             "property float y\nproperty float z\nproperty uchar red\nproperty uchar green\n"
             "property uchar blue\nelement face 1\nproperty list uchar int vertex_indices\n"
             "end_header\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n");
}

void carmen_seeds(const fs::path& dir) {
  // Scans of a room seen from a moving robot whose laser reports "no return" as 50.0 (no PARAM
  // says so), then every other record type.
  std::ostringstream log;
  log << "# CARMEN Logfile\n# file format is one message per line\n"
         "PARAM robot_front_laser_max 81.9 0 host 0\nPARAM robot_width 0.5 0 host 0\n";
  for (int s = 0; s < 4; ++s) {
    const double x = 0.2 * s;
    log << "FLASER 9";
    for (int i = 0; i < 9; ++i)
      log << ' ' << (i % 3 == 0 ? 50.0 : 2.0 + 0.1 * i + x);
    log << ' ' << x << " 0 0.1 " << x << " 0 0.1 " << 100.5 + s << " host " << 0.5 * s << '\n';
    log << "ODOM " << x << " 0 0.1 0.2 0 0 " << 100.6 + s << " host " << 0.5 * s + 0.1 << '\n';
  }
  log << "RLASER 3 1 2 nan 0 0 0 0 0 0 0 h 0\n"
         "RAWLASER1 0 -1.5 3 0.75 30 0.01 0 5 1 2 3 40 0.5 5 10 20 30 40 50 102.5 laser 3\n"
         "ROBOTLASER1 0 -0.5 1 0.5 20 0.01 0 3 3 20 4 2 7 8 0.1 0.2 0.3 -0.4 1.5 -0.6 0.1 0.2 "
         "0.3 0.4 0.5 103.25 robot 4\n"
         "NEFF 1 2 3\nTRUEPOS 0 0 0 0 0 0 1 h 1\n";
  write_text(dir / "room.clf", log.str());
  write_gzip_copy(dir / "room.clf", log.str());
  // Logs with rounded, zero and negative timestamps and another saturation value.
  write_text(dir / "stamps.clf",
             "FLASER 4 32.767 32.767 1 2 0 0 0 0 0 0 0 h 0\n"
             "FLASER 4 32.767 32.767 1 2 1 0 0 1 0 0 -5 h -5\n"
             "FLASER 4 32.767 32.767 1 2 2 0 0 2 0 0 1.13486e+09 h 1.13486e+09\n");
}

void pgm_seeds(const fs::path& dir) {
  std::string p5 = "P5\n# map\n4 3\n255\n";
  for (int i = 0; i < 12; ++i)
    p5.push_back(static_cast<char>(i * 20));
  write_text(dir / "map8.pgm", p5);
  std::string p5w = "P5 2 2 65535\n";
  for (const int v : {0, 1000, 40000, 65535}) {
    p5w.push_back(static_cast<char>(v >> 8));
    p5w.push_back(static_cast<char>(v & 0xff));
  }
  write_text(dir / "map16.pgm", p5w);
  write_text(dir / "plain.pgm", "P2\n# plain\n3 2\n15\n0 15 7\n# row\n3 0 15\n");
}

void trajectory_seeds(const fs::path& dir) {
  const std::vector<double> t{0.0, 0.5, 1.25};
  const std::vector<Pose2d> planar{{0, 0, 0}, {1, 0.5, 1.5}, {-2, 3, -3.1}};
  std::vector<Transform3d> poses(3, Transform3d::Identity());
  poses[1].translate(Eigen::Vector3d(1, 2, 3));
  poses[2].rotate(Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, 2, 3).normalized()));
  io::write_tum(dir / "traj.tum", t, poses);
  io::write_tum(dir / "planar.tum", t, planar);
  io::write_xytheta(dir / "traj.xyt", t, planar);
  write_gzip_copy(dir / "traj.tum", read_text(dir / "traj.tum"));
  write_text(dir / "comments.tum", "# t x y z qx qy qz qw\n\n1 0 0 0 0 0 0 1\r\n");
  io::write_kitti(dir / "poses.kitti", poses);
  write_text(dir / "matrix4.txt", "# T\n0 -1 0 0.2\n1 0 0 0.05\n0 0 1 0.9\n0 0 0 1\n");
  write_text(dir / "matrix3.txt", "1 0 0 1\n0 1 0 2\n0 0 1 3\n");
}

void relations_seeds(const fs::path& dir) {
  const std::string text =
      "1134864629.895182 1134864630.095182 0.10 0.01 0 0 0 0.02\n"
      "1134864630.095182 1134864631.5 -0.5 0.25 0 0 0 -3.1\n# comment\n\n"
      "1134864629.895182 1134864631.5 -0.4 0.3 0 0 0 1.2\n";
  write_text(dir / "rel.relations", text);
  write_gzip_copy(dir / "rel.relations", text);
}

void mrpt_seeds(const fs::path& dir) {
  Transform3d t = Transform3d::Identity();
  t.rotate(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -1, 0.5).normalized()));
  t.translation() = Eigen::Vector3d(1.5, -0.25, 3);
  std::string bytes;
  for (int col = 0; col < 4; ++col)
    for (int row = 0; row < 4; ++row) {
      const auto v = static_cast<float>(t.matrix()(row, col));
      char b[4];
      std::memcpy(b, &v, 4);  // little-endian hosts only: what the fuzz build runs on
      bytes.append(b, 4);
    }
  write_text(dir / "pose.mat.raw", bytes);
  write_gzip_copy(dir / "pose.mat", bytes);
}

void world_seeds(const fs::path& dir) {
  sim::World w;
  w.set_ceiling_height(2.6);
  w.add_polygon(std::vector<Point2d>{{0, 0}, {6, 0}, {6, 4}, {0, 4}}, 2.5);
  w.add_wall({3, 0}, {3, 1.5}, 2.0);
  w.add_box({{1.5, 3}, {0.8, 0.5}, 0.3, 0.0, 0.7});
  w.add_cylinder({{4.5, 1}, 0.15, 0.0, 1.1});
  w.add_door({{3, 1.5}, std::numbers::pi / 2, 0.9, 0.4});
  w.add_hole({{5, 3}, {0.6, 0.6}, 0.0, 0.2});
  std::ostringstream out;
  sim::write_world(out, w);
  write_text(dir / "room.world", out.str());
  write_text(dir / "polygon.world",
             "# a polygon and a wall with its default height\npolygon 2.5 0 0 4 0 4 3 0 3\n"
             "wall 1 1 2 2\n");
}

void g2o_seeds(const fs::path& dir) {
  // A square loop in 2D and a short chain in 3D, written by write_g2o.
  io::G2oGraph<2> planar;
  for (int k = 0; k < 4; ++k) {
    io::G2oVertex<2> v;
    v.id = k;
    v.pose = make_transform2(k % 2 == 0 ? 0.0 : 1.0, k < 2 ? 0.0 : 1.0, 0.5 * k);
    v.fixed = k == 0;
    planar.vertices.push_back(v);
  }
  for (std::size_t k = 0; k < 4; ++k) {
    io::G2oEdge<2> e;
    e.from = k;
    e.to = (k + 1) % 4;
    e.measurement = planar.vertices[k].pose.inverse() * planar.vertices[e.to].pose;
    e.information.diagonal() << 100, 100, 400;
    e.information(0, 1) = e.information(1, 0) = 5;
    planar.edges.push_back(e);
  }
  std::ostringstream out2;
  io::write_g2o(out2, planar);
  write_text(dir / "loop2d.g2o", out2.str());
  write_gzip_copy(dir / "loop2d.g2o", out2.str());
  io::G2oGraph<3> spatial;
  for (int k = 0; k < 3; ++k) {
    io::G2oVertex<3> v;
    v.id = 10 + k;
    v.pose = Transform3d::Identity();
    v.pose.rotate(Eigen::AngleAxisd(0.3 * k, Eigen::Vector3d(0.1, 0.2, 1).normalized()));
    v.pose.translation() = Eigen::Vector3d(k, 0.5 * k, 0.1);
    spatial.vertices.push_back(v);
  }
  for (std::size_t k = 0; k + 1 < 3; ++k) {
    io::G2oEdge<3> e;
    e.from = k;
    e.to = k + 1;
    e.measurement = spatial.vertices[k].pose.inverse() * spatial.vertices[k + 1].pose;
    spatial.edges.push_back(e);
  }
  std::ostringstream out3;
  io::write_g2o(out3, spatial);
  write_text(dir / "chain3d.g2o", out3.str());
  // Edges only (as CSAIL.g2o): the reader chains the vertices.
  write_text(dir / "edges_only.g2o",
             "EDGE_SE2 0 1 1 0 0 10 0 0 10 0 10\nEDGE_SE2 1 2 1 0 1.57 10 0 0 10 0 10\n"
             "EDGE_SE2 2 0 -1 1 -1.57 1 0 0 1 0 1\nFIX 0\n");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: make_seeds OUTPUT_DIR\n";
    return 2;
  }
  const fs::path root = argv[1];
  const auto dir = [&](const char* name) {
    const fs::path d = root / name;
    fs::create_directories(d);
    return d;
  };
  pcd_seeds(dir("pcd"));
  ply_seeds(dir("ply"));
  carmen_seeds(dir("carmen"));
  pgm_seeds(dir("pgm"));
  trajectory_seeds(dir("trajectory"));
  relations_seeds(dir("slam_relations"));
  mrpt_seeds(dir("mrpt_pose"));
  world_seeds(dir("world"));
  g2o_seeds(dir("g2o"));
  return 0;
}
