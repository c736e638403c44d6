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
  int base_size = 128;       // the smallest level's larger side is at most this (a power of two)
  int jpeg_quality = 85;     // 1..100, for opaque textures: the top level (model.glb's)
  int preview_quality = 75;  // 1..100, the levels below the top (shown while it is on its way)
  // Halvings of each side between consecutive levels (1..4): 1 ships every mip level (the
  // pyramid's pixels 4/3 of the top's), 2 every other one (each level 1/16 of the pixels of the
  // next: 1.07× the top's pixels), so the stream's textures cost little more than the top
  // level alone (issue 4/8: ≤ 1.15×). The smallest level lands on a multiple of this below the
  // top, at or under base_size.
  int level_halvings = 2;
  // Levels between the smallest and the top are dropped, most bytes first, while all levels
  // together cost more than this times the top level (issue 4/8: pay only for levels that pay);
  // with only the smallest left below the top, it halves until the pyramid fits.
  double max_pyramid_ratio = 1.15;
};

// Requires a decoded image whose width and height are powers of two. Errors name the image.
Result<TextureLevels> make_texture_levels(const Image& texture, const TextureLevelOptions& options);

// One 2x2 box-filter reduction in linear light (width and height halved, never below 1).
// Exposed for tests and for the renderer's mip chain.
Image downsample_half(const Image& image);

}  // namespace meshmux
