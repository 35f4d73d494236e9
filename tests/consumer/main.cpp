// Uses the installed rangenav headers: compiles only if the package exports its include path,
// C++20 and its dependencies (Eigen, Boost, nanoflann).
#include <cstdio>
#include <rangenav/rangenav.hpp>

int main() {
  const rangenav::LaserScan<double> scan(-1.0, 0.5, 0.0, 10.0, {1.0, 2.0, 3.0, 4.0, 5.0});
  const rangenav::Pose2d pose{1.0, 2.0, 0.5};
  const auto p = pose.transform_point(scan.valid_points().front());
  std::printf("rangenav consumer: %zu valid beams, first point in the world (%.3f, %.3f)\n",
              scan.valid_count(), p.x(), p.y());
  return scan.valid_count() == 5 ? 0 : 1;
}
