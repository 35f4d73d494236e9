// libFuzzer harness: read_mrpt_pose (gzip or plain) on arbitrary bytes. A pose returned is a
// finite rigid transform.
#include <cstdlib>

#include "fuzz_support.hpp"
#include "rangenav/io/mrpt_pose.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rangenav;
  const auto& path = fuzz::as_file(data, size);
  fuzz::expect_success_or_error([&] {
    const Transform3d t = io::read_mrpt_pose(path);
    if (!t.matrix().allFinite()) std::abort();
    if (!(t.linear().transpose() * t.linear()).isIdentity(1e-9)) std::abort();
  });
  return 0;
}
