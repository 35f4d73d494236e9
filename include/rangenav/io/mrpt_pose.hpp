#pragma once
// Camera poses of MRPT's plane-based-map demo data (mrpt_pbmap/poseN.mat): a gzip-compressed
// MRPT-serialised 4x4 float32 matrix. Decompressed, the file is exactly 64 bytes: 16
// little-endian float32 in column-major order, the last column holding the translation and the
// last row (0, 0, 0, 1). See ../shared/data/PROVENANCE.md.
//
// A gzip file (magic bytes 1f 8b) is decompressed with zlib when RANGENAV_HAVE_ZLIB is defined
// (the CMake target defines it when zlib is found); without zlib it raises io_error saying so.
// An uncompressed 64-byte file is read as is.

#include <cmath>
#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

#include <Eigen/Geometry>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/io/detail/fields.hpp"
#include "rangenav/io/detail/rigid.hpp"

#ifdef RANGENAV_HAVE_ZLIB
#include <zlib.h>
#endif

namespace rangenav::io {

namespace detail {

inline bool is_gzip(const std::string& bytes) {
  return bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0x1f &&
         static_cast<unsigned char>(bytes[1]) == 0x8b;
}

#ifdef RANGENAV_HAVE_ZLIB
/// The decompressed content of an in-memory gzip stream, at most `limit` bytes plus one (so a
/// caller expecting `limit` bytes sees that there are more). Throws io_error naming the file for
/// a corrupt or truncated stream.
inline std::string gunzip(std::string_view format, const std::filesystem::path& path,
                          const std::string& compressed, std::size_t limit) {
  z_stream z{};
  if (inflateInit2(&z, 16 + MAX_WBITS) != Z_OK) throw_io(format, path, 0, "gzip: zlib init failed");
  std::string out(limit + 1, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(compressed.data()));
  z.avail_in = static_cast<uInt>(compressed.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int status = inflate(&z, Z_FINISH);
  const std::size_t produced = out.size() - z.avail_out;
  inflateEnd(&z);
  // Z_BUF_ERROR with output space left: the input ended before the stream did.
  if (status == Z_DATA_ERROR || status == Z_NEED_DICT || status == Z_MEM_ERROR)
    throw_io(format, path, 0, "gzip: corrupt compressed data");
  if (status != Z_STREAM_END && produced <= limit)
    throw_io(format, path, 0, "gzip: truncated compressed data");
  out.resize(produced);
  return out;
}
#endif

}  // namespace detail

/// Reads an MRPT pose file (gzip-compressed or plain) as a rigid transform: the column-major 4x4
/// matrix, its rotation re-orthonormalised (float32 rounding) through a unit quaternion.
/// Throws io_error naming the file when it cannot be read, is gzip-compressed without zlib, is
/// corrupt or truncated, larger than 1 MiB, does not hold exactly 16 float32, has a non-finite
/// value, a last row other than (0, 0, 0, 1) or a rotation that is not orthonormal (tolerance
/// 1e-3).
[[nodiscard]] inline Transform3d read_mrpt_pose(const std::filesystem::path& path) {
  constexpr std::string_view format = "MRPT pose";
  constexpr std::size_t expected = 16 * sizeof(float);
  // A pose file is under a hundred bytes, compressed or not: nothing larger is read into memory.
  constexpr std::size_t max_file_bytes = std::size_t{1} << 20;
  std::string bytes = detail::read_whole_file(format, path, max_file_bytes);
  if (detail::is_gzip(bytes)) {
#ifdef RANGENAV_HAVE_ZLIB
    bytes = detail::gunzip(format, path, bytes, expected);
#else
    detail::throw_io(format, path, 0,
                     "gzip-compressed file, but rangenav was built without zlib "
                     "(RANGENAV_HAVE_ZLIB)");
#endif
  }
  if (bytes.size() != expected)
    detail::throw_io(
        format, path, 0,
        "expected 64 bytes (16 float32, a 4x4 matrix), got " +
            std::string(bytes.size() > expected ? "more" : std::to_string(bytes.size())));
  Eigen::Matrix4d m;
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  for (int col = 0; col < 4; ++col)
    for (int row = 0; row < 4; ++row) {
      const float v = detail::load_le<float>(data + 4 * (4 * col + row));
      if (!std::isfinite(v)) detail::throw_io(format, path, 0, "non-finite matrix element");
      m(row, col) = static_cast<double>(v);
    }
  if (!m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1), 1e-6))
    detail::throw_io(format, path, 0, "last row is not (0, 0, 0, 1): not a rigid transform");
  return detail::rigid_transform_or_fail(m.topRows<3>(), [&](std::string_view message) {
    detail::throw_io(format, path, 0, message);
  });
}

}  // namespace rangenav::io
