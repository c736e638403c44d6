// Texture levels (DESIGN.md "Texture levels", paper 000 §4.4 for why power-of-two levels stay
// clean when no chart crosses a power-of-two boundary).
#include "image/texture_levels.h"

#include <array>
#include <cmath>

#include "image/color.h"
#include "image/encode.h"

namespace meshmux {

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
  // The chain, full size first, down to the base.
  std::vector<Image> chain{texture};
  while (std::max(chain.back().width, chain.back().height) > o.base_size)
    chain.push_back(downsample_half(chain.back()));
  TextureLevels levels;
  for (size_t i = chain.size(); i-- > 0;) {
    TextureLevel level;
    level.width = chain[i].width;
    level.height = chain[i].height;
    auto bytes = alpha ? encode_png(chain[i]) : encode_jpeg(chain[i], o.jpeg_quality);
    if (!bytes.ok()) return bytes.status().with_prefix(who);
    level.mime_type = alpha ? "image/png" : "image/jpeg";
    level.encoded = bytes.take();
    levels.levels.push_back(std::move(level));
  }
  return levels;
}

}  // namespace meshmux
