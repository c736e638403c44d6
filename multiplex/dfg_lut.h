// The split-sum environment BRDF table (Karis 2013, "Real Shading in Unreal Engine 4", §Image
// based lighting: the specular integral's F0 scale and bias) that three.js's
// MeshStandardMaterial reads (r187: a 16×16 RG table indexed by (roughness, N·V), texel centres
// at (i + ½) / 16, bilinear). Ours is integrated here rather than copied: GGX importance sampling
// with the height-correlated Smith visibility three.js uses for punctual lights, Schlick's
// Fresnel. Used by the offscreen renderer's physically based shading (multiplex/render.h).
#pragma once

#include <vector>

namespace meshmux {

constexpr int kDfgLutSize = 16;

// kDfgLutSize² texels, row-major with N·V along rows (y) and roughness along columns (x): per
// texel (scale, bias), so the specular albedo for F0 is F0 · scale + F90 · bias.
// `samples`: importance samples per texel. Deterministic (Hammersley points).
std::vector<float> dfg_lut(int samples = 4096);

}  // namespace meshmux
