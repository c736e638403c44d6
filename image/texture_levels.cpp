// Texture levels (DESIGN.md "Texture levels", paper 000 §4.4 for why power-of-two levels stay
// clean when no chart crosses a power-of-two boundary).
#include "image/texture_levels.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "image/color.h"
#include "image/encode.h"

namespace meshmux {

namespace {
constexpr int kMinPreviewSide = 8;  // a preview level is never halved below this
}  // namespace

namespace {

bool power_of_two(int v) { return v > 0 && (v & (v - 1)) == 0; }

}  // namespace

Image downsample_half(const Image& in) {
  Image out;
  out.name = in.name;
  out.width = std::max(1, in.width / 2);
  out.height = std::max(1, in.height / 2);
  out.rgba.resize(size_t(out.width) * size_t(out.height) * 4);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      float acc[3] = {0, 0, 0};
      int alpha = 0, n = 0;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          int sx = std::min(in.width - 1, 2 * x + dx), sy = std::min(in.height - 1, 2 * y + dy);
          const uint8_t* p = &in.rgba[(size_t(sy) * size_t(in.width) + size_t(sx)) * 4];
          for (int c = 0; c < 3; ++c) acc[c] += srgb_to_linear(p[c]);
          alpha += p[3];
          ++n;
        }
      uint8_t* q = &out.rgba[(size_t(y) * size_t(out.width) + size_t(x)) * 4];
      for (int c = 0; c < 3; ++c) q[c] = linear_to_srgb(acc[c] / float(n));
      q[3] = uint8_t((alpha + n / 2) / n);
    }
  return out;
}

Result<TextureLevels> make_texture_levels(const Image& texture, const TextureLevelOptions& o) {
  std::string who =
      "texture levels: " + (texture.name.empty() ? std::string("texture") : texture.name);
  if (!texture.decoded())
    return Status::error(who + ": image is not decoded", ErrorKind::kInternal);
  if (!power_of_two(texture.width) || !power_of_two(texture.height))
    return Status::error(who + ": " + std::to_string(texture.width) + "x" +
                             std::to_string(texture.height) +
                             " is not a power of two in both dimensions",
                         ErrorKind::kInternal);
  if (!power_of_two(o.base_size))
    return Status::error(
        who + ": base size " + std::to_string(o.base_size) + " is not a power of two",
        ErrorKind::kInternal);
  bool alpha = false;
  for (size_t i = 3; i < texture.rgba.size() && !alpha; i += 4) alpha = texture.rgba[i] != 255;
  if (o.level_halvings < 1 || o.level_halvings > 4)
    return Status::error(
        who + ": level_halvings " + std::to_string(o.level_halvings) + " is not in 1..4",
        ErrorKind::kInternal);
  // The mip chain, full size first (each step a 2×2 box filter), down to the base; every
  // level_halvings-th is a level.
  const size_t step = size_t(o.level_halvings);
  std::vector<Image> chain{texture};
  while (std::max(chain.back().width, chain.back().height) > 1 &&
         (std::max(chain.back().width, chain.back().height) > o.base_size ||
          (chain.size() - 1) % step != 0))
    chain.push_back(downsample_half(chain.back()));
  TextureLevels levels;
  for (size_t i = chain.size(); i-- > 0;) {
    if (i % step != 0 && i + 1 != chain.size()) continue;
    TextureLevel level;
    level.width = chain[i].width;
    level.height = chain[i].height;
    auto bytes = alpha ? encode_png(chain[i])
                       : encode_jpeg(chain[i], i == 0 ? o.jpeg_quality : o.preview_quality);
    if (!bytes.ok()) return bytes.status().with_prefix(who);
    level.mime_type = alpha ? "image/png" : "image/jpeg";
    level.encoded = bytes.take();
    levels.levels.push_back(std::move(level));
  }
  auto total = [&] {
    uint64_t n = 0;
    for (const TextureLevel& l : levels.levels) n += l.encoded.size();
    return n;
  };
  const double top = double(levels.levels.back().encoded.size());
  while (levels.levels.size() > 2 && double(total()) > o.max_pyramid_ratio * top) {
    auto largest = std::max_element(levels.levels.begin() + 1, levels.levels.end() - 1,
                                    [](const TextureLevel& a, const TextureLevel& b) {
                                      return a.encoded.size() < b.encoded.size();
                                    });
    char why[160];
    std::snprintf(why, sizeof why,
                  "with it the levels cost %.3f× the top level (limit %.2f); the largest level "
                  "between the smallest and the top goes first",
                  double(total()) / top, o.max_pyramid_ratio);
    levels.dropped.push_back(
        {largest->width, largest->height, uint64_t(largest->encoded.size()), why});
    levels.levels.erase(largest);
  }
  // Still too dear with only the smallest level below the top: that level halves again (a
  // smaller first picture) until the pyramid fits or it is a single texel.
  Image smallest = chain.back();
  while (levels.levels.size() == 2 && double(total()) > o.max_pyramid_ratio * top &&
         std::max(smallest.width, smallest.height) > kMinPreviewSide) {
    TextureLevel& first = levels.levels.front();
    char why[160];
    std::snprintf(why, sizeof why,
                  "with it the levels cost %.3f× the top level (limit %.2f); the smallest level "
                  "halves instead",
                  double(total()) / top, o.max_pyramid_ratio);
    levels.dropped.push_back({first.width, first.height, uint64_t(first.encoded.size()), why});
    smallest = downsample_half(smallest);
    auto bytes = alpha ? encode_png(smallest) : encode_jpeg(smallest, o.preview_quality);
    if (!bytes.ok()) return bytes.status().with_prefix(who);
    first.width = smallest.width, first.height = smallest.height;
    first.encoded = bytes.take();
  }
  // A preview that small still too dear (a tiny texture: the file's headers dominate): the top
  // level is the only one.
  if (levels.levels.size() == 2 && double(total()) > o.max_pyramid_ratio * top) {
    const TextureLevel& first = levels.levels.front();
    char why[160];
    std::snprintf(why, sizeof why,
                  "with it the levels cost %.3f× the top level (limit %.2f) even at %dx%d: the "
                  "top level is the only one",
                  double(total()) / top, o.max_pyramid_ratio, first.width, first.height);
    levels.dropped.push_back({first.width, first.height, uint64_t(first.encoded.size()), why});
    levels.levels.erase(levels.levels.begin());
  }
  return levels;
}

}  // namespace meshmux
