// Resampling an image to another size with the Catmull-Rom cubic (Keys, "Cubic convolution
// interpolation for digital image processing", IEEE TASSP 1981, a = −0.5), separable, texel
// centres aligned ((x + 0.5) · in / out − 0.5), edges clamped. Used to bring a source texture
// of other sides to the power-of-two sides texture levels need: upsampling keeps every source
// texel's detail (bilinear would blur it by half a texel), so the result never has less than
// the source's density. Colour is filtered in linear light (sRGB decoded, re-encoded); alpha
// and data channels as stored. O(out texels × 4) per pass.
#pragma once

#include "scene/scene.h"

namespace meshmux {

// `in` decoded; width and height ≥ 1. The result has the name and no encoded bytes.
Image resize_cubic(const Image& in, int width, int height, bool srgb);

// The least power of two ≥ v (v ≥ 1).
int next_power_of_two(int v);

}  // namespace meshmux
