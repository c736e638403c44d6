// Distortion of a render against the full-quality render (Yang, Shen and Kuo, "Progressive
// coding of 3D textured graphic model via joint mesh-texture optimization" §3): measured over the
// union of both coverage masks, so background is excluded but silhouette changes count (a pixel
// covered in one image and not the other compares the covered colour with black background).
#pragma once

#include "multiplex/render.h"

namespace meshmux {

struct Distortion {
  double mse = 0;        // mean squared error over RGB (0..255 scale), union of masks
  double psnr = 0;       // 10 log10(255² / mse); +inf when identical
  double ciede2000 = 0;  // mean CIEDE2000 over the union of masks
  size_t pixels = 0;     // pixels in the union
};

Distortion measure_distortion(const RenderImage& reference, const RenderImage& image);

}  // namespace meshmux
