// Tiled textures stay tiled. A texture repeated many times over a surface (a town's grass, a café's
// floor tiles, brick walls: a REPEAT sampler and uvs spanning many periods) cannot be baked into an
// atlas at its native density: each period would be a copy, so the bake either grows without bound
// or, capped, blurs the tiles into blotches. Terrace, Cheslack-Postava, Levis and Freedman,
// "Unsupervised conversion of 3D models for interactive metaverses" §4.2 notes that wrapping would
// duplicate the texture many times. Such a material is kept as it came — its textures, samplers and
// the primitives' own uvs — beside the atlas, one material each (atlas/kept.h).
//
// A material is tiled when its base colour texture is decoded, its sampler repeats (REPEAT or
// MIRRORED_REPEAT) along an axis, and some connected piece of a primitive using it spans more
// than `periods` periods along that axis (KHR_texture_transform applied), a piece being the
// triangles joined through shared vertices (a uv seam splits pieces). O(vertices + triangles).
#pragma once

#include <cstdint>
#include <vector>

#include "scene/scene.h"

namespace meshmux {

// Per material of `scene`: whether it is tiled (see above).
std::vector<char> find_tiled_materials(const Scene& scene, double periods = 2.0);

}  // namespace meshmux
