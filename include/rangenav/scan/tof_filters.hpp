#pragma once
// Filters for time-of-flight depth images (3D-perception paper 002 §7.1): amplitude threshold,
// 3x3 median filter and the jump-edge filter of Eq. (13)-(14) (after May et al. 2009).
//
// Jump edges are spurious readings between a near and a far surface ("mixed pixels"). For a
// pixel p_i and each of its eight neighbours p_n, the triangle (focal point f = 0, p_i, p_n) has
// the angle φ at f between the two rays, and by the law of sines the angle at p_i satisfies
//   sin θ_i,n = ||p_n|| sin φ / ||p_n - p_i||,                                    Eq. (13)
// with θ_i,n obtuse when p_n lies behind p_i. A pixel whose largest angle θ_i = max_n θ_i,n exceeds
// ε_θ sees a neighbour almost straight behind it along its own ray (Eq. 14): J = {p_i | θ_i > ε_θ}.
// That holds for a mixed pixel and for the rim pixel of the near surface alike; with
// `keep_near_edges` (default) a pixel is a jump edge only if it also has a neighbour almost
// straight in front of it (θ_i,n < π - ε_θ), i.e. it floats between two surfaces, so the real
// edge of the near object survives. The filter is sensitive to noise: run the median filter first.
//
// Every filter works in place on the depth channel, marks removed pixels with NaN and allocates
// nothing once its scratch buffers have the image's size.

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <numbers>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/scan/depth_image.hpp"

namespace rangenav {

/// Invalidates (NaN) every pixel whose amplitude is below `threshold` (§7.1). Returns the number
/// of pixels invalidated. Throws when the image has no amplitude channel.
template <std::floating_point Scalar>
std::size_t apply_amplitude_threshold(DepthImage<Scalar>& image, Scalar threshold) {
  image.validate("apply_amplitude_threshold");
  detail::require_finite("apply_amplitude_threshold", "threshold", threshold);
  if (image.amplitude.empty())
    detail::throw_invalid("apply_amplitude_threshold", "the image has no amplitude channel");
  std::size_t removed = 0;
  for (std::size_t i = 0; i < image.depth.size(); ++i)
    if (DepthImage<Scalar>::is_valid_depth(image.depth[i]) && !(image.amplitude[i] >= threshold)) {
      image.depth[i] = std::numeric_limits<Scalar>::quiet_NaN();
      ++removed;
    }
  return removed;
}

/// 3x3 median filter on the depth channel over valid pixels: a valid pixel takes the median of
/// the valid depths in its 3x3 window (the lower middle one for an even count); invalid pixels
/// stay invalid. `scratch` holds a copy of the input between calls.
template <std::floating_point Scalar>
void apply_median_filter(DepthImage<Scalar>& image, std::vector<Scalar>& scratch) {
  image.validate("apply_median_filter");
  const std::size_t w = image.width(), h = image.height(), n = w * h;
  // scratch: a copy of the input, then per column of the current row triple its sorted values
  // (lo, mid, hi) and whether all three are valid.
  scratch.resize(n + 4 * w);
  std::copy(image.depth.begin(), image.depth.end(), scratch.begin());
  const Scalar* in = scratch.data();
  Scalar* lo = scratch.data() + n;
  Scalar* mid = lo + w;
  Scalar* hi = mid + w;
  Scalar* full = hi + w;  // 1 when the column's three values are valid
  const auto valid = [](Scalar d) {
    return d > Scalar(0) && d < std::numeric_limits<Scalar>::infinity();
  };
  const auto generic = [&](std::size_t r, std::size_t c) {
    Scalar window[9];
    int k = 0;
    const std::size_t r0 = r == 0 ? 0 : r - 1, r1 = std::min(r + 1, h - 1);
    const std::size_t c0 = c == 0 ? 0 : c - 1, c1 = std::min(c + 1, w - 1);
    for (std::size_t rr = r0; rr <= r1; ++rr)
      for (std::size_t cc = c0; cc <= c1; ++cc)
        if (valid(in[rr * w + cc])) window[k++] = in[rr * w + cc];
    for (int i = 1; i < k; ++i) {  // insertion sort of at most nine values
      const Scalar v = window[i];
      int j = i - 1;
      while (j >= 0 && window[j] > v) {
        window[j + 1] = window[j];
        --j;
      }
      window[j + 1] = v;
    }
    image.depth[r * w + c] = window[(k - 1) / 2];
  };
  for (std::size_t r = 0; r < h; ++r) {
    const bool interior_row = r > 0 && r + 1 < h;
    if (interior_row)
      for (std::size_t c = 0; c < w; ++c) {
        Scalar a = in[(r - 1) * w + c], b = in[r * w + c], d = in[(r + 1) * w + c];
        full[c] = valid(a) && valid(b) && valid(d) ? Scalar(1) : Scalar(0);
        if (a > b) std::swap(a, b);
        if (b > d) std::swap(b, d);
        if (a > b) std::swap(a, b);
        lo[c] = a, mid[c] = b, hi[c] = d;
      }
    for (std::size_t c = 0; c < w; ++c) {
      if (!valid(in[r * w + c])) continue;
      if (interior_row && c > 0 && c + 1 < w && full[c - 1] + full[c] + full[c + 1] == Scalar(3)) {
        // The median of nine from the sorted columns: med3(max of the lows, med3 of the
        // middles, min of the highs).
        const Scalar l = std::max(std::max(lo[c - 1], lo[c]), lo[c + 1]);
        const Scalar u = std::min(std::min(hi[c - 1], hi[c]), hi[c + 1]);
        const Scalar m = std::max(std::min(mid[c - 1], mid[c]),
                                  std::min(std::max(mid[c - 1], mid[c]), mid[c + 1]));
        image.depth[r * w + c] = std::max(std::min(l, m), std::min(std::max(l, m), u));
      } else {
        generic(r, c);
      }
    }
  }
}

/// The same, with its own scratch buffer (allocates).
template <std::floating_point Scalar>
void apply_median_filter(DepthImage<Scalar>& image) {
  std::vector<Scalar> scratch;
  apply_median_filter(image, scratch);
}

/// Parameters of the jump-edge filter.
template <std::floating_point Scalar = double>
struct JumpEdgeParams {
  /// ε_θ of Eq. (14), rad. The paper gives no value; 170 deg keeps surfaces seen at up to about
  /// 80 deg incidence.
  Scalar epsilon_theta{std::numbers::pi_v<Scalar> * Scalar(170) / Scalar(180)};
  /// Only pixels with a neighbour almost straight behind *and* one almost straight in front are
  /// jump edges (mixed pixels); false applies Eq. (14) alone, which also removes the rim of the
  /// nearer surface.
  bool keep_near_edges{true};
  /// m: a neighbour counts as behind or in front only when its distance differs by more than
  /// this. Eq. (14) alone judges the angle only: on a surface seen at a grazing angle (a table
  /// top 2 m ahead of a camera 0.6 m above it: 73 deg incidence, neighbours 2.5 cm apart in
  /// depth) the noise left after the median tips pixel pairs past ε_θ, and a real edge pixel
  /// that also gets a neighbour "in front" that way is removed (10-15 % of them in the
  /// simulated SR4000 scenes). A mixed pixel lies far from both of its surfaces. 8 cm, tuned on
  /// those scenes (tests/egocentric/tof_obstacles.cpp): every simulated mixed pixel is still
  /// removed and 92-97 % of the real edge pixels are kept; a mixed pixel it keeps is within
  /// 8 cm of a surface. 0: Eq. (14) alone.
  Scalar min_jump{Scalar(0.08)};

  /// Throws invalid_argument unless min_jump >= 0 and epsilon_theta lies in (pi/2, pi).
  void validate(std::string_view where = "JumpEdgeParams") const {
    detail::require_non_negative(where, "min_jump", min_jump);
    if (!(epsilon_theta > std::numbers::pi_v<Scalar> / 2 &&
          epsilon_theta < std::numbers::pi_v<Scalar>))
      detail::throw_invalid_argument(where, "epsilon_theta", epsilon_theta,
                                     "must lie in (pi/2, pi)");
  }
};

/// The jump-edge filter of Eq. (13)-(14) for one camera: the cosines of the angles φ between
/// neighbouring pixel rays are computed once from the intrinsics; filter() then needs no
/// trigonometry (the angle test is done on cosines, squared) and allocates nothing.
template <std::floating_point Scalar = double>
class JumpEdgeFilter {
 public:
  JumpEdgeFilter() = default;
  /// The filter for a camera with these intrinsics and depth kind. Throws invalid_argument for
  /// invalid intrinsics or parameters.
  JumpEdgeFilter(const PinholeIntrinsics<Scalar>& intrinsics, DepthKind kind,
                 const JumpEdgeParams<Scalar>& params = {})
      : intrinsics_(intrinsics), kind_(kind), params_(params) {
    intrinsics_.validate("JumpEdgeFilter");
    params_.validate("JumpEdgeFilter");
    const std::size_t w = intrinsics_.width, h = intrinsics_.height, n = w * h;
    ray_norm_.resize(n);
    std::vector<Point<3, Scalar>> unit(n);
    for (std::size_t r = 0; r < h; ++r)
      for (std::size_t c = 0; c < w; ++c) {
        const Point<3, Scalar> ray = intrinsics_.optical_ray(r, c);
        ray_norm_[r * w + c] = ray.norm();
        unit[r * w + c] = ray / ray.norm();
      }
    // cos φ towards the right, lower, lower-right and lower-left neighbours; the other four
    // directions are the same pairs seen from the other pixel.
    for (int k = 0; k < 4; ++k)
      cos_phi_[k].assign(n, Scalar(1));
    for (std::size_t r = 0; r < h; ++r)
      for (std::size_t c = 0; c < w; ++c) {
        const std::size_t i = r * w + c;
        for (int k = 0; k < 4; ++k) {
          const auto [dr, dc] = offsets_[k];
          const std::ptrdiff_t rr = static_cast<std::ptrdiff_t>(r) + dr;
          const std::ptrdiff_t cc = static_cast<std::ptrdiff_t>(c) + dc;
          if (rr < 0 || cc < 0 || rr >= static_cast<std::ptrdiff_t>(h) ||
              cc >= static_cast<std::ptrdiff_t>(w))
            continue;
          cos_phi_[k][i] =
              unit[i].dot(unit[static_cast<std::size_t>(rr) * w + static_cast<std::size_t>(cc)]);
        }
      }
  }

  /// The filter's parameters.
  [[nodiscard]] const JumpEdgeParams<Scalar>& params() const { return params_; }

  /// Marks the jump edges of `image` (same intrinsics as the filter) invalid; returns how many.
  std::size_t filter(DepthImage<Scalar>& image) {
    if (image.width() != intrinsics_.width || image.height() != intrinsics_.height)
      detail::throw_invalid_argument("JumpEdgeFilter::filter", "image.width()", image.width(),
                                     "and height must match the filter's intrinsics");
    image.validate("JumpEdgeFilter::filter");
    const std::size_t w = intrinsics_.width, h = intrinsics_.height, n = w * h;
    radial_.resize(n);
    flags_.assign(n, 0);
    for (std::size_t i = 0; i < n; ++i) {
      const Scalar d = image.depth[i];
      radial_[i] = DepthImage<Scalar>::is_valid_depth(d)
                       ? (kind_ == DepthKind::z_depth ? d * ray_norm_[i] : d)
                       : Scalar(0);
    }
    // cos θ of the angle at p (towards f and towards q): (|p| - |q| cos φ) / |q - p|.
    // θ > ε_θ (behind) <=> cos θ < cos ε_θ < 0; θ < π - ε_θ (in front) <=> cos θ > -cos ε_θ.
    const Scalar ce = -std::cos(params_.epsilon_theta);  // > 0
    const Scalar ce_sq = ce * ce;
    const Scalar min_jump = params_.min_jump;
    constexpr unsigned char behind = 1, in_front = 2;
    // One pass per neighbour direction over the pixels that have that neighbour, so the inner
    // loop runs over a contiguous row span without bounds tests.
    for (int k = 0; k < 4; ++k) {
      const auto [dr, dc] = offsets_[k];
      const std::size_t c0 = dc < 0 ? 1 : 0, c1 = dc > 0 ? w - 1 : w;
      const std::size_t rows = h - static_cast<std::size_t>(dr);
      const std::ptrdiff_t off = dr * static_cast<std::ptrdiff_t>(w) + dc;
      const Scalar* cos_phi = cos_phi_[k].data();
      for (std::size_t r = 0; r < rows; ++r)
        for (std::size_t c = c0; c < c1; ++c) {
          const std::size_t i = r * w + c;
          const Scalar a = radial_[i];
          const std::size_t j = static_cast<std::size_t>(static_cast<std::ptrdiff_t>(i) + off);
          const Scalar b = radial_[j];
          if (a == Scalar(0) || b == Scalar(0)) continue;
          const Scalar cphi = cos_phi[i];
          const Scalar dist_sq = a * a + b * b - 2 * a * b * cphi;  // |p_i - p_n|^2
          const Scalar ta = a - b * cphi;                           // |p_i - p_n| cos θ at p_i
          const Scalar tb = b - a * cphi;                           // |p_i - p_n| cos θ at p_n
          const Scalar lim = ce_sq * dist_sq;
          if (std::abs(a - b) <= min_jump) continue;  // within the noise: no jump
          if (ta * ta > lim) flags_[i] |= ta < 0 ? behind : in_front;
          if (tb * tb > lim) flags_[j] |= tb < 0 ? behind : in_front;
        }
    }
    const unsigned char jump = params_.keep_near_edges ? (behind | in_front) : behind;
    std::size_t removed = 0;
    for (std::size_t i = 0; i < n; ++i)
      if ((flags_[i] & jump) == jump) {
        image.depth[i] = std::numeric_limits<Scalar>::quiet_NaN();
        ++removed;
      }
    return removed;
  }

 private:
  static constexpr std::pair<int, int> offsets_[4] = {{0, 1}, {1, 0}, {1, 1}, {1, -1}};
  PinholeIntrinsics<Scalar> intrinsics_{};
  DepthKind kind_{DepthKind::radial};
  JumpEdgeParams<Scalar> params_{};
  std::vector<Scalar> ray_norm_;
  std::vector<Scalar> cos_phi_[4];
  std::vector<Scalar> radial_;
  std::vector<unsigned char> flags_;
};

}  // namespace rangenav
