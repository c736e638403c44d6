// The atlas within its bytes bound (see atlas_bytes.h).
#include "atlas/atlas_bytes.h"

#include <algorithm>

#include "core/parallel.h"
#include "image/encode.h"

namespace meshmux {

Result<Scene> build_atlas_within_bytes(const Scene& scene, const AtlasOptions& options,
                                       int jpeg_quality, AtlasReport* report, Warnings* warnings,
                                       EncodeCounts* counts) {
  AtlasOptions o = options;
  AtlasReport rep;
  AtlasMemo memo;  // the charts, segmented and flattened once for every round
  auto atlased = build_atlas(scene, o, &rep, warnings, &memo);
  std::vector<AtlasBytesRound> rounds;
  struct Encoded {
    std::vector<uint8_t> bytes;
    std::string mime_type;
  };
  std::vector<Encoded> encoded;  // the last build's atlas images, as the top level encodes them
  for (int round = 0; atlased.ok(); ++round) {
    rep.source_bytes = rep.atlas_bytes = 0;
    for (int32_t i : rep.baked_images)
      rep.source_bytes += double(scene.images[size_t(i)].encoded.size());
    encoded.assign(std::min(rep.atlas_images, atlased->images.size()), {});
    // The images on every core (a 4096×2048 base colour with alpha: 0.6 s of PNG alone).
    parallel_chunks(encoded.size(), 1, [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        // Each page's first image is its base colour (PNG where it has alpha).
        const bool base_colour = i % std::max<size_t>(rep.page_images, 1) == 0;
        encoded[i].bytes = encode_as_top_level(atlased->images[i], jpeg_quality, base_colour,
                                               &encoded[i].mime_type);
      }
    });
    for (const Encoded& e : encoded) rep.atlas_bytes += double(e.bytes.size());
    const double bound =
        kAtlasBytesBound * rep.source_bytes + kAtlasImageAllowance * double(rep.atlas_images);
    if (!(rep.source_bytes > 0) || rep.atlas_bytes <= bound || round == kAtlasBytesRounds ||
        o.density <= kAtlasMinDensity)
      break;
    o.density = std::max(kAtlasMinDensity,
                         o.density * std::clamp(0.9 * bound / rep.atlas_bytes, 0.01, 0.9));
    rounds.push_back({rep.atlas_bytes, bound, rep.source_bytes, o.density});
    rep = AtlasReport{};
    atlased = build_atlas(scene, o, &rep, warnings, &memo);
  }
  rep.bytes_rounds = std::move(rounds);
  // The bytes measured are the top level's: handed on (TextureLevelOptions::top_from_encoded).
  if (atlased.ok())
    for (size_t i = 0; i < encoded.size(); ++i)
      if (!encoded[i].bytes.empty()) {
        atlased->images[i].encoded = std::move(encoded[i].bytes);
        atlased->images[i].mime_type = encoded[i].mime_type;
        count(counts, &EncodeCounts::images);
      }
  if (report) *report = std::move(rep);
  return atlased;
}

}  // namespace meshmux
