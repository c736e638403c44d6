// The texture pyramid of the conditioned texture (Terrace, Cheslack-Postava, Levis and Freedman,
// "Unsupervised conversion of 3D models for interactive metaverses" §4.4: the atlas is packed so
// that every power-of-two reduction stays clean; this makes the reductions). Levels go from
// `base_size` (or the texture's size, when smaller) up to the full size, each half the next in both
// dimensions, each downsampled from the level above with a 2x2 box filter in linear light (sRGB
// decoded, averaged, re-encoded; alpha averaged as is), then encoded independently: JPEG through
// libjpeg-turbo, or PNG when any texel is not opaque.
// Complexity: O(pixels) for the filtering (4/3 of the full size in all), plus encoding.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/encode_counts.h"
#include "image/ktx2_encode.h"
#include "scene/scene.h"
#include "scene/texture_levels.h"

namespace meshmux {

struct TextureLevelOptions {
  int base_size = 128;       // the smallest level's larger side is at most this (a power of two)
  int jpeg_quality = 85;     // 1..100, for opaque textures: the top level (model.glb's)
  int preview_quality = 75;  // 1..100, the levels below the top (shown while it is on its way)
  // Halvings of each side between consecutive levels (1..4): 1 ships every mip level (the
  // pyramid's pixels 4/3 of the top's), 2 every other one (each level 1/16 of the pixels of the
  // next: 1.07× the top's pixels), so the stream's textures cost little more than the top
  // level alone (≤ 1.15×). The smallest level lands on a multiple of this below the
  // top, at or under base_size.
  int level_halvings = 2;
  // Levels between the smallest and the top are dropped, most bytes first, while all levels
  // together cost more than this times the top level (pay only for levels that pay);
  // with only the smallest left below the top, it halves until the pyramid fits.
  double max_pyramid_ratio = 1.15;
  EncodeCounts* counts = nullptr;  // observer: every file encoded is counted here (when given)
  // The top level takes each map's own encoded bytes where it has them in the format the level
  // writes (an atlas's images, encoded so by its bytes bound: image/encode.h
  // encode_as_top_level at jpeg_quality) instead of encoding it again. Only for images whose
  // bytes are that encoding (never a source's own file).
  bool top_from_encoded = false;
  // Every map of every level (and the kept maps: image/kept_levels.h) as KTX2 (Basis Universal,
  // glTF's KHR_texture_basisu; mime "image/ktx2") instead of JPEG/PNG: ETC1S in sRGB for colour,
  // UASTC with Zstandard for normal and data maps (encode_level_ktx2). The byte bounds above
  // then count KTX2 bytes.
  bool ktx2 = false;
  Ktx2EncodeOptions ktx2_options;  // the encoder's quality settings when `ktx2`
};

// How a channel's texels average when a level halves.
enum class TexelFilter {
  kSrgb,    // colour: averaged in linear light, alpha as is
  kData,    // data (occlusion, roughness, metallic): averaged as stored
  kNormal,  // tangent-space normals (2 · texel − 1): averaged, then renormalized
};

// A further material channel carried at every level beside the base colour: the
// same size as the base colour texture, opaque, JPEG-coded like it.
struct ChannelTexture {
  std::string channel;  // "normal", "occlusion_roughness_metallic" or "emissive"
  const Image* image = nullptr;
  TexelFilter filter = TexelFilter::kData;
};

// One map encoded as KTX2 in the mode its texels ask: kSrgb → ETC1S in sRGB (UASTC in sRGB with
// base.colour_uastc), kNormal → UASTC
// tuned for normals, kData → UASTC linear (mode, colour space and normal tuning of `base` are
// replaced; its qualities, threads and limits kept). Errors: encode_ktx2's.
Result<Ktx2Encoded> encode_level_ktx2(const Image& map, TexelFilter filter,
                                      const Ktx2EncodeOptions& base);

// Requires a decoded image whose width and height are powers of two (and channels of its size).
// Errors name the image. The channels move with the base colour: each level carries every
// channel at its size (TextureLevel::other_maps, in `channels` order), and the byte bounds above
// count them all.
Result<TextureLevels> make_texture_levels(const Image& texture, const TextureLevelOptions& options,
                                          const std::vector<ChannelTexture>& channels = {});

// The bytes of one level: every map it carries (base colour, further channels, kept images).
uint64_t level_bytes(const TextureLevel& level);

// All levels' bytes over the top level's (levels.back()); requires at least one level.
double pyramid_ratio(const TextureLevels& levels);

// With more than two levels and the pyramid over `max_ratio` (pyramid_ratio), drops the level
// between the smallest and the top that costs most bytes, records it in levels.dropped (its why
// names `what`, e.g. "the levels") and returns its index; otherwise changes nothing and returns
// nullopt. Both byte bounds (make_texture_levels, add_kept_levels) drop through this.
std::optional<size_t> drop_dearest_middle_level(TextureLevels& levels, double max_ratio,
                                                const std::string& what);

// One 2x2 box-filter reduction in linear light (width and height halved, never below 1).
// Exposed for tests and for the renderer's mip chain.
Image downsample_half(const Image& image);

// The same reduction for other texel kinds.
Image downsample_half(const Image& image, TexelFilter filter);

}  // namespace meshmux
