// Texture levels (docs/ARCHITECTURE.md "Texture levels"; Terrace, Cheslack-Postava, Levis and
// Freedman, "Unsupervised conversion of 3D models for interactive metaverses" §4.4 for why
// power-of-two levels stay clean when no chart crosses a power-of-two boundary).
#include "image/texture_levels.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <deque>

#include "core/parallel.h"
#include "image/color.h"
#include "image/encode.h"

namespace meshmux {

namespace {
constexpr int kMinPreviewSide = 8;  // a preview level is never halved below this
}  // namespace

namespace {

bool power_of_two(int v) { return v > 0 && (v & (v - 1)) == 0; }

}  // namespace

uint64_t level_bytes(const TextureLevel& l) {
  uint64_t n = l.encoded.size();
  for (const TextureMap& m : l.other_maps) n += m.encoded.size();
  for (const KeptMap& k : l.kept) n += k.encoded.size();
  return n;
}

double pyramid_ratio(const TextureLevels& levels) {
  uint64_t total = 0;
  for (const TextureLevel& l : levels.levels) total += level_bytes(l);
  return double(total) / double(std::max<uint64_t>(1, level_bytes(levels.levels.back())));
}

std::optional<size_t> drop_dearest_middle_level(TextureLevels& levels, double max_ratio,
                                                const std::string& what) {
  if (levels.levels.size() <= 2 || pyramid_ratio(levels) <= max_ratio) return std::nullopt;
  auto dearest = std::max_element(
      levels.levels.begin() + 1, levels.levels.end() - 1,
      [](const TextureLevel& a, const TextureLevel& b) { return level_bytes(a) < level_bytes(b); });
  char why[240];
  std::snprintf(why, sizeof why,
                "with it %s cost %.3f× the top level (limit %.2f); the largest level between the "
                "smallest and the top goes first",
                what.c_str(), pyramid_ratio(levels), max_ratio);
  levels.dropped.push_back({dearest->width, dearest->height, level_bytes(*dearest), why});
  const size_t at = size_t(dearest - levels.levels.begin());
  levels.levels.erase(dearest);
  return at;
}

Image downsample_half(const Image& in) { return downsample_half(in, TexelFilter::kSrgb); }

namespace {

// Row y of `out`, the 2×2 box reduction of `in` (see downsample_half).
void half_row(const Image& in, TexelFilter filter, Image& out, int y) {
  for (int x = 0; x < out.width; ++x) {
    float acc[3] = {0, 0, 0};
    int alpha = 0, n = 0;
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx) {
        int sx = std::min(in.width - 1, 2 * x + dx), sy = std::min(in.height - 1, 2 * y + dy);
        const uint8_t* p = &in.rgba[(size_t(sy) * size_t(in.width) + size_t(sx)) * 4];
        for (int c = 0; c < 3; ++c)
          acc[c] += filter == TexelFilter::kSrgb     ? srgb_to_linear(p[c])
                    : filter == TexelFilter::kNormal ? p[c] / 127.5f - 1.0f
                                                     : p[c] / 255.0f;
        alpha += p[3];
        ++n;
      }
    uint8_t* q = &out.rgba[(size_t(y) * size_t(out.width) + size_t(x)) * 4];
    if (filter == TexelFilter::kSrgb) {
      for (int c = 0; c < 3; ++c) q[c] = linear_to_srgb(acc[c] / float(n));
    } else if (filter == TexelFilter::kNormal) {
      float l = std::sqrt(acc[0] * acc[0] + acc[1] * acc[1] + acc[2] * acc[2]);
      if (!(l > 1e-6f)) acc[0] = acc[1] = 0, acc[2] = l = 1;
      for (int c = 0; c < 3; ++c)
        q[c] = uint8_t(std::lround(std::clamp((acc[c] / l + 1.0f) * 127.5f, 0.0f, 255.0f)));
    } else {
      for (int c = 0; c < 3; ++c)
        q[c] = uint8_t(std::lround(std::clamp(acc[c] / float(n) * 255.0f, 0.0f, 255.0f)));
    }
    q[3] = uint8_t((alpha + n / 2) / n);
  }
}

}  // namespace

Image downsample_half(const Image& in, TexelFilter filter) {
  Image out;
  out.name = in.name;
  out.width = std::max(1, in.width / 2);
  out.height = std::max(1, in.height / 2);
  out.rgba.resize(size_t(out.width) * size_t(out.height) * 4);
  // Rows are independent: split over the threads (each writes its own rows).
  const size_t rows_per_chunk = std::max<size_t>(1, size_t(65536) / size_t(out.width));
  parallel_chunks(size_t(out.height), rows_per_chunk, [&](size_t row_begin, size_t row_end) {
    for (int y = int(row_begin); y < int(row_end); ++y) half_row(in, filter, out, y);
  });
  return out;
}

Result<Ktx2Encoded> encode_level_ktx2(const Image& map, TexelFilter filter,
                                      const Ktx2EncodeOptions& base) {
  Ktx2EncodeOptions k = base;
  k.mode = filter == TexelFilter::kSrgb && !base.colour_uastc ? Ktx2Mode::kEtc1s : Ktx2Mode::kUastc;
  k.srgb = filter == TexelFilter::kSrgb;
  k.normal_map = filter == TexelFilter::kNormal;
  return encode_ktx2(map, k);
}

Result<TextureLevels> make_texture_levels(const Image& texture, const TextureLevelOptions& o,
                                          const std::vector<ChannelTexture>& channels) {
  std::string who =
      "texture levels: " + (texture.name.empty() ? std::string("texture") : texture.name);
  if (!texture.decoded())
    return Status::error(who + ": image is not decoded", ErrorKind::kInternal);
  if (!power_of_two(texture.width) || !power_of_two(texture.height))
    return Status::error(who + ": " + std::to_string(texture.width) + "x" +
                             std::to_string(texture.height) +
                             " is not a power of two in both dimensions",
                         ErrorKind::kInternal);
  for (const ChannelTexture& c : channels)
    if (!c.image || !c.image->decoded() || c.image->width != texture.width ||
        c.image->height != texture.height)
      return Status::error(who + ": channel " + c.channel + " is not decoded at " +
                               std::to_string(texture.width) + "x" + std::to_string(texture.height),
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
  // level_halvings-th is a level. Each chain entry holds the base colour and every channel.
  const size_t step = size_t(o.level_halvings);
  // A level's images (base colour, then the channels); the top level's are the caller's, not
  // copied (a 4096² atlas's four channels are 256 MB), the others owned by `owned`.
  using Maps = std::vector<const Image*>;
  std::deque<std::vector<Image>> owned;
  auto halve = [&](const Maps& m) {
    std::vector<Image>& out = owned.emplace_back();
    out.push_back(downsample_half(*m[0]));
    for (size_t c = 0; c < channels.size(); ++c)
      out.push_back(downsample_half(*m[c + 1], channels[c].filter));
    Maps refs;
    for (const Image& i : out) refs.push_back(&i);
    return refs;
  };
  std::vector<Maps> chain(1, Maps{&texture});
  for (const ChannelTexture& c : channels) chain[0].push_back(c.image);
  while (std::max(chain.back()[0]->width, chain.back()[0]->height) > 1 &&
         (std::max(chain.back()[0]->width, chain.back()[0]->height) > o.base_size ||
          (chain.size() - 1) % step != 0))
    chain.push_back(halve(chain.back()));
  // One level's files: the base colour (PNG with alpha), the channels (JPEG).
  // The top level's maps as the caller encoded them (TextureLevelOptions::top_from_encoded).
  auto given = [&](const Image& map, const char* mime, bool top) -> const std::vector<uint8_t>* {
    return top && o.top_from_encoded && !map.encoded.empty() && map.mime_type == mime ? &map.encoded
                                                                                      : nullptr;
  };
  // A level's map `map` (0: the base colour, c + 1: channel c) as KTX2, one encoder thread
  // each when several run side by side. The level's sides become the file's (multiples of 4).
  auto encode_job_ktx2 = [&](TexelFilter filter, const Image& image, size_t map, size_t jobs,
                             TextureLevel& level) -> Status {
    Ktx2EncodeOptions k = o.ktx2_options;
    if (jobs > 1) k.threads = 1;
    auto r = encode_level_ktx2(image, filter, k);
    if (!r.ok()) return r.status();
    if (map == 0) {
      level.encoded = std::move(r->bytes);
      level.width = r->width, level.height = r->height;
    } else {
      level.other_maps[map - 1] = {channels[map - 1].channel, "image/ktx2", std::move(r->bytes)};
    }
    return Status::ok();
  };
  // Levels' maps encoded as independent jobs on every core (each writes its own file; the
  // first error in level and map order is the one returned).
  struct Job {
    const Maps* maps;
    int quality;
    TextureLevel* level;
    size_t map;  // 0: the base colour, c + 1: channel c
  };
  auto encode_levels = [&](const std::vector<std::pair<const Maps*, int>>& which,
                           const std::vector<TextureLevel*>& out) -> Status {
    std::vector<Job> jobs;
    for (size_t l = 0; l < which.size(); ++l) {
      TextureLevel* level = out[l];
      const Maps& m = *which[l].first;
      level->width = m[0]->width;
      level->height = m[0]->height;
      level->mime_type = o.ktx2 ? "image/ktx2" : alpha ? "image/png" : "image/jpeg";
      level->other_maps.assign(channels.size(), {});
      for (size_t k = 0; k <= channels.size(); ++k) jobs.push_back({&m, which[l].second, level, k});
    }
    std::vector<Status> status(jobs.size());
    parallel_chunks(jobs.size(), 1, [&](size_t begin, size_t end) {
      for (size_t j = begin; j < end; ++j) {
        const Job& job = jobs[j];
        const Maps& m = *job.maps;
        const bool top = m[0] == &texture;
        const Image& map = *m[job.map];
        if (o.ktx2) {
          status[j] =
              encode_job_ktx2(job.map == 0 ? TexelFilter::kSrgb : channels[job.map - 1].filter, map,
                              job.map, jobs.size(), *job.level);
          if (!status[j]) status[j] = status[j].with_prefix(who);
          continue;
        }
        if (job.map == 0) {
          const std::vector<uint8_t>* own = given(map, job.level->mime_type.c_str(), top);
          auto bytes = own     ? Result<std::vector<uint8_t>>(*own)
                       : alpha ? encode_png(map, o.counts)
                               : encode_jpeg(map, job.quality, o.counts);
          if (!bytes.ok())
            status[j] = bytes.status().with_prefix(who);
          else
            job.level->encoded = bytes.take();
          continue;
        }
        const size_t c = job.map - 1;
        const std::vector<uint8_t>* own_map = given(map, "image/jpeg", top);
        auto more = own_map ? Result<std::vector<uint8_t>>(*own_map)
                            : encode_jpeg(map, job.quality, o.counts);
        if (!more.ok())
          status[j] = more.status().with_prefix(who + ": " + channels[c].channel);
        else
          job.level->other_maps[c] = {channels[c].channel, "image/jpeg", more.take()};
      }
    });
    for (const Status& st : status)
      if (!st) return st;
    return Status::ok();
  };
  TextureLevels levels;
  {
    std::vector<std::pair<const Maps*, int>> which;
    for (size_t i = chain.size(); i-- > 0;) {
      if (i % step != 0 && i + 1 != chain.size()) continue;
      which.push_back({&chain[i], i == 0 ? o.jpeg_quality : o.preview_quality});
    }
    levels.levels.resize(which.size());
    std::vector<TextureLevel*> out;
    for (TextureLevel& l : levels.levels) out.push_back(&l);
    if (Status s = encode_levels(which, out); !s.is_ok()) return s;
  }
  while (drop_dearest_middle_level(levels, o.max_pyramid_ratio, "the levels")) {
  }
  // Still too dear with only the smallest level below the top: that level halves again (a
  // smaller first picture) until the pyramid fits or it is a single texel.
  Maps smallest = chain.back();
  while (levels.levels.size() == 2 && pyramid_ratio(levels) > o.max_pyramid_ratio &&
         std::max(smallest[0]->width, smallest[0]->height) > kMinPreviewSide) {
    TextureLevel& first = levels.levels.front();
    char why[160];
    std::snprintf(why, sizeof why,
                  "with it the levels cost %.3f× the top level (limit %.2f); the smallest level "
                  "halves instead",
                  pyramid_ratio(levels), o.max_pyramid_ratio);
    levels.dropped.push_back({first.width, first.height, level_bytes(first), why});
    smallest = halve(smallest);
    if (Status s = encode_levels({{&smallest, o.preview_quality}}, {&first}); !s.is_ok()) return s;
  }
  // A preview that small still too dear (a tiny texture: the file's headers dominate): the top
  // level is the only one.
  if (levels.levels.size() == 2 && pyramid_ratio(levels) > o.max_pyramid_ratio) {
    const TextureLevel& first = levels.levels.front();
    char why[160];
    std::snprintf(why, sizeof why,
                  "with it the levels cost %.3f× the top level (limit %.2f) even at %dx%d: the "
                  "top level is the only one",
                  pyramid_ratio(levels), o.max_pyramid_ratio, first.width, first.height);
    levels.dropped.push_back({first.width, first.height, level_bytes(first), why});
    levels.levels.erase(levels.levels.begin());
  }
  return levels;
}

}  // namespace meshmux
