// libFuzzer harness: read_pgm on arbitrary bytes, then occupied_cells of what it read. Every
// pixel returned lies within maxval and every cell centre is finite.
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>

#include "fuzz_support.hpp"
#include "rangenav/io/pgm.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rangenav;
  fuzz::expect_success_or_error([&] {
    std::istringstream in{std::string(fuzz::as_text(data, size))};
    const io::GrayImage image = io::read_pgm(in, "fuzz.pgm");
    if (image.pixels.size() != image.width * image.height) std::abort();
    for (const auto v : image.pixels)
      if (v > image.max_value) std::abort();
    for (const auto& p : io::occupied_cells(image, 0.05, {-10.0, 5.0}))
      if (!p.allFinite()) std::abort();
  });
  return 0;
}
