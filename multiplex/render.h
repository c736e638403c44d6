// Offscreen rendering the way the web client draws (paper 004 §3: distortion is measured on
// rendered images): OpenGL 4.5 core through EGL's surfaceless platform (Mesa llvmpipe without a
// GPU), perspective camera, base colour texture with mipmapped trilinear filtering and 16x
// anisotropy, shading = base colour × (ambient + Lambert from a fixed light). Returns RGBA8 and a
// coverage mask. Deterministic: identical inputs give identical images. Not thread-safe: one
// Renderer per thread. No GL or EGL type leaks out of render.cpp.
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

struct RenderOptions {
  int width = 256, height = 256;  // pixels
  float ambient = 0.35f;          // light terms, as the web viewer uses them
  float diffuse = 0.65f;
  Vec3 light_direction{0.4f, 0.8f, 0.45f};  // towards the light, world space (normalized inside)
  bool light_follows_camera = true;         // light direction given in camera space instead
  float anisotropy = 16;                    // max anisotropic filtering
};

struct RenderImage {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;      // width*height*4, row 0 at the top, background (0,0,0,0)
  std::vector<uint8_t> coverage;  // width*height, 1 where geometry was drawn
};

class Renderer {
 public:
  // Creates the EGL display and an OpenGL 4.5 core context with an offscreen framebuffer.
  // Errors (kInternal) say what is missing: no EGL, no surfaceless platform, no GL 4.5.
  static Result<std::unique_ptr<Renderer>> create(const RenderOptions& options = {});
  ~Renderer();

  // Uploads the geometry of a scene (every mesh's primitives with positions, normals and uv
  // set 0; every instance's transform; materials' base-colour factors). With `with_textures`
  // each primitive also gets its material's decoded base-colour image (uploaded once per image)
  // and reads the uv set that texture names: what `meshmux render` of a multi-material scene
  // needs. Returns a handle.
  int add_geometry(const Scene& scene, bool with_textures = false);
  // Uploads an RGBA8 texture with a full mip chain. Returns a handle.
  int add_texture(const Image& image);
  // Frees what add_* uploaded.
  void remove_geometry(int handle);
  void remove_texture(int handle);

  // Draws geometry `g` with texture `t` on every primitive; t = -1: each primitive's own texture
  // (add_geometry with_textures), or base-colour factors only.
  RenderImage render(int g, int t, const Camera& camera);

  const RenderOptions& options() const;

 private:
  Renderer();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace meshmux
