// libFuzzer harness: read_pcd_header and read_pcd (double and float) on arbitrary bytes. A read
// either succeeds with a consistent cloud without infinite values or throws rangenav::error.
#include "rangenav/io/pcd.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rangenav;
  const auto& path = fuzz::as_file(data, size);
  fuzz::expect_success_or_error([&] { (void)io::read_pcd_header(path); });
  fuzz::expect_success_or_error([&] { fuzz::check_cloud(io::read_pcd<double>(path)); });
  fuzz::expect_success_or_error([&] { fuzz::check_cloud(io::read_pcd<float>(path)); });
  return 0;
}
