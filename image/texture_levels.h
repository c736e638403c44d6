// The texture pyramid of the conditioned texture (paper 000 §4.4: the atlas is packed so that
// every power-of-two reduction stays clean; this makes the reductions). Levels go from
// `base_size` (or the texture's size, when smaller) up to the full size, each half the next in
// both dimensions, each downsampled from the level above with a 2x2 box filter in linear light
// (sRGB decoded, averaged, re-encoded; alpha averaged as is), then encoded independently:
// JPEG through libjpeg-turbo, or PNG when any texel is not opaque.
// Complexity: O(pixels) for the filtering (4/3 of the full size in all), plus encoding.
#pragma once

#include "scene/scene.h"
#include "scene/texture_levels.h"

namespace meshmux {

struct TextureLevelOptions {
  int base_size = 128;    // the smallest level's larger side, in pixels (a power of two)
  int jpeg_quality = 85;  // 1..100, for opaque textures
};

// Requires a decoded image whose width and height are powers of two. Errors name the image.
Result<TextureLevels> make_texture_levels(const Image& texture, const TextureLevelOptions& options);

// One 2x2 box-filter reduction in linear light (width and height halved, never below 1).
// Exposed for tests and for the renderer's mip chain.
Image downsample_half(const Image& image);

}  // namespace meshmux
