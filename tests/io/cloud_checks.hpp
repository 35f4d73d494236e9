#pragma once
// Checks shared by the PCD and PLY tests: bit-exact cloud comparison, test clouds with NaNs,
// finite-point counts and bounding boxes.

#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "rangenav/core/cloud.hpp"

namespace rangenav::test {

/// Same bits, except that any NaN equals any NaN (text formats write "nan" without payload).
template <class S>
bool same_value(S a, S b) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  return std::bit_cast<std::conditional_t<sizeof(S) == 4, std::uint32_t, std::uint64_t>>(a) ==
         std::bit_cast<std::conditional_t<sizeof(S) == 4, std::uint32_t, std::uint64_t>>(b);
}

template <int D, class S>
bool same_vectors(const std::vector<Point<D, S>>& a, const std::vector<Point<D, S>>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    for (int k = 0; k < D; ++k)
      if (!same_value(a[i][k], b[i][k])) return false;
  return true;
}

/// Every attribute identical (bit for bit, NaN == NaN), organisation included.
template <int D, class S>
void require_same_cloud(const Cloud<D, S>& a, const Cloud<D, S>& b) {
  REQUIRE(a.width == b.width);
  REQUIRE(a.height == b.height);
  REQUIRE(a.size() == b.size());
  CHECK(same_vectors(a.points, b.points));
  CHECK(same_vectors(a.normals, b.normals));
  REQUIRE(a.intensities.size() == b.intensities.size());
  bool intensities_same = true;
  for (std::size_t i = 0; i < a.intensities.size(); ++i)
    intensities_same = intensities_same && same_value(a.intensities[i], b.intensities[i]);
  CHECK(intensities_same);
  CHECK(a.colors == b.colors);
}

template <int D, class S>
std::size_t finite_count(const Cloud<D, S>& c) {
  std::size_t n = 0;
  for (const auto& p : c.points)
    n += p.allFinite() ? 1 : 0;
  return n;
}

/// Bounding box of the finite points.
template <class S>
std::pair<Point<3, double>, Point<3, double>> finite_bounds(const Cloud<3, S>& c) {
  Point<3, double> lo = Point<3, double>::Constant(std::numeric_limits<double>::infinity());
  Point<3, double> hi = -lo;
  for (const auto& p : c.points) {
    if (!p.allFinite()) continue;
    lo = lo.cwiseMin(p.template cast<double>());
    hi = hi.cwiseMax(p.template cast<double>());
  }
  return {lo, hi};
}

/// A 4 x 3 organised cloud with NaN points, intensities, colours and normals; every value is
/// exactly representable as float so float32 storage is lossless too.
template <class S>
Cloud<3, S> make_organised_test_cloud() {
  Cloud<3, S> c;
  c.width = 4;
  c.height = 3;
  const S nan = std::numeric_limits<S>::quiet_NaN();
  for (std::size_t i = 0; i < 12; ++i) {
    const auto v = static_cast<S>(i);
    if (i == 1 || i == 6 || i == 11) {
      c.points.emplace_back(nan, nan, nan);
    } else {
      c.points.emplace_back(v * S(0.25) - S(1), S(-0.125) * v, S(1.5) + v / S(1024));
    }
    c.intensities.push_back(i == 6 ? std::numeric_limits<float>::quiet_NaN()
                                   : static_cast<float>(i) * 3.5f);
    c.colors.push_back({static_cast<std::uint8_t>(20 * i), static_cast<std::uint8_t>(255 - i),
                        static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(i % 2 ? 255 : 7)});
    c.normals.emplace_back(S(0.5), S(-0.5), S(0.70703125));  // unit to 1e-4, float-exact
  }
  return c;
}

inline void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

}  // namespace rangenav::test
