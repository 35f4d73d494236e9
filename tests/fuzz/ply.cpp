// libFuzzer harness: read_ply (double and float) on arbitrary bytes. A read either succeeds with a
// consistent cloud without infinite values or throws rangenav::error.
#include "rangenav/io/ply.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rangenav;
  const auto& path = fuzz::as_file(data, size);
  fuzz::expect_success_or_error([&] { fuzz::check_cloud(io::read_ply<double>(path)); });
  fuzz::expect_success_or_error([&] { fuzz::check_cloud(io::read_ply<float>(path)); });
  return 0;
}
