// libFuzzer harness: read_g2o (file: plain or gzip, and stream) on arbitrary bytes. Every vertex
// pose and edge measurement returned is finite, edges refer to existing vertices, information
// matrices are symmetric, and the file and stream readers agree.
#include <cstdlib>
#include <sstream>
#include <string>
#include <variant>

#include "fuzz_support.hpp"
#include "rangenav/io/g2o.hpp"

namespace {
template <int D>
void check(const rangenav::io::G2oGraph<D>& graph) {
  for (const auto& v : graph.vertices)
    if (!v.pose.matrix().allFinite()) std::abort();
  for (const auto& e : graph.edges) {
    if (e.from >= graph.vertices.size() || e.to >= graph.vertices.size()) std::abort();
    if (!e.measurement.matrix().allFinite()) std::abort();
    if (!e.information.allFinite() || !(e.information - e.information.transpose()).isZero(0))
      std::abort();
  }
}

std::size_t size_of(const rangenav::io::G2oFile& file) {
  return std::visit([](const auto& g) { return g.vertices.size() * 1000003 + g.edges.size(); },
                    file);
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rangenav;
  const auto& path = fuzz::as_file(data, size);
  bool from_file = false;
  std::size_t file_size = 0;
  fuzz::expect_success_or_error([&] {
    const io::G2oFile file = io::read_g2o(path);
    std::visit([](const auto& g) { check(g); }, file);
    from_file = true;
    file_size = size_of(file);
  });
  fuzz::expect_success_or_error([&] {
    std::istringstream in{std::string(fuzz::as_text(data, size))};
    const io::G2oFile stream = io::read_g2o(in, "fuzz.g2o");
    std::visit([](const auto& g) { check(g); }, stream);
    // A gzip input reads only as a file; plain text the same both ways.
    if (from_file && size >= 2 && data[0] != 0x1f && size_of(stream) != file_size) std::abort();
  });
  return 0;
}
