// Catmull-Rom resampling (see resize.h).
#include "image/resize.h"

#include <algorithm>
#include <cmath>

#include "core/parallel.h"
#include "image/color.h"

namespace meshmux {
namespace {

// Keys's cubic with a = −0.5 (Catmull-Rom), |t| < 2.
double cubic(double t) {
  t = std::abs(t);
  if (t < 1) return (1.5 * t - 2.5) * t * t + 1;
  if (t < 2) return ((-0.5 * t + 2.5) * t - 4) * t + 2;
  return 0;
}

// Per output coordinate: the four input taps (clamped) and their weights (normalized).
struct Taps {
  std::vector<int> index;      // 4 per output
  std::vector<double> weight;  // 4 per output
};
Taps taps(int in, int out) {
  Taps t;
  t.index.resize(size_t(out) * 4);
  t.weight.resize(size_t(out) * 4);
  for (int o = 0; o < out; ++o) {
    const double x = (o + 0.5) * double(in) / out - 0.5;
    const int x0 = int(std::floor(x));
    double sum = 0;
    for (int k = 0; k < 4; ++k) {
      const int i = x0 - 1 + k;
      const double w = cubic(x - i);
      t.index[size_t(o) * 4 + size_t(k)] = std::clamp(i, 0, in - 1);
      t.weight[size_t(o) * 4 + size_t(k)] = w;
      sum += w;
    }
    for (int k = 0; k < 4; ++k) t.weight[size_t(o) * 4 + size_t(k)] /= sum;
  }
  return t;
}

}  // namespace

int next_power_of_two(int v) {
  int p = 1;
  while (p < v && p < (1 << 30)) p *= 2;
  return p;
}

Image resize_cubic(const Image& in, int width, int height, bool srgb) {
  Image out;
  out.name = in.name;
  out.width = width;
  out.height = height;
  const size_t iw = size_t(in.width), ih = size_t(in.height);
  // Linear values, 4 per texel. Each pass in bands of rows on every core (each band writes its
  // own rows: the same values whatever the thread count).
  std::vector<float> src(iw * ih * 4);
  parallel_chunks(ih, 16, [&](size_t y0, size_t y1) {
    for (size_t i = y0 * iw * 4; i < y1 * iw * 4; ++i)
      src[i] = srgb && i % 4 != 3 ? srgb_to_linear(in.rgba[i]) : in.rgba[i] / 255.0f;
  });
  const Taps tx = taps(in.width, width), ty = taps(in.height, height);
  std::vector<float> rows(size_t(width) * ih * 4);  // horizontal pass
  parallel_chunks(ih, 16, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y)
      for (size_t x = 0; x < size_t(width); ++x)
        for (size_t c = 0; c < 4; ++c) {
          double v = 0;
          for (size_t k = 0; k < 4; ++k)
            v += tx.weight[x * 4 + k] * src[(y * iw + size_t(tx.index[x * 4 + k])) * 4 + c];
          rows[(y * size_t(width) + x) * 4 + c] = float(v);
        }
  });
  out.rgba.resize(size_t(width) * size_t(height) * 4);
  parallel_chunks(size_t(height), 16, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y)
      for (size_t x = 0; x < size_t(width); ++x)
        for (size_t c = 0; c < 4; ++c) {
          double v = 0;
          for (size_t k = 0; k < 4; ++k)
            v += ty.weight[y * 4 + k] *
                 rows[(size_t(ty.index[y * 4 + k]) * size_t(width) + x) * 4 + c];
          const float f = float(std::clamp(v, 0.0, 1.0));
          out.rgba[(y * size_t(width) + x) * 4 + c] =
              srgb && c != 3 ? linear_to_srgb(f) : uint8_t(std::lround(f * 255.0f));
        }
  });
  return out;
}

}  // namespace meshmux
