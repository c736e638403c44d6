// The atlas within its bytes bound (see atlas_bytes.h).
#include "atlas/atlas_bytes.h"

#include <algorithm>

#include "image/encode.h"

namespace meshmux {

Result<Scene> build_atlas_within_bytes(const Scene& scene, const AtlasOptions& options,
                                       int jpeg_quality, AtlasReport* report, Warnings* warnings) {
  AtlasOptions o = options;
  AtlasReport rep;
  auto atlased = build_atlas(scene, o, &rep, warnings);
  std::vector<AtlasBytesRound> rounds;
  for (int round = 0; atlased.ok(); ++round) {
    rep.source_bytes = rep.atlas_bytes = 0;
    for (int32_t i : rep.baked_images)
      rep.source_bytes += double(scene.images[size_t(i)].encoded.size());
    for (size_t i = 0; i < rep.atlas_images && i < atlased->images.size(); ++i)
      rep.atlas_bytes += double(encoded_size(atlased->images[i], jpeg_quality,
                                             i % std::max<size_t>(rep.page_images, 1) == 0));
    const double bound =
        kAtlasBytesBound * rep.source_bytes + kAtlasImageAllowance * double(rep.atlas_images);
    if (!(rep.source_bytes > 0) || rep.atlas_bytes <= bound || round == kAtlasBytesRounds ||
        o.density <= kAtlasMinDensity)
      break;
    o.density = std::max(kAtlasMinDensity,
                         o.density * std::clamp(0.9 * bound / rep.atlas_bytes, 0.01, 0.9));
    rounds.push_back({rep.atlas_bytes, bound, rep.source_bytes, o.density});
    rep = AtlasReport{};
    atlased = build_atlas(scene, o, &rep, warnings);
  }
  rep.bytes_rounds = std::move(rounds);
  if (report) *report = std::move(rep);
  return atlased;
}

}  // namespace meshmux
