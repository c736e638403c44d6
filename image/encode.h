// Encodes decoded RGBA8 pixels: PNG (lossless, alpha kept) through libpng, JPEG through
// libjpeg-turbo.
#pragma once

#include <cstdint>
#include <vector>

#include "scene/scene.h"

namespace meshmux {

// PNG bytes of image.rgba (width x height). Drops the alpha channel when every pixel is
// opaque. Errors when the image is not decoded.
Result<std::vector<uint8_t>> encode_png(const Image& image);

}  // namespace meshmux

namespace meshmux {

// Baseline JPEG bytes of image.rgba (alpha ignored) through libjpeg-turbo, 4:2:0 chroma,
// accurate DCT. `quality` 1..100. Errors when the image is not decoded or the quality is out
// of range. Deterministic.
Result<std::vector<uint8_t>> encode_jpeg(const Image& image, int quality);

}  // namespace meshmux

namespace meshmux {

// The bytes an image takes as the texture levels' top level encodes it (texture_levels.h): PNG
// when `alpha` is true and any texel is not opaque, else JPEG at `quality`. A measure for
// budgets (the atlas's bytes bound): not counted by images_encoded. 0 when not decoded.
size_t encoded_size(const Image& image, int quality, bool alpha);

// Images encoded (PNG or JPEG) by this process so far: a counter for tests that check each
// texture level is encoded once per conversion. Thread-safe.
uint64_t images_encoded();

}  // namespace meshmux
