#pragma once
// ReaderLimits: upper bounds on what a file reader allocates, and the checked arithmetic every
// reader applies to the sizes, counts, offsets and products it reads from a file.
//
// A reader never trusts a count in a header: before it allocates, it checks that the count fits
// these limits and that the file holds enough bytes for it (a binary record needs its size, a
// text value at least one character and a separator), so what it allocates stays proportional to
// the input and bounded by the limits. A crafted header ("POINTS 100000000000", "P5 999999999
// 999999999 255") then gives an io_error naming the file, line and field, never std::bad_alloc,
// an out-of-memory kill or an out-of-bounds read.

#include <cstddef>
#include <limits>
#include <string>
#include <string_view>

#include "rangenav/core/error.hpp"

namespace rangenav::io {

/// Upper bounds on what one read allocates; checked before allocating. The defaults hold every
/// real file the library is meant for (a 100-million-point cloud, a 16k x 16k map) and keep a
/// crafted file from exhausting the process.
struct ReaderLimits {
  /// Most points, pixels, beams or records one read returns (> 0).
  std::size_t max_points = std::size_t{1} << 28;
  /// Most bytes one read holds in memory at once: a whole file, a decompressed block (> 0).
  std::size_t max_bytes = std::size_t{1} << 32;
  /// Longest text line a line-oriented reader accepts (bytes, > 0).
  std::size_t max_line_bytes = std::size_t{1} << 24;

  /// Throws invalid_argument naming `where` for a zero limit.
  void validate(std::string_view where) const {
    if (max_points == 0)
      ::rangenav::detail::throw_invalid_argument(where, "limits.max_points", max_points,
                                                 "must be > 0");
    if (max_bytes == 0)
      ::rangenav::detail::throw_invalid_argument(where, "limits.max_bytes", max_bytes,
                                                 "must be > 0");
    if (max_line_bytes == 0)
      ::rangenav::detail::throw_invalid_argument(where, "limits.max_line_bytes", max_line_bytes,
                                                 "must be > 0");
  }
};

namespace detail {

/// a * b, or false when the product does not fit std::size_t.
[[nodiscard]] constexpr bool checked_mul(std::size_t a, std::size_t b, std::size_t& out) {
  if (b != 0 && a > std::numeric_limits<std::size_t>::max() / b) return false;
  out = a * b;
  return true;
}

/// a + b, or false when the sum does not fit std::size_t.
[[nodiscard]] constexpr bool checked_add(std::size_t a, std::size_t b, std::size_t& out) {
  if (a > std::numeric_limits<std::size_t>::max() - b) return false;
  out = a + b;
  return true;
}

/// "<what> = <value> exceeds ReaderLimits::<limit> = <bound>", the message of a limit that a
/// file's count breaks.
[[nodiscard]] inline std::string exceeds_limit(std::string_view what, std::size_t value,
                                               std::string_view limit, std::size_t bound) {
  std::string msg(what);
  msg.append(" = ").append(std::to_string(value)).append(" exceeds ReaderLimits::");
  msg.append(limit).append(" = ").append(std::to_string(bound));
  return msg;
}

}  // namespace detail
}  // namespace rangenav::io
