// Encodes decoded RGBA8 pixels: PNG (lossless, alpha kept) through libpng, JPEG through
// libjpeg-turbo.
#pragma once

#include <cstdint>
#include <vector>

#include "core/encode_counts.h"
#include "scene/scene.h"

namespace meshmux {

// PNG bytes of image.rgba (width x height). Drops the alpha channel when every pixel is
// opaque. Errors when the image is not decoded. Counted in `counts` (when given).
Result<std::vector<uint8_t>> encode_png(const Image& image, EncodeCounts* counts = nullptr);

}  // namespace meshmux

namespace meshmux {

// Baseline JPEG bytes of image.rgba (alpha ignored) through libjpeg-turbo, 4:2:0 chroma,
// accurate DCT. `quality` 1..100. Errors when the image is not decoded or the quality is out
// of range. Deterministic. Counted in `counts` (when given).
Result<std::vector<uint8_t>> encode_jpeg(const Image& image, int quality,
                                         EncodeCounts* counts = nullptr);

}  // namespace meshmux

namespace meshmux {

// The image encoded as the texture levels' top level encodes it (texture_levels.h): PNG when
// `alpha` is true and any texel is not opaque, else JPEG at `quality`; `mime_type` (when given)
// receives which. Never counted (the atlas's bytes bound measures with it and hands the bytes on
// to the levels: TextureLevelOptions::top_from_encoded). Empty when not decoded.
std::vector<uint8_t> encode_as_top_level(const Image& image, int quality, bool alpha,
                                         std::string* mime_type);

// encode_as_top_level's size: a measure for budgets. 0 when not decoded.
size_t encoded_size(const Image& image, int quality, bool alpha);

}  // namespace meshmux
