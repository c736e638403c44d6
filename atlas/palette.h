// Palette textures as plain colours. Low-poly and game assets often colour faces by placing
// their uvs inside one swatch of a small palette image (BoomBoxWithAxes' axes: a 32 × 32 image,
// every face inside one of its colours). Such a face shows one colour whatever the
// parameterization, but as a textured face it keeps the scene from reusing its main texture
// as the atlas (atlas/source_atlas.h: one image) and sends every face through charts and
// resampling, which blurs the main texture (bilinear resampling is a low-pass filter:
// BoomBoxWithAxes lost 1 dB unlit and spent 11 s baking a 4096² atlas for a 2048² source).
// Here each such face becomes a plain colour: its material's base colour texture is replaced
// by its factor × the swatch's colour, one material per colour, the primitive split by colour.
// The atlas applies it only where the scene then has one texture it keeps as it is (elsewhere
// the charts bake palettes as before). The result is what the faces showed at the texture's
// full resolution (a far view's mip levels of the palette, which blend swatches, are not kept:
// neither does a resampled chart).
#pragma once

#include <optional>

#include "scene/scene.h"

namespace meshmux {

// The scene with the faces of palette materials as plain colours, and how many materials
// were so replaced (nullopt and 0: none; `scene` stands). A material qualifies when it samples a
// decoded base colour texture with no KHR_texture_transform and no other texture, and every face of
// every primitive using it has no vertex colours and reads one RGBA value over all the texels
// its bilinear footprint touches (within one uv cell where the sampler repeats, clamped where
// it clamps; at most 64 × 64 texels per face). O(faces × footprint texels).
std::optional<Scene> palette_as_plain_colors(const Scene& scene, size_t* replaced);

}  // namespace meshmux
