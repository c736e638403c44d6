// The source's own texture as the atlas. Terrace, Cheslack-Postava, Levis and Freedman,
// "Unsupervised conversion of 3D models for interactive metaverses" §4.4 builds one atlas by
// resampling every source texture into new charts; when every textured face of a scene already
// samples ONE image through one uv set, face by face inside one unit cell of uv space (the common
// single-texture model: a scan, a game or Sketchfab asset, a COLLADA vehicle whose glass and trim
// are plain colours), that image already is an atlas. Resampling it through new charts only blurs
// it (bilinear resampling is a low-pass filter: −18 dB unlit PSNR on DamagedHelmet against the
// original in the fidelity harness) and inflates it (2048² became 4096²); it also changes what the
// original's own mip levels show at its chart borders. So the atlas stage keeps the image and the
// source uvs, with the base-colour factor folded into the pixels, and gives each plain colour a
// block of texels the source does not use.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "scene/scene.h"

namespace meshmux {

struct SourceAtlas {
  int32_t image = -1;         // index into Scene::images: the image every textured face samples
  uint32_t tex_coord = 0;     // the uv set it is sampled through (the same on every primitive)
  Vec4 factor{1, 1, 1, 1};    // the base-colour factor the textured materials share (linear)
  int width = 0, height = 0;  // the atlas: the image's part, or twice its height when the
                              // plain colours found no room in it
  int part_width = 0, part_height = 0;  // the image's part of the atlas: its sides rounded up to
                                        // powers of two (resampled when they differ)
  // The atlas's wrap per axis: kRepeat where every textured face's base-colour sampler repeats
  // on that axis (the atlas then shows past the image's edges what REPEAT shows there: the
  // image's opposite edge, glTF 2.0 §3.8.4.4), else kClampToEdge (a mirrored repeat shows the
  // edge texel past the edge too, as a clamp does, for the faces inside [0, 1]).
  Wrap wrap_s = Wrap::kClampToEdge, wrap_t = Wrap::kClampToEdge;
  // Plain colours: faces whose material has no base-colour texture (and no vertex colours)
  // show their factor; each distinct one gets an aligned square block of texels no textured
  // face comes near (`block` texels, clean down to mip level log2(block)).
  std::vector<Vec4> flat_colors;       // linear RGBA, in first-use order
  std::vector<Vec2> flat_uv;           // per flat colour: its block's centre, atlas uv
  std::vector<int> flat_x, flat_y;     // per flat colour: its block's top-left texel
  int block = 0;                       // block side, texels (0: no flat colours)
  int32_t material = -1;               // the first textured face's material (all textured faces'
                                       // materials agree on every channel, see below)
  std::vector<int32_t> flat_material;  // per flat colour: the first material showing it (-1:
                                       // the default material)
};

// The further material channels an atlas image may carry.
enum class AtlasChannel { kNormal, kOcclusionRoughnessMetallic, kEmissive, kSheen };

// The kept image, when:
// - every primitive with faces either samples, through its material's base-colour texture, the
//   same image through the same uv set with no KHR_texture_transform and the same factor, or
//   has no base-colour texture (a plain colour); none has vertex colours; at least one is
//   textured;
// - each textured face's uvs lie in one unit cell [kx, kx + 1] × [ky, ky + 1] (within 1e-3),
//   and a cell other than [0, 1]² only on axes whose sampler repeats; the face is then moved to
//   [0, 1]² (face_uv_cell), where a clamped sampler shows the same texels. On an axis every
//   textured face repeats, a face may reach past its cell's far edge by less than a period (the
//   atlas keeps REPEAT there; where a half is appended below the image, only as far as its copy
//   of the image's top rows reaches);
// - the image is decoded and its sides, rounded up to powers of two, are at most `max_size`
//   (texture levels halve: other sides are resampled up, image/resize.h, never losing density);
// - the plain colours find aligned free blocks (4 to 64 texels, 8 texels clear of every
//   textured face, and of its copies one period away on a repeating axis: the original samples
//   there across the edge) in the image or in a second image height appended below it
//   (≤ max_size): below its first `block` rows when wrap_t repeats (they continue the image
//   across its bottom edge) and above its last `block` rows (they continue it across its top).
// - the textured faces' materials agree on their normal, occlusion, metallic-roughness and
//   emissive textures (through the same uv set, no transform) and factors; plain-colour
//   materials sample no texture, and those sharing a colour share their factors.
// Otherwise nullopt (the atlas is built from charts). O(referenced uvs + texels of the
// textured faces' uv bounding boxes + image texels).
std::optional<SourceAtlas> find_source_atlas(const Scene& scene, int max_size);

// The unit cell of uv space a face lies in: the floor of its smallest coordinates (+ 1e-3, so a
// face touching 1.0 from [0, 1] stays there). Subtract it from the face's uvs.
Vec2 face_uv_cell(Vec2 a, Vec2 b, Vec2 c);

// The plain colour of a primitive's material (its factor; white for the default material), or
// -1 when the material samples a base-colour texture. Index into SourceAtlas::flat_colors.
int flat_color_index(const Scene& scene, const SourceAtlas& source, int32_t material);

// The atlas image: the source pixels × the factor (sRGB-decoded, multiplied in linear light,
// re-encoded; alpha × factor.w; unchanged when the factor is 1), resampled to the part's sides;
// the appended half (if any) repeats the part's last row (as a clamped edge shows, so nothing
// bleeds across the boundary) or, when wrap_t repeats, starts with the part's first `block`
// rows and ends with its last `block` rows (so bilinear filtering and the box-filtered mip
// levels down to log2(block) read across either edge of the part what REPEAT reads there: the
// opposite edge's rows); then each plain colour's block, between them. Named "atlas".
Image source_atlas_image(const Scene& scene, const SourceAtlas& source);

// A further channel as an image of the atlas's size: each texel of the source's part takes the
// textured material's value at its centre (atlas/material_sample.h: factors folded in), the
// appended half is made as source_atlas_image's, each plain colour's block takes its material's
// factors. Normal: the
// source's map (normalized, scale folded; the uvs and so the tangent frame are the source's),
// flat (0, 0, 1) in the blocks. Occlusion-roughness-metallic: linear bytes. Emissive: sRGB
// bytes of the radiance / emissive_scale. Alpha 255.
Image source_atlas_channel(const Scene& scene, const SourceAtlas& source, AtlasChannel channel,
                           float emissive_scale);

}  // namespace meshmux
