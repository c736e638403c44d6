// Kept images at the texture levels' scales (image/kept_levels.h).
#include "image/kept_levels.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "image/decode.h"
#include "image/encode.h"
#include "image/resize.h"
#include "image/texture_levels.h"

namespace meshmux {

namespace {}  // namespace

TexelFilter kept_image_filter(const Scene& scene, int32_t image) {
  bool colour = false, normal = false, other = false;
  for (const Material& m : scene.materials) {
    auto is = [&](const TextureRef& t) { return t.present() && t.image == image; };
    colour = colour || is(m.base_color) || is(m.emissive) || is(m.sheen_color) ||
             is(m.layer(LayerSlot::kSpecularColor));
    normal = normal || is(m.normal) || is(m.layer(LayerSlot::kClearcoatNormal));
    for (const TextureRef* t : texture_refs(m))
      other = other || (is(*t) && t != &m.base_color && t != &m.emissive && t != &m.sheen_color &&
                        t != &m.layer(LayerSlot::kSpecularColor) && t != &m.normal &&
                        t != &m.layer(LayerSlot::kClearcoatNormal));
  }
  if (colour) return TexelFilter::kSrgb;
  return normal && !other ? TexelFilter::kNormal : TexelFilter::kData;
}

namespace {

// The image's sides at `scale` of its own.
std::pair<int, int> scaled_sides(const Image& img, double scale) {
  auto side = [&](int s) {
    return std::max(std::min(s, kKeptMinSide), int(std::lround(double(s) * scale)));
  };
  return {side(img.width), side(img.height)};
}

// `full` reduced to width × height: box halvings while both sides stay at least twice the
// target's, then one Catmull-Rom resample.
Image reduce(const Image& full, int width, int height, TexelFilter filter) {
  Image cur = full;
  while (cur.width / 2 >= width * 2 && cur.height / 2 >= height * 2)
    cur = downsample_half(cur, filter);
  if (cur.width == width && cur.height == height) return cur;
  return resize_cubic(cur, width, height, filter == TexelFilter::kSrgb);
}

}  // namespace

std::vector<int32_t> kept_level_images(const Scene& scene) {
  std::set<int32_t> streamed, used;
  if (!scene.materials.empty())
    for (const TextureRef* t : texture_refs(scene.materials[0]))
      if (t->present()) streamed.insert(t->image);
  for (const Material& m : scene.materials)
    for (const TextureRef* t : texture_refs(m))
      if (t->present() && size_t(t->image) < scene.images.size() && !streamed.count(t->image))
        used.insert(t->image);
  return {used.begin(), used.end()};
}

Status add_kept_levels(const Scene& scene, TextureLevels& levels, int preview_quality) {
  if (levels.levels.empty()) return Status::ok();
  const double top = double(std::max(1, levels.levels.back().width));
  for (int32_t i : kept_level_images(scene)) {
    const Image& source = scene.images[size_t(i)];
    if (source.encoded.empty() ||
        (source.mime_type != "image/jpeg" && source.mime_type != "image/png"))
      continue;     // shipped as it is (the exporter re-encodes what it must)
    Image decoded;  // only when the scene holds no pixels for it
    if (!source.decoded()) {
      decoded = source;
      if (!decode_image(decoded)) continue;
    }
    const Image& full = source.decoded() ? source : decoded;
    const TexelFilter filter = kept_image_filter(scene, i);
    const bool jpeg = source.mime_type == "image/jpeg";
    std::pair<int, int> before = {0, 0};
    for (size_t j = 0; j < levels.levels.size(); ++j) {
      TextureLevel& level = levels.levels[j];
      const bool finest = j + 1 == levels.levels.size();
      const std::pair<int, int> sides = finest ? std::pair<int, int>{full.width, full.height}
                                               : scaled_sides(full, double(level.width) / top);
      if (sides == before) continue;  // the level below's map stands
      before = sides;
      KeptMap map;
      map.image = i;
      map.width = sides.first, map.height = sides.second;
      map.mime_type = source.mime_type;
      if (sides == std::pair<int, int>{full.width, full.height}) {
        map.encoded = source.encoded;
      } else {
        Image small = reduce(full, sides.first, sides.second, filter);
        auto bytes = jpeg ? encode_jpeg(small, preview_quality) : encode_png(small);
        if (!bytes.ok())
          return Status::error("texture levels: kept image " + std::to_string(i) + " '" +
                                   source.name + "': " + bytes.status().message(),
                               ErrorKind::kInternal);
        map.encoded = bytes.take();
      }
      level.kept.push_back(std::move(map));
    }
  }
  return Status::ok();
}

void apply_kept_level(Scene& scene, const TextureLevels& levels, size_t level) {
  for (size_t j = 0; j <= level && j < levels.levels.size(); ++j)
    for (const KeptMap& map : levels.levels[j].kept) {
      if (map.image < 0 || size_t(map.image) >= scene.images.size()) continue;
      Image& img = scene.images[size_t(map.image)];
      img.encoded = map.encoded;
      img.mime_type = map.mime_type;
      img.width = map.width, img.height = map.height;
      std::vector<uint8_t>().swap(img.rgba);
    }
}

}  // namespace meshmux
