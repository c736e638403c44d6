// The base colour a surface point shows under its original material: base-colour factor ×
// vertex colour × texture (bilinear, honouring the sampler's wrap/mirror/clamp and the
// KHR_texture_transform of the texture reference). Used by the atlas baker and by the colour
// fidelity test, so both read the source the same way. Colours are linear RGBA in [0, 1]
// (texture texels are sRGB-decoded).
#pragma once

#include "image/color.h"  // srgb_to_linear, linear_to_srgb
#include "scene/scene.h"

namespace meshmux {

// Bilinear texel fetch at uv (glTF convention: (0,0) top-left of the image, texel centres at
// (i + 0.5) / width), with the sampler's wrap modes. Linear RGBA (sRGB decoded; alpha as is).
Vec4 sample_image(const Image& image, const Sampler& sampler, Vec2 uv);

// The same fetch for data textures (normal, occlusion, metallic-roughness): the bytes / 255,
// no sRGB decoding.
Vec4 sample_image_data(const Image& image, const Sampler& sampler, Vec2 uv);

// uv after KHR_texture_transform.
Vec2 apply_transform(const TextureTransform& t, Vec2 uv);

// The base colour of `material` at a point with texture coordinates `uvs` (all of the
// primitive's sets, interpolated) and vertex colour `vertex_color` (interpolated; (1,1,1,1)
// when the primitive has none). material < 0 means the glTF default material (white).
Vec4 sample_base_color(const Scene& scene, int32_t material, const std::vector<Vec2>& uvs,
                       Vec4 vertex_color);

// Occlusion (x), roughness (y) and metallic (z) of `material` at the point, packed as glTF packs
// them: occlusion = 1 + strength · (texel.r − 1), roughness = factor · texel.g, metallic =
// factor · texel.b (texels are 1 without a texture). Linear, in [0, 1]. The default material
// gives (1, 1, 1).
Vec3 sample_occlusion_roughness_metallic(const Scene& scene, int32_t material,
                                         const std::vector<Vec2>& uvs);

// Emissive radiance of `material` at the point: factor (strength folded in on import, so it
// may exceed 1) × the sRGB-decoded texture. Linear RGB.
Vec3 sample_emissive(const Scene& scene, int32_t material, const std::vector<Vec2>& uvs);

// Sheen colour (KHR_materials_sheen) of `material` at the point: factor × the sRGB-decoded
// texture. Linear RGB; (0, 0, 0) without sheen.
Vec3 sample_sheen_color(const Scene& scene, int32_t material, const std::vector<Vec2>& uvs);

// The tangent-space normal the material's normal map stores at the point (2 · texel − 1, x and
// y multiplied by normalTexture.scale; not normalized), or (0, 0, 1) without a normal map.
Vec3 sample_normal_map(const Scene& scene, int32_t material, const std::vector<Vec2>& uvs);

// The uv set and transform through which `material`'s normal map is sampled (for the tangent
// frame, which follows the transformed uvs); false without a normal map.
bool normal_map_uv(const Scene& scene, int32_t material, uint32_t* tex_coord,
                   TextureTransform* transform);

}  // namespace meshmux
