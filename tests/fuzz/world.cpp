// libFuzzer harness: read_world on arbitrary text. A world read has finite bounds, and rays cast
// through its index (2D and 3D) run without a sanitizer report, within libFuzzer's time and
// memory limits (a world whose index grew without bound would exceed them).
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
    const Point2d extent = hi - lo;
    if (!extent.allFinite()) std::abort();
    const double reach = extent.norm() + 1.0;
    for (int k = 0; k < 8; ++k) {
      const double a = k * std::numbers::pi / 4 + 0.1;
      const Point2d d(std::cos(a), std::sin(a));
      (void)world.cast_ray_2d(centre, d, 0.5, reach);
      (void)world.cast_ray({centre.x(), centre.y(), 1.0}, {d.x() * 0.8, d.y() * 0.8, -0.6}, reach);
    }
  });
  return 0;
}
