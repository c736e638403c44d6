// PSNR of two RGBA8 images (see psnr.h).
#include "image/psnr.h"

#include <cmath>

namespace meshmux {

double psnr_rgb(const Image& a, const Image& b) {
  double se = 0;
  size_t n = 0;
  for (size_t k = 0; k < a.rgba.size() && k < b.rgba.size(); ++k) {
    if (k % 4 == 3) continue;
    const double d = double(a.rgba[k]) - double(b.rgba[k]);
    se += d * d, ++n;
  }
  return se == 0 || n == 0 ? 99 : 10 * std::log10(255.0 * 255.0 / (se / double(n)));
}

}  // namespace meshmux
