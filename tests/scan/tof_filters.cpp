#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/scan/tof_filters.hpp"

using namespace rangenav;

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A depth image of fronto-parallel planes: pixel column c sees the plane x = plane_x(c).
template <class F>
DepthImage<double> planes(std::size_t w, std::size_t h, F plane_x) {
  DepthImage<double> img;
  img.intrinsics = PinholeIntrinsics<double>::from_fov(w, h, deg_to_rad(43.0), deg_to_rad(34.0));
  img.kind = DepthKind::radial;
  img.depth.resize(w * h);
  for (std::size_t r = 0; r < h; ++r)
    for (std::size_t c = 0; c < w; ++c)
      img.depth[r * w + c] = plane_x(c) * img.intrinsics.optical_ray(r, c).norm();
  return img;
}
}  // namespace

TEST_CASE("amplitude threshold invalidates weak returns", "[scan][tof]") {
  DepthImage<double> img;
  img.intrinsics = PinholeIntrinsics<double>::from_fov(3, 2, 1.0, 1.0);
  img.depth = {1, 2, 3, 4, kNaN, 6};
  img.amplitude = {10, 5, 20, 4.9, 1, 5};
  CHECK(apply_amplitude_threshold(img, 5.0) == 1);
  CHECK(std::isnan(img.depth[3]));
  CHECK(img.depth[1] == 2.0);  // at the threshold: kept
  CHECK(img.depth[5] == 6.0);
  img.amplitude.clear();
  CHECK_THROWS_WITH(apply_amplitude_threshold(img, 5.0),
                    "rangenav: apply_amplitude_threshold: the image has no amplitude channel");
  img.depth.pop_back();
  CHECK_THROWS_WITH(apply_median_filter(img),
                    "rangenav: apply_median_filter: argument 'depth.size()' = 5 must equal "
                    "width*height = 6");
}

TEST_CASE("median filter removes a spike and keeps invalid pixels invalid", "[scan][tof]") {
  auto img = planes(5, 5, [](std::size_t) { return 2.0; });
  const auto clean = img.depth;
  img.depth[12] = 5.0;  // centre spike
  img.depth[6] = kNaN;
  apply_median_filter(img);
  CHECK(std::isnan(img.depth[6]));
  CHECK(img.depth[12] == Approx(clean[12]).epsilon(0.02));
  CHECK(img.depth[0] == Approx(clean[0]).epsilon(0.02));
}

TEST_CASE("jump-edge filter (Eq. 13-14) removes mixed pixels and keeps real edges", "[scan][tof]") {
  const std::size_t w = 40, h = 30;
  // Near plane at 1 m left of column 20, far plane at 3 m right of it, mixed pixels in column 20.
  auto img = planes(w, h, [](std::size_t c) { return c < 20 ? 1.0 : (c == 20 ? 2.0 : 3.0); });
  JumpEdgeFilter<double> filter(img.intrinsics, DepthKind::radial);
  auto keep = img;
  CHECK(filter.filter(keep) == h);
  for (std::size_t r = 0; r < h; ++r) {
    CHECK(std::isnan(keep.at(r, 20)));
    CHECK(keep.at(r, 19) == img.at(r, 19));  // the near object's real edge
    CHECK(keep.at(r, 21) == img.at(r, 21));  // the far surface's edge
  }
  // Eq. (14) alone also removes the rim of the near surface.
  JumpEdgeParams<double> strict;
  strict.keep_near_edges = false;
  JumpEdgeFilter<double> strict_filter(img.intrinsics, DepthKind::radial, strict);
  auto s = img;
  CHECK(strict_filter.filter(s) == 2 * h);
  CHECK(std::isnan(s.at(5, 19)));
  CHECK(s.at(5, 21) == img.at(5, 21));
  // A plane has no jump edges; z-depth images work the same.
  auto flat = planes(w, h, [](std::size_t) { return 2.0; });
  CHECK(filter.filter(flat) == 0);
  DepthImage<double> zimg = img;
  zimg.kind = DepthKind::z_depth;
  for (std::size_t r = 0; r < h; ++r)
    for (std::size_t c = 0; c < w; ++c)
      zimg.depth[r * w + c] = c < 20 ? 1.0 : (c == 20 ? 2.0 : 3.0);
  JumpEdgeFilter<double> zfilter(zimg.intrinsics, DepthKind::z_depth);
  CHECK(zfilter.filter(zimg) == h);
  // Bad input.
  JumpEdgeParams<double> bad;
  bad.epsilon_theta = 1.0;
  CHECK_THROWS_WITH(
      JumpEdgeFilter<double>(img.intrinsics, DepthKind::radial, bad),
      "rangenav: JumpEdgeFilter: argument 'epsilon_theta' = 1 must lie in (pi/2, pi)");
  JumpEdgeParams<double> negative;
  negative.min_jump = -0.5;
  CHECK_THROWS_WITH(JumpEdgeFilter<double>(img.intrinsics, DepthKind::radial, negative),
                    "rangenav: JumpEdgeFilter: argument 'min_jump' = -0.5 must be finite and >= 0");
  auto small = planes(4, 3, [](std::size_t) { return 1.0; });
  CHECK_THROWS_WITH(filter.filter(small),
                    "rangenav: JumpEdgeFilter::filter: argument 'image.width()' = 4 and height "
                    "must match the filter's intrinsics");
}

TEST_CASE("median filter equals the brute-force median of the valid window", "[scan][tof]") {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(0.5, 4.0);
  std::uniform_real_distribution<double> coin(0.0, 1.0);
  DepthImage<double> img;
  img.intrinsics = PinholeIntrinsics<double>::from_fov(23, 17, 1.0, 1.0);
  img.depth.resize(23 * 17);
  for (auto& d : img.depth)
    d = coin(rng) < 0.08 ? kNaN : u(rng);
  const auto in = img.depth;
  apply_median_filter(img);
  for (std::size_t r = 0; r < 17; ++r)
    for (std::size_t c = 0; c < 23; ++c) {
      const double d = in[r * 23 + c];
      if (std::isnan(d)) {
        REQUIRE(std::isnan(img.depth[r * 23 + c]));
        continue;
      }
      std::vector<double> win;
      for (std::size_t rr = r == 0 ? 0 : r - 1; rr <= std::min<std::size_t>(r + 1, 16); ++rr)
        for (std::size_t cc = c == 0 ? 0 : c - 1; cc <= std::min<std::size_t>(c + 1, 22); ++cc)
          if (!std::isnan(in[rr * 23 + cc])) win.push_back(in[rr * 23 + cc]);
      std::sort(win.begin(), win.end());
      REQUIRE(img.depth[r * 23 + c] == win[(win.size() - 1) / 2]);
    }
}
