// Image distortion over the union of coverage masks (Yang, Shen and Kuo, "Progressive coding of
// 3D textured graphic model via joint mesh-texture optimization" §3: distortion is measured on
// the rendered image against the full-quality render; the paper uses MSE, we also report PSNR
// and mean CIEDE2000).
#include "multiplex/distortion.h"

#include <array>
#include <cmath>
#include <limits>

#include "image/color.h"

namespace meshmux {

// Conventions beyond the header:
//  - Sizes differ (or a buffer is shorter than width×height says): nothing can be compared;
//    returns pixels = 0, mse = ciede2000 = +inf and psnr = −inf (10 log10(255²/∞)), so such a
//    result is never mistaken for a good one.
//  - A pixel is measured when either image covers it; an uncovered pixel counts as black
//    (0,0,0), whatever its rgba bytes hold. Alpha is ignored.
//  - Empty union: all zeros, pixels = 0.
Distortion measure_distortion(const RenderImage& reference, const RenderImage& image) {
  Distortion out;
  const double inf = std::numeric_limits<double>::infinity();
  auto valid = [](const RenderImage& im) {
    if (im.width < 0 || im.height < 0) return false;
    size_t n = size_t(im.width) * size_t(im.height);
    return im.rgba.size() >= n * 4 && im.coverage.size() >= n;
  };
  if (reference.width != image.width || reference.height != image.height || !valid(reference) ||
      !valid(image)) {
    out.mse = inf;
    out.psnr = -inf;
    out.ciede2000 = inf;
    out.pixels = 0;
    return out;
  }

  std::array<double, 256> linear;
  for (int v = 0; v < 256; ++v) linear[v] = srgb_to_linear(uint8_t(v));

  const size_t n = size_t(reference.width) * size_t(reference.height);
  double sum_sq = 0, sum_de = 0;
  size_t count = 0;
  for (size_t p = 0; p < n; ++p) {
    bool in_ref = reference.coverage[p] != 0, in_img = image.coverage[p] != 0;
    if (!in_ref && !in_img) continue;
    uint8_t a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
    for (int c = 0; c < 3; ++c) {
      if (in_ref) a[c] = reference.rgba[p * 4 + c];
      if (in_img) b[c] = image.rgba[p * 4 + c];
      double diff = double(a[c]) - double(b[c]);
      sum_sq += diff * diff;
    }
    if (a[0] != b[0] || a[1] != b[1] || a[2] != b[2]) {
      Lab la = linear_rgb_to_lab(linear[a[0]], linear[a[1]], linear[a[2]]);
      Lab lb = linear_rgb_to_lab(linear[b[0]], linear[b[1]], linear[b[2]]);
      sum_de += ciede2000(la, lb);
    }
    ++count;
  }
  out.pixels = count;
  if (count == 0) return out;
  out.mse = sum_sq / (double(count) * 3.0);
  out.psnr = out.mse > 0 ? 10.0 * std::log10(255.0 * 255.0 / out.mse) : inf;
  out.ciede2000 = sum_de / double(count);
  return out;
}

}  // namespace meshmux
