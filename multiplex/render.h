// Offscreen rendering the way the web client draws (Yang, Shen and Kuo, "Progressive coding of
// 3D textured graphic model via joint mesh-texture optimization" §3: distortion is measured on
// rendered images): OpenGL 4.5 core through EGL's surfaceless platform (Mesa llvmpipe without a
// GPU), perspective camera, base colour texture with mipmapped trilinear filtering and 16x
// anisotropy, shading = base colour × (ambient + Lambert from a fixed light), or physically
// based (normal, occlusion-roughness-metallic and emissive maps; multiplex/render_shaders.cpp).
// Returns RGBA8 and a coverage mask. Deterministic: identical inputs give identical images. Not
// thread-safe: one Renderer per thread. No GL or EGL type leaks out of render.cpp.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "scene/scene.h"

namespace meshmux {

struct Camera {
  Vec3 eye{0, 0, 3};     // world position
  Vec3 target{0, 0, 0};  // looked-at point
  Vec3 up{0, 1, 0};
  float fov_y_degrees = 45;
  float near_plane = 0.01f, far_plane = 100;
};

enum class Shading {
  kLambert,   // base colour × (ambient + diffuse · Lambert), texels used as stored bytes
  kPhysical,  // glTF metal-roughness as three.js's MeshStandardMaterial shades it
};

struct RenderOptions {
  int width = 256, height = 256;  // pixels
  Shading shading = Shading::kLambert;
  float ambient = 0.35f;  // Lambert: light terms, as the web viewer uses them
  float diffuse = 0.65f;
  Vec3 light_direction{0.4f, 0.8f, 0.45f};  // towards the light, world space (normalized inside)
  bool light_follows_camera = true;         // light direction given in camera space instead
  float anisotropy = 16;                    // max anisotropic filtering
  // With several texture sets in one call (render with sets), draw depth alone first, then
  // shade each set with an equal depth test: one geometry-only pass shared by the sets, and
  // each pixel shaded once however deep the overdraw. Where coplanar faces overlap, the last
  // drawn shows instead of the first.
  bool depth_prepass = true;
  // Physical: a uniform environment of this radiance (linear, white; three.js: a constant
  // environment map, intensity 1) and a white directional light of this intensity from
  // light_direction (three.js: DirectionalLight.intensity).
  float environment = 0.5f;
  float light_intensity = 1.6f;
  // Display pixels per image pixel: textures are sampled with the footprint a pixel has on the
  // display the order is made for (a level-of-detail bias of −log2(scale)), so the mip level is
  // the one three.js picks there and each image pixel is one sample of the display's picture (its
  // mean error estimated from 1 / scale² of the display's pixels). Other than 1, the samplers
  // are trilinear (llvmpipe's anisotropic filter ignores the bias): isotropic, the footprint's
  // major axis, where three.js filters up to `anisotropy`. 1: the image's own pixels.
  float display_scale = 1;
};

// The options the stream is measured and shown with: physically based shading.
inline RenderOptions physical_shading() {
  RenderOptions o;
  o.shading = Shading::kPhysical;
  return o;
}

// The textures a draw samples (handles from add_texture; -1: none). Physical shading reads all
// of them; Lambert only the base colour.
struct TextureSet {
  int base_color = -1;  // sRGB colour (with alpha)
  int normal = -1;      // tangent-space normal map (data)
  int orm = -1;         // occlusion (R), roughness (G), metallic (B) (data)
  int emissive = -1;    // sRGB colour
  int sheen = -1;       // sheen colour (KHR_materials_sheen), sRGB
  // For primitives that keep their own material's images (add_geometry streamed_material): the
  // handle standing for each of the scene's images (image index, handle), ascending by index;
  // an image not listed is drawn without its texture.
  std::vector<std::pair<int32_t, int>> kept;
};

struct RenderImage {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;      // width*height*4, row 0 at the top, background (0,0,0,0)
  std::vector<uint8_t> coverage;  // width*height, 1 where geometry was drawn
};

class Renderer {
 public:
  // Creates the EGL display and an OpenGL 4.5 core context with an offscreen framebuffer.
  // Errors (kUnavailable: `meshmux render` exits 5) say what is missing: no EGL, no
  // surfaceless platform, no GL 4.5; a size outside the GL's limits is kInput, other GL
  // failures kInternal.
  static Result<std::unique_ptr<Renderer>> create(const RenderOptions& options = {});
  ~Renderer();

  // Uploads the geometry of a scene (every mesh's primitives with positions, normals and uv
  // set 0; every instance's transform; materials' factors). With `with_textures` each
  // primitive also gets its material's decoded images (base colour, normal, metallic-roughness
  // with any occlusion in its R, emissive; uploaded once per image and wrap, sampled with the
  // wraps of the material's sampler) and reads the uv set the
  // base colour names: what `meshmux render` of a multi-material scene needs. Returns a handle.
  // With `streamed_material` ≥ 0 instead (the material the texture levels stream,
  // TextureLevels::material), the primitives whose material does not sample the base colour
  // image that material samples (the materials kept beside the atlas, atlas/kept.h) keep their
  // own images when drawn with an explicit set: each slot's image through the set's `kept`
  // handles (nothing is uploaded here), with their own uv set and factors.
  int add_geometry(const Scene& scene, bool with_textures = false, int32_t streamed_material = -1);
  // Uploads an RGBA8 texture with a full mip chain. Returns a handle. `color`: the texels are
  // sRGB colours (base colour, emissive), decoded by the GL under physical shading; otherwise
  // data (normal, occlusion-roughness-metallic), read as stored. `wrap_s`, `wrap_t`: how it is
  // sampled past its edges (its material's sampler: a kept source image as the atlas may
  // repeat, atlas/source_atlas.h; charts are clamped).
  int add_texture(const Image& image, bool color = true, Wrap wrap_s = Wrap::kClampToEdge,
                  Wrap wrap_t = Wrap::kClampToEdge);
  // Frees what add_* uploaded.
  void remove_geometry(int handle);
  void remove_texture(int handle);

  // Draws geometry `g` with texture `t` on every primitive; t = -1: each primitive's own texture
  // (add_geometry with_textures), or base-colour factors only.
  RenderImage render(int g, int t, const Camera& camera);
  // Draws geometry `g` with the texture set `t` on every primitive (its factors from each
  // primitive's material), but those that keep their own images (add_geometry streamed_material);
  // an empty set (all -1): each primitive's own textures, as above.
  RenderImage render(int g, const TextureSet& t, const Camera& camera);
  // Draws geometry `g` with every set from every camera: images camera-major (camera c, set k
  // at c * sets.size() + k), each what render(g, set, camera) gives, except that with two or
  // more sets the depth pre-pass is used (where coplanar faces overlap a pixel may show the
  // other face). Cheaper than separate calls: the geometry-only pass is drawn once per camera
  // for all sets.
  std::vector<RenderImage> render(int g, const std::vector<TextureSet>& sets,
                                  const std::vector<Camera>& cameras);

  const RenderOptions& options() const;

 private:
  Renderer();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace meshmux
