// libFuzzer harness: read_tum, read_xytheta, read_kitti and read_transform_matrix (files: plain or
// gzip) on arbitrary bytes. Every timestamp and pose returned is finite, every rotation
// orthonormal.
#include <cmath>
#include <cstdlib>

#include "fuzz_support.hpp"
#include "rangenav/io/trajectory.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rangenav;
  const auto& path = fuzz::as_file(data, size);
  fuzz::expect_success_or_error([&] {
    for (const auto& s : io::read_tum(path)) {
      if (!std::isfinite(s.timestamp) || !s.pose.matrix().allFinite()) std::abort();
      if (!(s.pose.linear().transpose() * s.pose.linear()).isIdentity(1e-9)) std::abort();
    }
  });
  fuzz::expect_success_or_error([&] {
    for (const auto& s : io::read_xytheta(path))
      if (!std::isfinite(s.timestamp) || !std::isfinite(s.pose.x) || !std::isfinite(s.pose.y) ||
          !(std::abs(s.pose.theta) <= 3.1415926535897932))
        std::abort();
  });
  const auto rigid = [](const Transform3d& t) {
    if (!t.matrix().allFinite() || !(t.linear().transpose() * t.linear()).isIdentity(1e-9) ||
        !(t.linear().determinant() > 0))
      std::abort();
  };
  fuzz::expect_success_or_error([&] {
    for (const auto& t : io::read_kitti(path))
      rigid(t);
  });
  fuzz::expect_success_or_error([&] { rigid(io::read_transform_matrix(path)); });
  return 0;
}
