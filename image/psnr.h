// Peak signal-to-noise ratio of two RGBA8 images (the tests' and benchmarks' measure of a lossy
// encoder's round trip).
#pragma once

#include "scene/scene.h"

namespace meshmux {

// PSNR in dB over the R, G and B channels of the texels both images have (row by row as stored;
// alpha left out), peak 255; 99 when they are equal. O(pixels).
double psnr_rgb(const Image& a, const Image& b);

}  // namespace meshmux
