// Kept images at the texture levels' scales (image/kept_levels.h).
#include "image/kept_levels.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <tuple>

#include "image/decode.h"
#include "image/encode.h"
#include "image/resize.h"
#include "image/texture_levels.h"

namespace meshmux {

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

// `full`'s 2×2 box halvings, made as the sizes asked for need them (full itself not copied).
class Halvings {
 public:
  Halvings(const Image& full, TexelFilter filter) : full_(full), filter_(filter) {}
  // `full` reduced to width × height: box halvings while both sides stay at least twice the
  // target's, then one Catmull-Rom resample.
  Image reduce(int width, int height) {
    const Image* cur = &full_;
    for (size_t k = 0; cur->width / 2 >= width * 2 && cur->height / 2 >= height * 2; ++k) {
      if (k == chain_.size()) chain_.push_back(downsample_half(*cur, filter_));
      cur = &chain_[k];
    }
    if (cur->width == width && cur->height == height) return *cur;
    return resize_cubic(*cur, width, height, filter_ == TexelFilter::kSrgb);
  }

 private:
  const Image& full_;
  TexelFilter filter_;
  std::deque<Image> chain_;  // full's halvings, in order
};

}  // namespace

std::vector<int32_t> kept_level_images(const Scene& scene, int32_t streamed_material) {
  std::set<int32_t> streamed, used;
  if (streamed_material >= 0 && size_t(streamed_material) < scene.materials.size())
    for (const TextureRef* t : texture_refs(scene.materials[size_t(streamed_material)]))
      if (t->present()) streamed.insert(t->image);
  for (const Material& m : scene.materials)
    for (const TextureRef* t : texture_refs(m))
      if (t->present() && size_t(t->image) < scene.images.size() && !streamed.count(t->image))
        used.insert(t->image);
  return {used.begin(), used.end()};
}

namespace {

// One kept image a level can carry. Its pixels are the scene's, or decoded where they are used
// (one image's at a time: a scene of many large tiled textures would hold them all otherwise).
struct KeptSource {
  int32_t image = -1;
  const Image* source = nullptr;  // the scene's image: its encoded bytes and mime type
  TexelFilter filter = TexelFilter::kData;
  int width = 0, height = 0;  // as decoded
  // The source's own bytes are JPEG or PNG (KTX2 when the levels are KTX2), which the finest
  // level carries as they came; else (pixels made in code, WebP, a transcoded KTX2) every
  // level's map is made, as PNG (KTX2).
  bool own_bytes = true;
};

// The kept images a level can carry: JPEG or PNG (KTX2 when `ktx2`), or pixels that can be
// encoded as PNG (KTX2) (`streamed_material`'s own images are the levels').
std::vector<KeptSource> kept_sources(const Scene& scene, int32_t streamed_material, bool ktx2) {
  std::vector<KeptSource> out;
  for (int32_t i : kept_level_images(scene, streamed_material)) {
    const Image& source = scene.images[size_t(i)];
    KeptSource k;
    k.image = i, k.source = &source, k.filter = kept_image_filter(scene, i);
    k.own_bytes = !source.encoded.empty() &&
                  (ktx2 ? source.mime_type == "image/ktx2"
                        : source.mime_type == "image/jpeg" || source.mime_type == "image/png");
    k.width = source.width, k.height = source.height;
    if (!source.decoded()) {                 // never decoded: is it decodable, and how large?
      if (source.encoded.empty()) continue;  // no pixels and no bytes: shipped as it is
      Image probe = source;
      if (!decode_image(probe)) continue;
      k.width = probe.width, k.height = probe.height;
    }
    out.push_back(k);
  }
  return out;
}

// A kept image's map at some sides, once encoded: the byte bound's rounds ask for the same maps
// again (the levels that stay keep their scales).
using KeptMaps = std::map<std::tuple<int32_t, int, int>, std::vector<uint8_t>>;

// The sides each level's map of `full_sides` has at `scales` (the finest: as it came), or none
// where the level below's map stands.
std::vector<std::optional<std::pair<int, int>>> kept_sides(std::pair<int, int> full_sides,
                                                           const std::vector<double>& scales) {
  Image probe;  // scaled_sides reads the sides only
  probe.width = full_sides.first, probe.height = full_sides.second;
  std::vector<std::optional<std::pair<int, int>>> out;
  std::pair<int, int> before = {0, 0};
  for (size_t j = 0; j < scales.size(); ++j) {
    const std::pair<int, int> sides =
        j + 1 == scales.size() ? full_sides : scaled_sides(probe, scales[j]);
    out.push_back(sides == before ? std::nullopt : std::optional(sides));
    before = sides;
  }
  return out;
}

// One kept map as KTX2 (encode_level_ktx2, every core), its file's bytes.
Result<std::vector<uint8_t>> kept_ktx2(const Image& small, TexelFilter filter,
                                       const TextureLevelOptions& options) {
  auto r = encode_level_ktx2(small, filter, options.ktx2_options);
  if (!r.ok()) return r.status();
  return std::move(r->bytes);
}

// Fills levels[j].kept with every source at scales[j] of its size (the finest: as it came), a
// map only where the size differs from the level below's. Maps already in `made` are not made
// again; those made here go into it.
Status fill_kept(const std::vector<KeptSource>& sources, const std::vector<double>& scales,
                 TextureLevels& levels, const TextureLevelOptions& options, KeptMaps& made) {
  for (TextureLevel& l : levels.levels) l.kept.clear();
  for (const KeptSource& k : sources) {
    const std::pair<int, int> full_sides = {k.width, k.height};
    const auto sides = kept_sides(full_sides, scales);
    bool missing = false;
    for (const auto& s : sides)
      missing |=
          s && (*s != full_sides || !k.own_bytes) && !made.count({k.image, s->first, s->second});
    Image decoded;  // only when a map must be made and the scene holds no pixels for it
    if (missing && !k.source->decoded()) {
      decoded = *k.source;
      if (!decode_image(decoded)) continue;  // shipped as it is, like an image with no pixels
    }
    const Image& full = k.source->decoded() ? *k.source : decoded;
    Halvings halvings(full, k.filter);
    for (size_t j = 0; j < levels.levels.size() && j < sides.size(); ++j) {
      if (!sides[j]) continue;  // the level below's map stands
      KeptMap map;
      map.image = k.image;
      map.width = sides[j]->first, map.height = sides[j]->second;
      map.mime_type = k.own_bytes ? k.source->mime_type : options.ktx2 ? "image/ktx2" : "image/png";
      const std::tuple<int32_t, int, int> key = {k.image, map.width, map.height};
      if (*sides[j] == full_sides && k.own_bytes) {
        map.encoded = k.source->encoded;
      } else if (auto it = made.find(key); it != made.end()) {
        map.encoded = it->second;
      } else {
        Image small = halvings.reduce(map.width, map.height);
        auto bytes = map.mime_type == "image/jpeg"
                         ? encode_jpeg(small, options.preview_quality, options.counts)
                     : map.mime_type == "image/png" ? encode_png(small, options.counts)
                                                    : kept_ktx2(small, k.filter, options);
        if (!bytes.ok())
          return Status::error("texture levels: kept image " + std::to_string(k.image) + " '" +
                                   k.source->name + "': " + bytes.status().message(),
                               ErrorKind::kInternal);
        map.encoded = bytes.take();
        made[key] = map.encoded;
      }
      if (map.mime_type == "image/ktx2") {  // sides rounded up to multiples of 4 (ktx2_sides)
        const std::pair<int, int> s = ktx2_sides(map.width, map.height);
        map.width = s.first, map.height = s.second;
      }
      levels.levels[j].kept.push_back(std::move(map));
    }
  }
  return Status::ok();
}

}  // namespace

Status add_kept_levels(const Scene& scene, TextureLevels& levels,
                       const TextureLevelOptions& options) {
  if (levels.levels.empty()) return Status::ok();
  const std::vector<KeptSource> sources = kept_sources(scene, levels.material, options.ktx2);
  if (sources.empty()) return Status::ok();
  const double top = double(std::max(1, levels.levels.back().width));
  std::vector<double> scales;
  for (const TextureLevel& l : levels.levels) scales.push_back(double(l.width) / top);
  // An atlas of one level (smaller than the base size) gives the kept images no smaller scale:
  // levels below it are made for them, the atlas resent as it is (a few bytes at that size),
  // each a level's step smaller, until the largest kept image fits the base size.
  int largest = 0;
  for (const KeptSource& k : sources) largest = std::max({largest, k.width, k.height});
  size_t inserted = 0;
  if (levels.levels.size() == 1) {
    const double step = double(1 << std::clamp(options.level_halvings, 1, 4));
    for (double s = 1.0 / step; double(largest) * s * step > double(options.base_size);
         s /= step, ++inserted) {
      levels.levels.insert(levels.levels.begin(), levels.levels.front());
      scales.insert(scales.begin(), s);
    }
  }
  KeptMaps made;
  if (Status st = fill_kept(sources, scales, levels, options, made); !st) return st;
  // The byte bound counts the kept maps as make_texture_levels counts the atlas's: levels
  // between the smallest and the top go, most bytes first, while the pyramid is over it.
  while (const std::optional<size_t> at = drop_dearest_middle_level(
             levels, options.max_pyramid_ratio, "the levels and the kept images' maps")) {
    if (*at < inserted) --inserted;
    scales.erase(scales.begin() + std::ptrdiff_t(*at));
    if (Status st = fill_kept(sources, scales, levels, options, made); !st) return st;
  }
  // A level made for the kept images alone that costs more than the bound (the atlas resent is
  // dearer than the kept images save): the atlas's one level carries them as they came.
  if (inserted > 0 && pyramid_ratio(levels) > options.max_pyramid_ratio) {
    levels.levels.erase(levels.levels.begin(), levels.levels.end() - 1);
    return fill_kept(sources, {1.0}, levels, options, made);
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
