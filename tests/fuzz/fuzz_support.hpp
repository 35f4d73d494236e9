#pragma once
// What every libFuzzer harness of tests/fuzz shares: the input as a file (the readers take paths)
// and the one outcome a bad input may have besides success, a rangenav::error. Anything else
// (another exception, a signal, a sanitizer report, a leak) is a finding.

#include <unistd.h>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "rangenav/core/cloud.hpp"
#include "rangenav/core/error.hpp"

namespace rangenav::fuzz {

/// A file of this process, rewritten with every input (removed at exit).
inline const std::filesystem::path& input_file() {
  static const std::filesystem::path path = [] {
    auto p = std::filesystem::temp_directory_path() /
             ("rangenav_fuzz_" + std::to_string(::getpid()) + ".in");
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove(input_file(), ec);
    });
    return p;
  }();
  return path;
}

/// Writes the input to input_file() and returns its path.
inline const std::filesystem::path& as_file(const std::uint8_t* data, std::size_t size) {
  const auto& path = input_file();
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) std::abort();  // the harness itself failed: not the reader's fault, but stop
  return path;
}

/// The input as text.
inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

/// Runs f(); a rangenav::error is the documented answer to a bad input, everything else escapes
/// to libFuzzer as a finding.
template <class F>
void expect_success_or_error(F&& f) {
  try {
    f();
  } catch (const rangenav::error&) {
  }
}

/// What a cloud reader must return: consistent sizes, no infinite coordinate (NaN marks a missing
/// point). Aborts, a finding, otherwise.
template <class Scalar>
void check_cloud(const Cloud<3, Scalar>& cloud) {
  try {
    cloud.validate("fuzz");
  } catch (const rangenav::error&) {
    std::abort();  // inside expect_success_or_error this would pass for a rejected input
  }
  for (const auto& p : cloud.points)
    if (p.array().isInf().any()) std::abort();
}

}  // namespace rangenav::fuzz
