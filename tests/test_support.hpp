#pragma once
// Helpers shared by the tests: where the real data lives, and the visible skip.

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>

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

}  // namespace rangenav::test
