// Filling the empty texels of an image from the texels that hold something, by pull-push (Gortler,
// Grzeszczuk, Szeliski and Cohen, "The Lumigraph", SIGGRAPH 1996, the pull-push step of its
// rebinning): "pull" averages the filled texels into ever coarser levels (2 × 2 blocks, each level
// a texel's mean over its filled children), "push" gives every empty texel its parent's value at
// the next coarser level, from the coarsest level down. An empty texel next to filled ones takes
// their mean; one far from everything takes a coarse average of the region around it. Used for the
// atlas's empty space, so that no mip level averages a chart with transparent black and the space
// costs almost nothing encoded (flat blocks), in O(texels) (a ring-by-ring dilation of a 4096²
// atlas at 3% use visited 16 M texels once per ring).
#pragma once

#include <cstdint>
#include <vector>

namespace meshmux {

// One image of a set sharing one mask of filled texels.
struct FillLayer {
  std::vector<uint8_t>* rgba;  // w × h RGBA8, row-major
  bool srgb;                   // colour (averaged in linear light) or data (averaged as stored);
                               // alpha is always averaged as stored
};

// Every texel i with filled[i] == 0 gets its value in every layer; filled texels are left as they
// are. `filled` has w × h entries; w, h ≥ 1. Nothing changes when no texel is filled. The result
// is the same on any number of threads (each output texel is computed from fixed inputs).
// Memory: one float RGBA level at a quarter of the texels, and its coarser levels, per layer in
// turn.
void fill_empty_texels(int w, int h, const std::vector<uint8_t>& filled,
                       const std::vector<FillLayer>& layers);

}  // namespace meshmux
