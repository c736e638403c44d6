// Materials the atlas cannot stand in for are kept as they came, beside it: their textures,
// samplers and the primitives' own uvs, one material each ("as few materials as appearance
// allows"). A material is kept when
// - a texture of it is tiled (atlas/tiled.h: repeated over many periods on a piece);
// - it has a reflection layer's texture (clearcoat, specular, iridescence, sheen roughness,
//   thickness: Material::layers), a transmission texture, or anisotropy: the atlas carries the
//   base colour and the physically based channels only, and anisotropy's direction lives in
//   the source uvs' tangent frame, which charts do not keep;
// - a texture of it is sampled without mipmaps or with NEAREST magnification (glTF sampler
//   filters NEAREST / LINEAR as minFilter, NEAREST as magFilter): what shows then is the
//   source's own texel grid, which a resampled chart of another density and alignment cannot
//   reproduce (a 2 × 1 texture stretched over a quad, a checker minified without mip levels).
// O(vertices + triangles + materials).
#pragma once

#include <cstdint>
#include <vector>

#include "core/encode_counts.h"
#include "scene/scene.h"

namespace meshmux {

enum class KeptReason : uint8_t {
  kNone,       // baked into the atlas
  kTiled,      // a tiled texture
  kLayers,     // layer, transmission textures or anisotropy
  kTexelGrid,  // a sampler without mipmaps or with NEAREST magnification
};

// Per material of `scene`: whether it is kept and why. `periods` as find_tiled_materials's
// (0: no texture counts as tiled).
std::vector<KeptReason> find_kept_materials(const Scene& scene, double periods);

// `scene` split in two: `rest` is the scene without the primitives of kept materials (their
// materials replaced by the default, so nothing counts their textures); `kept` holds those
// primitives, one mesh per primitive (one material each, as the stream needs), placed by the
// same instances, with only the materials and images they use.
struct KeptSplit {
  Scene rest;
  Scene kept;
  size_t kept_materials = 0;  // kept materials in use
};
KeptSplit split_kept(const Scene& scene, const std::vector<KeptReason>& kept);

// The kept materials' images as the texture levels code the atlas: each image the last
// `kept_materials` materials of `scene` sample (those append_scene put after the atlas's),
// decoded and opaque, is re-encoded as JPEG at `quality` where that is at most 90% of the
// bytes it came with (lossless PNG sources of photographs and data maps: the corpus's kept
// textures doubled model.glb's bytes when shipped as they came). Images with alpha, or whose
// JPEG would save little, keep their bytes. Returns the bytes saved.
// Each file encoded is counted in `counts` (when given).
size_t encode_kept_images(Scene& scene, size_t kept_materials, int quality,
                          EncodeCounts* counts = nullptr);

// Appends `extra`'s images, materials, meshes and instances to `out`, indices shifted (by value:
// a caller done with `extra` moves it in, and its images move across uncopied).
void append_scene(Scene& out, Scene extra);

}  // namespace meshmux
