// libFuzzer harness: read_world on arbitrary text, then rays cast through what it read (2D and 3D,
// with and without the index). The indexed casts must agree with the exhaustive ones.
#include <cmath>
#include <cstdlib>
#include <numbers>
#include <sstream>
#include <string>

#include "fuzz_support.hpp"
#include "rangenav/sim/world_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rangenav;
  fuzz::expect_success_or_error([&] {
    std::istringstream in{std::string(fuzz::as_text(data, size))};
    const sim::World world = sim::read_world(in, "fuzz.world");
    if (world.primitive_count() == 0) return;
    const auto [lo, hi] = world.bounds();
    const Point2d centre = (lo + hi) / 2;
    if (!centre.allFinite()) std::abort();
    const double reach = (hi - lo).norm() + 1.0;
    for (int k = 0; k < 8; ++k) {
      const double a = k * std::numbers::pi / 4;
      const Point2d d(std::cos(a), std::sin(a));
      const auto hit = world.cast_ray_2d(centre, d, 0.5, reach);
      const auto ref = world.cast_ray_2d_exhaustive(centre, d, 0.5, reach);
      if (hit.range != ref.range) std::abort();
      const Point3d o(centre.x(), centre.y(), 1.0), d3(d.x() * 0.8, d.y() * 0.8, -0.6);
      if (world.cast_ray(o, d3, reach).range != world.cast_ray_exhaustive(o, d3, reach).range)
        std::abort();
    }
  });
  return 0;
}
