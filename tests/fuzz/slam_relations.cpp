// libFuzzer harness: read_slam_relations on arbitrary bytes, then the relations evaluated against
// a trajectory at their own timestamps. Every relation read is finite.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

#include "fuzz_support.hpp"
#include "rangenav/io/slam_relations.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rangenav;
  const auto& path = fuzz::as_file(data, size);
  fuzz::expect_success_or_error([&] {
    const auto relations = io::read_slam_relations(path);
    std::vector<double> stamps;
    for (const auto& r : relations) {
      if (!std::isfinite(r.first) || !std::isfinite(r.second) || !std::isfinite(r.delta.x) ||
          !std::isfinite(r.delta.y) || !std::isfinite(r.delta.theta))
        std::abort();
      stamps.push_back(r.first);
      stamps.push_back(r.second);
    }
    std::sort(stamps.begin(), stamps.end());
    stamps.erase(std::unique(stamps.begin(), stamps.end()), stamps.end());
    const std::vector<Pose2d> poses(stamps.size());
    const auto e = io::evaluate_slam_relations(relations, stamps, poses);
    if (e.all.count + e.missing != relations.size()) std::abort();
  });
  return 0;
}
