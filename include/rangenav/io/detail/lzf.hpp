#pragma once
// LZF compression as used by PCL's "DATA binary_compressed" PCD files.
//
// The stream format is Marc Lehmann's liblzf 3.x (lzf_d.c, BSD licence), which PCL embeds as
// pcl/io/lzf.h. A compressed stream is a sequence of chunks, each starting with a control byte c:
//   c < 32           a literal run: the next c + 1 bytes are copied to the output;
//   c >= 32          a back reference: len = c >> 5 (if len == 7, one more byte is added to it),
//                    then one byte lo; len + 2 bytes are copied (byte by byte, overlap allowed)
//                    from output position  out - ((c & 31) << 8 | lo) - 1.
// Offsets therefore reach 8192 bytes back and a reference copies 3 to 264 bytes. The compressor
// below is a greedy one with a hash table of 3-byte prefixes; any valid chunk sequence decodes
// with every LZF decoder, so it need not reproduce liblzf's output byte for byte.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

namespace rangenav::io::detail {

inline constexpr std::size_t lzf_max_offset = std::size_t{1} << 13;  // 8192
inline constexpr std::size_t lzf_max_literal = 32;
inline constexpr std::size_t lzf_max_match = 7 + 255 + 2;  // 264
/// The largest output / input ratio of any LZF stream: a 3-byte back reference copies 264 bytes
/// (literal runs and 2-byte references expand less).
inline constexpr std::size_t lzf_max_expansion = lzf_max_match / 3;  // 88

/// Appends the LZF compression of in[0, n) to out (cleared first). Output is at most
/// n + n / 32 + 1 bytes; an empty input gives an empty output.
inline void lzf_compress(const std::uint8_t* in, std::size_t n, std::vector<std::uint8_t>& out) {
  out.clear();
  out.reserve(n + n / lzf_max_literal + 1);
  constexpr unsigned hash_bits = 16;
  constexpr std::size_t none = std::numeric_limits<std::size_t>::max();
  std::vector<std::size_t> table(std::size_t{1} << hash_bits, none);
  const auto hash = [&](std::size_t i) {
    const std::uint32_t v = std::uint32_t{in[i]} << 16 | std::uint32_t{in[i + 1]} << 8 | in[i + 2];
    return static_cast<std::size_t>((v * 2654435761u) >> (32 - hash_bits));
  };
  std::size_t literal_start = 0;
  const auto flush_literals = [&](std::size_t end) {
    while (literal_start < end) {
      const std::size_t run = std::min(lzf_max_literal, end - literal_start);
      out.push_back(static_cast<std::uint8_t>(run - 1));
      out.insert(out.end(), in + literal_start, in + literal_start + run);
      literal_start += run;
    }
  };
  std::size_t i = 0;
  while (i + 2 < n) {
    const std::size_t h = hash(i);
    const std::size_t ref = table[h];
    table[h] = i;
    if (ref != none && i - ref <= lzf_max_offset && in[ref] == in[i] && in[ref + 1] == in[i + 1] &&
        in[ref + 2] == in[i + 2]) {
      const std::size_t max_len = std::min(lzf_max_match, n - i);
      std::size_t len = 3;
      while (len < max_len && in[ref + len] == in[i + len])
        ++len;
      flush_literals(i);
      const std::size_t offset = i - ref - 1;
      const std::size_t stored = len - 2;
      const auto high = static_cast<std::uint8_t>(offset >> 8);
      if (stored < 7) {
        out.push_back(static_cast<std::uint8_t>(high | stored << 5));
      } else {
        out.push_back(static_cast<std::uint8_t>(high | 7u << 5));
        out.push_back(static_cast<std::uint8_t>(stored - 7));
      }
      out.push_back(static_cast<std::uint8_t>(offset & 0xffu));
      for (std::size_t k = i + 1; k < i + len && k + 2 < n; ++k)
        table[hash(k)] = k;
      i += len;
      literal_start = i;
    } else {
      ++i;
    }
  }
  flush_literals(n);
}

/// What lzf_decompress returns for a corrupt stream or one that does not fit the output.
inline constexpr std::size_t lzf_error = std::numeric_limits<std::size_t>::max();

/// Decodes the LZF stream in[0, n) into out[0, capacity). Returns the number of bytes written, or
/// lzf_error when the stream is corrupt (a reference before the output's start, a chunk cut
/// short) or its output would exceed capacity.

inline std::size_t lzf_decompress(const std::uint8_t* in, std::size_t n, std::uint8_t* out,
                                  std::size_t capacity) {
  std::size_t ip = 0, op = 0;
  while (ip < n) {
    const std::size_t ctrl = in[ip++];
    if (ctrl < lzf_max_literal) {
      const std::size_t run = ctrl + 1;
      if (run > n - ip || run > capacity - op) return lzf_error;
      std::copy(in + ip, in + ip + run, out + op);
      ip += run;
      op += run;
    } else {
      std::size_t len = ctrl >> 5;
      if (ip >= n) return lzf_error;
      if (len == 7) {
        len += in[ip++];
        if (ip >= n) return lzf_error;
      }
      const std::size_t back = ((ctrl & 0x1fu) << 8) + in[ip++] + 1;
      len += 2;
      if (back > op || len > capacity - op) return lzf_error;
      if (back >= len) {  // source and destination do not overlap
        std::memcpy(out + op, out + op - back, len);
        op += len;
      } else {  // a repeating pattern: copy byte by byte, re-reading what was just written
        for (std::size_t k = 0; k < len; ++k, ++op)
          out[op] = out[op - back];
      }
    }
  }
  return op;
}

}  // namespace rangenav::io::detail
