// Encodes decoded RGBA8 pixels to PNG (lossless, alpha kept) through OpenImageIO.
#pragma once

#include <cstdint>
#include <vector>

#include "scene/scene.h"

namespace meshmux {

// PNG bytes of image.rgba (width x height). Drops the alpha channel when every pixel is
// opaque. Errors when the image is not decoded.
Result<std::vector<uint8_t>> encode_png(const Image& image);

}  // namespace meshmux
