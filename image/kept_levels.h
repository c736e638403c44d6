// The images of materials kept beside the atlas (tiled textures, layer textures, texel grids:
// atlas/kept.h) carried by the texture levels at each level's scale (TextureLevel::kept), so the
// base holds them small and the stream brings them up with the atlas. Without this a kept
// material's images went into the base at full size: a glass or iridescent model's base was
// nearly its whole model.glb (Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised
// conversion of 3D models for interactive metaverses" §4.4: the base shows a small texture and
// the levels refine it; this extends that to the images the atlas cannot stand in for).
//
// Which images: every image some material samples that the streamed material (material 0, the
// atlas's, whose base colour the levels are) does not. Scale of level j: its width over the
// finest level's (levels.back()); an image's side s becomes max(min(s, kKeptMinSide),
// round(s · scale)). The finest level carries the image's own bytes when they are JPEG or PNG; a
// level carries an image only where its size differs from the level below's (level 0, the
// base's, carries every one). Reduced by 2×2 box halvings (linear light for colour, renormalized
// for normal maps, as stored for data), then a Catmull-Rom resample to the exact size; encoded as
// the image came (JPEG at `preview_quality`, or PNG; with KTX2 levels, TextureLevelOptions::ktx2,
// every map is KTX2 in its texels' mode, a KTX2 upload's finest as it came, the sides rounded up
// to multiples of 4). An image whose pixels have no JPEG or PNG
// bytes (made in code, as the importer's anisotropy directions re-expressed for another tangent
// frame; WebP; a transcoded KTX2) has every level's map made as PNG, the finest included: such an
// image went into the base at full size, and was PNG-encoded again for every base the bytes
// bound tried. Images with neither pixels nor decodable bytes stay as they are (no kept maps).
// O(kept texels) filtering plus encoding.
#pragma once

#include "image/texture_levels.h"
#include "scene/scene.h"
#include "scene/texture_levels.h"

namespace meshmux {

constexpr int kKeptMinSide = 4;  // a kept image is never reduced below this side (or its own)

// The image indices of `scene` that a level carries as kept maps (see above), ascending: every
// image a material samples but `streamed_material` (the levels' own, TextureLevels::material;
// -1: none) does not.
std::vector<int32_t> kept_level_images(const Scene& scene, int32_t streamed_material);

// How image `image` of `scene` holds its texels, by the slots that sample it: colour (base colour,
// emissive, sheen or specular colour) wins; a normal map only as a normal map; else data.
TexelFilter kept_image_filter(const Scene& scene, int32_t image);

// Fills levels.levels[j].kept for every level. `levels` as make_texture_levels gave them (at
// least one level); a no-op without levels or kept images. Two more rules, from `options`:
// - an atlas of one level (smaller than base_size) gets levels below it for the kept images, the
//   atlas resent at its size in each, one level step (level_halvings) apart, until the largest
//   kept image fits base_size: without them the base held every kept image at full size;
// - max_pyramid_ratio counts the kept maps with the atlas's: levels between the smallest and the
//   top are dropped, most bytes first (recorded in levels.dropped), while all levels cost more
//   than that times the top level (levels made for the kept images go too, if they alone are
//   over it).
// Errors name the image that failed to encode.
Status add_kept_levels(const Scene& scene, TextureLevels& levels,
                       const TextureLevelOptions& options);

// `scene`'s images as texture level `level` shows them: each kept image replaced by the last
// kept map of it at levels 0..level (encoded bytes, mime type and size; pixels dropped).
void apply_kept_level(Scene& scene, const TextureLevels& levels, size_t level);

}  // namespace meshmux
