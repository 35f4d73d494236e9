#pragma once
// Portable graymap (PGM) images, the usual file format of occupancy-grid maps (ROS map_server,
// EVG-THIN, GIMP): binary "P5" and plain "P2", 8 or 16 bits per pixel, '#' comments in the header.
//
// read_pgm() loads an image; occupied_cells() turns the occupied cells of a map image into 2D
// points (one per cell centre) at a given resolution, ready for any algorithm that takes a
// PointCloud, e.g. the Voronoi path graph of paper 000 §4.

#include <algorithm>
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <istream>
#include <limits>
#include <string>
#include <system_error>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/io/reader_limits.hpp"

namespace rangenav::io {

/// A grayscale image, row-major, row 0 at the top (as stored in the file).
struct GrayImage {
  std::size_t width{0};               ///< pixels per row (columns)
  std::size_t height{0};              ///< rows
  std::uint16_t max_value{255};       ///< the file's maxval (1 ... 65535)
  std::vector<std::uint16_t> pixels;  ///< width * height values in [0, max_value]

  /// The pixel at (column, row); throws invalid_argument outside the image.
  [[nodiscard]] std::uint16_t at(std::size_t column, std::size_t row) const {
    if (column >= width)
      rangenav::detail::throw_invalid_argument("GrayImage::at", "column", column,
                                               "must be < width = " + std::to_string(width));
    if (row >= height)
      rangenav::detail::throw_invalid_argument("GrayImage::at", "row", row,
                                               "must be < height = " + std::to_string(height));
    return pixels.at(row * width + column);
  }
};

namespace detail {

[[noreturn]] inline void throw_pgm(const std::string& source, const std::string& what) {
  throw io_error("rangenav: read_pgm: " + source + ": " + what);
}

[[noreturn]] inline void throw_pgm_pixel(const std::string& source, std::size_t i,
                                         unsigned long value, unsigned long max_value) {
  throw_pgm(source, "pixel " + std::to_string(i) + " = " + std::to_string(value) +
                        " exceeds maxval " + std::to_string(max_value));
}

/// Skips whitespace and '#' comments (which run to the end of the line) in a PGM header.
inline void skip_pgm_space(std::istream& in) {
  for (;;) {
    const int c = in.peek();
    if (c == '#') {
      in.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
    } else if (c != std::char_traits<char>::eof() && std::isspace(c)) {
      in.get();
    } else {
      return;
    }
  }
}

inline unsigned long read_pgm_number(std::istream& in, const std::string& source,
                                     const char* field) {
  skip_pgm_space(in);
  std::string digits;
  while (digits.size() <= 9 && std::isdigit(in.peek()))
    digits.push_back(static_cast<char>(in.get()));
  if (digits.empty() || digits.size() > 9)
    throw_pgm(source, std::string("header field '") + field + "' is missing or not a number");
  return std::stoul(digits);
}

}  // namespace detail

/// Reads a PGM image from a stream; `source` names it in error messages (e.g. the file name).
/// Throws io_error naming the source and the problem (wrong magic number, bad header field, an
/// image beyond `limits`, truncated pixel data, pixel above maxval). The pixels are stored as they
/// arrive, so a header that promises more than the stream holds allocates no more than it holds.
[[nodiscard]] inline GrayImage read_pgm(std::istream& in, const std::string& source = "<stream>",
                                        const ReaderLimits& limits = {}) {
  limits.validate("read_pgm");
  char magic[2] = {0, 0};
  in.read(magic, 2);
  if (!in || magic[0] != 'P' || (magic[1] != '5' && magic[1] != '2'))
    detail::throw_pgm(source, "not a PGM file (magic number must be P5 or P2)");
  const bool binary = magic[1] == '5';
  GrayImage image;
  image.width = detail::read_pgm_number(in, source, "width");
  image.height = detail::read_pgm_number(in, source, "height");
  const unsigned long max_value = detail::read_pgm_number(in, source, "maxval");
  if (image.width == 0 || image.height == 0)
    detail::throw_pgm(source, "image size " + std::to_string(image.width) + "x" +
                                  std::to_string(image.height) + " is empty");
  if (max_value == 0 || max_value > 65535)
    detail::throw_pgm(source, "maxval " + std::to_string(max_value) + " is not in 1..65535");
  image.max_value = static_cast<std::uint16_t>(max_value);
  // Each side has at most 9 digits: the product fits std::size_t.
  const std::size_t count = image.width * image.height;
  const std::string size_text =
      "image size " + std::to_string(image.width) + "x" + std::to_string(image.height);
  if (count > limits.max_points)
    detail::throw_pgm(source, detail::exceeds_limit(size_text + ": pixel count", count,
                                                    "max_points", limits.max_points));
  if (count > limits.max_bytes / sizeof(std::uint16_t))
    detail::throw_pgm(source,
                      detail::exceeds_limit(size_text + ": bytes", count * sizeof(std::uint16_t),
                                            "max_bytes", limits.max_bytes));
  if (binary) {
    if (!std::isspace(in.get())) detail::throw_pgm(source, "no whitespace after maxval");
    const std::size_t bytes_per_pixel = max_value > 255 ? 2 : 1;
    constexpr std::size_t chunk_pixels = std::size_t{1} << 16;
    std::vector<unsigned char> raw;
    while (image.pixels.size() < count) {
      const std::size_t done = image.pixels.size();
      const std::size_t pixels = std::min(chunk_pixels, count - done);
      raw.resize(pixels * bytes_per_pixel);
      in.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(raw.size()));
      const auto got = static_cast<std::size_t>(in.gcount());
      for (std::size_t i = 0; i + bytes_per_pixel <= got; i += bytes_per_pixel)
        image.pixels.push_back(
            bytes_per_pixel == 1 ? raw[i] : static_cast<std::uint16_t>((raw[i] << 8) | raw[i + 1]));
      if (got != raw.size()) {
        const std::size_t read = done * bytes_per_pixel + got;
        detail::throw_pgm(source, "truncated pixel data: " + std::to_string(read) + " of " +
                                      std::to_string(count * bytes_per_pixel) + " bytes");
      }
    }
  } else {
    for (std::size_t i = 0; i < count; ++i) {
      detail::skip_pgm_space(in);
      if (!std::isdigit(in.peek()))
        detail::throw_pgm(source, "truncated pixel data: pixel " + std::to_string(i) + " of " +
                                      std::to_string(count) + " is missing");
      const unsigned long value = detail::read_pgm_number(in, source, "pixel");
      if (value > max_value) detail::throw_pgm_pixel(source, i, value, max_value);
      image.pixels.push_back(static_cast<std::uint16_t>(value));
    }
  }
  for (std::size_t i = 0; i < count; ++i)
    if (image.pixels[i] > image.max_value)
      detail::throw_pgm_pixel(source, i, image.pixels[i], max_value);
  return image;
}

/// Reads a PGM file; throws io_error naming the file when it cannot be opened or is malformed.
[[nodiscard]] inline GrayImage read_pgm(const std::filesystem::path& path,
                                        const ReaderLimits& limits = {}) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw io_error("rangenav: read_pgm: " + path.string() + ": is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw io_error("rangenav: read_pgm: cannot open " + path.string());
  return read_pgm(in, path.string(), limits);
}

/// How map pixels are read as occupancy: the ROS map_server convention, occupancy =
/// (maxval - value) / maxval, so black (0) is occupied and white free.
struct OccupancyThresholds {
  double occupied = 0.65;  ///< a cell with occupancy above this is occupied
};

/// The centres of the occupied cells of a map image as 2D points in metres. Column c, row r of
/// the image maps to (origin.x + (c + 0.5) res, origin.y + (height - 1 - r + 0.5) res): x to the
/// right, y up, the image's bottom-left corner at `origin`.
[[nodiscard]] inline std::vector<Point2d> occupied_cells(
    const GrayImage& image, double resolution, const Point2d& origin = Point2d::Zero(),
    const OccupancyThresholds& thresholds = {}) {
  rangenav::detail::require_positive("occupied_cells", "resolution", resolution);
  rangenav::detail::require_finite("occupied_cells", "origin.x", origin.x());
  rangenav::detail::require_finite("occupied_cells", "origin.y", origin.y());
  if (!(thresholds.occupied >= 0.0 && thresholds.occupied < 1.0))
    rangenav::detail::throw_invalid_argument("occupied_cells", "thresholds.occupied",
                                             thresholds.occupied, "must be in [0, 1)");
  std::size_t count = 0;
  if (!detail::checked_mul(image.width, image.height, count) || image.pixels.size() != count)
    rangenav::detail::throw_invalid_argument("occupied_cells", "image.pixels.size()",
                                             image.pixels.size(), "must equal width * height");
  // The farthest cell centre must be finite too (a huge resolution or origin overflows).
  const Point2d far_corner =
      origin +
      Point2d(static_cast<double>(image.width), static_cast<double>(image.height)) * resolution;
  if (!far_corner.allFinite())
    rangenav::detail::throw_invalid(
        "occupied_cells", "origin + image size * resolution overflows: resolution = " +
                              rangenav::detail::format_value(resolution) + " is too large");
  std::vector<Point2d> points;
  const double max_value = image.max_value;
  for (std::size_t r = 0; r < image.height; ++r)
    for (std::size_t c = 0; c < image.width; ++c) {
      const double occupancy = (max_value - image.pixels[r * image.width + c]) / max_value;
      if (occupancy > thresholds.occupied)
        points.emplace_back(
            origin.x() + (static_cast<double>(c) + 0.5) * resolution,
            origin.y() + (static_cast<double>(image.height - 1 - r) + 0.5) * resolution);
    }
  return points;
}

}  // namespace rangenav::io
