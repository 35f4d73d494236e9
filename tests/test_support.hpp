#pragma once
// Helpers shared by the tests: where the real data lives, and the visible skip.

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

namespace rangenav::test {

/// ../shared/data (or $RANGENAV_DATA_DIR).
inline std::filesystem::path data_dir() {
  if (const char* env = std::getenv("RANGENAV_DATA_DIR"); env && *env) return env;
  return RANGENAV_TEST_DATA_DIR;
}

/// The path of a shared data file, or an empty path after printing the skip marker that makes
/// ctest report the test as skipped.
inline std::filesystem::path data_file_or_skip(const std::string& relative) {
  const auto path = data_dir() / relative;
  if (std::filesystem::exists(path)) return path;
  std::cout << "[rangenav-skip] data file not found: " << path.string() << '\n';
  return {};
}

/// Sample mean of v (v not empty).
inline double mean(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v)
    sum += x;
  return sum / static_cast<double>(v.size());
}

/// Sample standard deviation of v (with the n - 1 denominator; v has at least two values).
inline double stddev(const std::vector<double>& v) {
  const double m = mean(v);
  double sum = 0;
  for (double x : v)
    sum += (x - m) * (x - m);
  return std::sqrt(sum / static_cast<double>(v.size() - 1));
}

}  // namespace rangenav::test
