#include "image/fill_empty.h"

#include <algorithm>
#include <cmath>

#include "core/parallel.h"
#include "image/color.h"

namespace meshmux {

namespace {

// One level of the pyramid: per texel an RGBA mean (linear light for colour) and whether any
// texel below it was filled.
struct Level {
  int w = 0, h = 0;
  std::vector<float> value;  // w × h × 4
  std::vector<uint8_t> ok;   // w × h
};

// Rows of one level are independent: split them over the threads.
void for_rows(int h, int w, const std::function<void(int)>& row) {
  const size_t rows_per_chunk = std::max<size_t>(1, size_t(65536) / size_t(std::max(1, w)));
  parallel_chunks(size_t(h), rows_per_chunk, [&](size_t begin, size_t end) {
    for (size_t y = begin; y < end; ++y) row(int(y));
  });
}

// The coarser level over a w × h grid: each texel the mean of its 2 × 2 children that `add`
// finds filled (add(i, sum): adds child i's RGBA to sum and returns true, or returns false).
template <class Add>
Level pull_level(int w, int h, const Add& add) {
  Level out;
  out.w = (w + 1) / 2, out.h = (h + 1) / 2;
  out.value.assign(size_t(out.w) * size_t(out.h) * 4, 0.0f);
  out.ok.assign(size_t(out.w) * size_t(out.h), 0);
  for_rows(out.h, out.w, [&](int y) {
    for (int x = 0; x < out.w; ++x) {
      float sum[4] = {0, 0, 0, 0};
      int n = 0;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const int sx = 2 * x + dx, sy = 2 * y + dy;
          if (sx < w && sy < h && add(size_t(sy) * size_t(w) + size_t(sx), sum)) ++n;
        }
      if (n == 0) continue;
      const size_t o = size_t(y) * size_t(out.w) + size_t(x);
      for (int c = 0; c < 4; ++c) out.value[o * 4 + size_t(c)] = sum[c] / float(n);
      out.ok[o] = 1;
    }
  });
  return out;
}

// The first coarser level, from the image's filled texels.
Level pull_from_image(int w, int h, const std::vector<uint8_t>& filled,
                      const std::vector<uint8_t>& rgba, bool srgb) {
  return pull_level(w, h, [&](size_t i, float* sum) {
    if (!filled[i]) return false;
    const uint8_t* p = &rgba[i * 4];
    for (int c = 0; c < 3; ++c) sum[c] += srgb ? srgb_to_linear(p[c]) : p[c] / 255.0f;
    sum[3] += p[3] / 255.0f;
    return true;
  });
}

// The next coarser level of `in`.
Level pull(const Level& in) {
  return pull_level(in.w, in.h, [&](size_t i, float* sum) {
    if (!in.ok[i]) return false;
    for (int c = 0; c < 4; ++c) sum[c] += in.value[i * 4 + size_t(c)];
    return true;
  });
}

// Every texel of `fine` that is not ok takes its parent's value in `coarse` (all ok).
void push(const Level& coarse, Level& fine) {
  for_rows(fine.h, fine.w, [&](int y) {
    for (int x = 0; x < fine.w; ++x) {
      const size_t i = size_t(y) * size_t(fine.w) + size_t(x);
      if (fine.ok[i]) continue;
      const size_t p = size_t(y / 2) * size_t(coarse.w) + size_t(x / 2);
      std::copy_n(&coarse.value[p * 4], 4, &fine.value[i * 4]);
      fine.ok[i] = 1;
    }
  });
}

bool all_ok(const Level& l) {
  return std::all_of(l.ok.begin(), l.ok.end(), [](uint8_t v) { return v != 0; });
}

void fill_layer(int w, int h, const std::vector<uint8_t>& filled, const FillLayer& layer) {
  std::vector<uint8_t>& rgba = *layer.rgba;
  // Pull until a level is filled everywhere (at the latest the 1 × 1 level, which is, since
  // the caller checked some texel is filled).
  std::vector<Level> levels;
  levels.push_back(pull_from_image(w, h, filled, rgba, layer.srgb));
  while (!all_ok(levels.back()) && (levels.back().w > 1 || levels.back().h > 1))
    levels.push_back(pull(levels.back()));
  // Push down to the first coarser level, then into the image's empty texels.
  for (size_t k = levels.size() - 1; k > 0; --k) push(levels[k], levels[k - 1]);
  const Level& parent = levels.front();
  for_rows(h, w, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      if (filled[i]) continue;
      const float* v = &parent.value[(size_t(y / 2) * size_t(parent.w) + size_t(x / 2)) * 4];
      uint8_t* q = &rgba[i * 4];
      for (int c = 0; c < 3; ++c)
        q[c] = layer.srgb ? linear_to_srgb(v[c])
                          : uint8_t(std::lround(std::clamp(v[c], 0.0f, 1.0f) * 255.0f));
      q[3] = uint8_t(std::lround(std::clamp(v[3], 0.0f, 1.0f) * 255.0f));
    }
  });
}

}  // namespace

void fill_empty_texels(int w, int h, const std::vector<uint8_t>& filled,
                       const std::vector<FillLayer>& layers) {
  if (w < 1 || h < 1 || filled.size() < size_t(w) * size_t(h)) return;
  if (std::none_of(filled.begin(), filled.end(), [](uint8_t v) { return v != 0; })) return;
  for (const FillLayer& layer : layers)
    if (layer.rgba && layer.rgba->size() >= size_t(w) * size_t(h) * 4)
      fill_layer(w, h, filled, layer);
}

}  // namespace meshmux
