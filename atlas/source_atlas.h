// The source's own texture as the atlas. Paper 000 §4.4 builds one atlas by resampling every
// source texture into new charts; when every face of a scene already samples ONE image through
// one uv set that stays inside [0, 1] (the common single-texture-set model: a scan, a game or
// Sketchfab asset), that image already is an atlas. Resampling it through new charts only blurs
// it (bilinear resampling is a low-pass filter: −18 dB unlit PSNR on DamagedHelmet against the
// original, fidelity harness) and inflates it (a 2048² texture became 4096²). So the atlas stage
// keeps the image and the source uvs, with the base-colour factor folded into the pixels.
#pragma once

#include <cstdint>
#include <optional>

#include "scene/scene.h"

namespace meshmux {

struct SourceAtlas {
  int32_t image = -1;       // index into Scene::images: the image every face samples
  uint32_t tex_coord = 0;   // the uv set it is sampled through (the same on every primitive)
  Vec4 factor{1, 1, 1, 1};  // the base-colour factor all those materials share (linear RGBA)
};

// The image to keep, when:
// - every primitive with faces has a material whose base colour texture is that one image,
//   through the same uv set, with no KHR_texture_transform and the same base-colour factor;
// - no such primitive has vertex colours;
// - each face's uvs lie in one unit cell [kx, kx + 1] × [ky, ky + 1] (within 1e-3), and a
//   cell other than [0, 1]² only on axes whose sampler repeats; the face is then moved to
//   [0, 1]² (face_uv_cell), where a clamped sampler shows the same texels;
// - the image is decoded, both sides are powers of two and at most `max_size`.
// Otherwise nullopt (the atlas is built from charts). O(referenced uvs).
std::optional<SourceAtlas> find_source_atlas(const Scene& scene, int max_size);

// The unit cell of uv space a face lies in: the floor of its smallest coordinates (+ 1e-3, so a
// face touching 1.0 from [0, 1] stays there). Subtract it from the face's uvs.
Vec2 face_uv_cell(Vec2 a, Vec2 b, Vec2 c);

// The image as the atlas: the source pixels × the factor (sRGB-decoded, multiplied in linear
// light, re-encoded; alpha × factor.w), named "atlas". Unchanged pixels when the factor is 1.
Image source_atlas_image(const Scene& scene, const SourceAtlas& source);

}  // namespace meshmux
