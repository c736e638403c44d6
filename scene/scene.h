// The plain data model every stage reads and writes. Indices, not pointers; no third-party
// types. Units: positions in the author's units as imported (glTF metres, COLLADA converted
// to metres and Y-up by the importer); uv in glTF convention (origin top-left, v down);
// colours linear RGBA in [0,1] (base colour texture pixels stay sRGB-encoded as stored).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/status.h"
#include "scene/math.h"

namespace meshmux {

// GL enum values, as glTF stores them.
enum class Wrap : int { kRepeat = 10497, kClampToEdge = 33071, kMirroredRepeat = 33648 };

struct Sampler {
  Wrap wrap_s = Wrap::kRepeat;  // horizontal wrap
  Wrap wrap_t = Wrap::kRepeat;  // vertical wrap
  int mag_filter = 0;           // GL enum (9728 NEAREST, 9729 LINEAR); 0 = unspecified
  int min_filter = 0;           // GL enum incl. mipmap modes; 0 = unspecified
};

// KHR_texture_transform: uv' = T(offset) * R(rotation) * S(scale) * uv.
struct TextureTransform {
  float offset[2] = {0, 0};  // uv units
  float rotation = 0;        // radians, counter-clockwise in uv space
  float scale[2] = {1, 1};   // uv units
  bool is_identity() const {
    return offset[0] == 0 && offset[1] == 0 && rotation == 0 && scale[0] == 1 && scale[1] == 1;
  }
};

// A material's use of an image.
struct TextureRef {
  int32_t image = -1;          // index into Scene::images; -1 = no texture
  Sampler sampler;             // how to sample it
  uint32_t tex_coord = 0;      // which uv set of the primitive
  TextureTransform transform;  // identity unless KHR_texture_transform was given
  float scale = 1;             // normalTexture.scale or occlusionTexture.strength
  bool present() const { return image >= 0; }
};

enum class AlphaMode { kOpaque, kMask, kBlend };

// The textures of a material's reflection layers, carried as they came (glTF's extension and
// key of each in kLayerSlots). The atlas keeps a material that has any beside it, with its own
// textures (atlas/kept.h): no atlas channel carries them.
enum class LayerSlot : uint8_t {
  kClearcoat,             // R scales clearcoat_factor
  kClearcoatRoughness,    // G scales clearcoat_roughness_factor
  kClearcoatNormal,       // the clearcoat's tangent-space normal map (TextureRef::scale)
  kSpecular,              // A scales specular_factor
  kSpecularColor,         // sRGB RGB scales specular_color_factor
  kIridescence,           // R scales iridescence_factor
  kIridescenceThickness,  // G: the film's thickness between its minimum and maximum
  kSheenRoughness,        // A scales sheen_roughness_factor
  kAnisotropy,            // RG direction, B strength (KHR_materials_anisotropy)
  kThickness,             // G scales thickness_factor (KHR_materials_volume)
  kCount
};
struct LayerSlotName {
  const char* extension;  // e.g. "KHR_materials_clearcoat"
  const char* key;        // e.g. "clearcoatTexture"
};
inline constexpr LayerSlotName kLayerSlots[size_t(LayerSlot::kCount)] = {
    {"KHR_materials_clearcoat", "clearcoatTexture"},
    {"KHR_materials_clearcoat", "clearcoatRoughnessTexture"},
    {"KHR_materials_clearcoat", "clearcoatNormalTexture"},
    {"KHR_materials_specular", "specularTexture"},
    {"KHR_materials_specular", "specularColorTexture"},
    {"KHR_materials_iridescence", "iridescenceTexture"},
    {"KHR_materials_iridescence", "iridescenceThicknessTexture"},
    {"KHR_materials_sheen", "sheenRoughnessTexture"},
    {"KHR_materials_anisotropy", "anisotropyTexture"},
    {"KHR_materials_volume", "thicknessTexture"},
};

// glTF metallic-roughness material. COLLADA's common profile maps onto it (diffuse → base
// colour, transparency → alpha).
struct Material {
  std::string name;
  Vec4 base_color_factor{1, 1, 1, 1};  // linear RGBA
  TextureRef base_color;               // sRGB texture, multiplied by the factor
  float metallic_factor = 1;           // [0,1]
  float roughness_factor = 1;          // [0,1]
  TextureRef metallic_roughness;       // linear; G = roughness, B = metallic
  TextureRef normal;                   // tangent-space normal map
  TextureRef occlusion;                // linear; R = occlusion
  TextureRef emissive;                 // sRGB
  Vec3 emissive_factor{0, 0, 0};       // linear RGB; may exceed 1 (KHR_materials_emissive_strength)
  Vec3 sheen_color_factor{0, 0, 0};    // KHR_materials_sheen: linear RGB (0: no sheen layer)
  TextureRef sheen_color;              // sRGB, RGB multiplied by the factor
  float sheen_roughness_factor = 0;    // [0,1] (its texture: layers[kSheenRoughness])
  // Glass (KHR_materials_transmission, _ior, _volume): carried, never approximated by alpha.
  float transmission_factor = 0;    // [0,1]: share of light passing through (0: none)
  TextureRef transmission;          // linear; R scales transmission_factor (the volume's
                                    // thickness texture: layers[kThickness])
  float ior = 1.5f;                 // index of refraction (KHR_materials_ior), ≥ 1
  float thickness_factor = 0;       // volume thickness, mesh units (0: thin-walled)
  float attenuation_distance = 0;   // distance light travels before it is attenuated to
                                    // attenuation_color; 0 = infinite (no attenuation)
  Vec3 attenuation_color{1, 1, 1};  // linear RGB
  bool transmissive() const { return transmission_factor > 0; }
  // Layers of the surface's reflection (MeshPhysicalMaterial in three.js): factors, and their
  // textures in `layers`.
  float clearcoat_factor = 0;            // KHR_materials_clearcoat: a second specular layer [0,1]
  float clearcoat_roughness_factor = 0;  // its roughness [0,1]
  float specular_factor = 1;             // KHR_materials_specular: strength of the reflection [0,1]
  Vec3 specular_color_factor{1, 1, 1};   // its F0 colour, linear (may exceed 1)
  float iridescence_factor = 0;          // KHR_materials_iridescence: thin-film layer [0,1]
  float iridescence_ior = 1.3f;          // the film's index of refraction
  float iridescence_thickness = 400;     // the film's thickness, nanometres (glTF's maximum,
                                         // what applies without the thickness texture)
  float iridescence_thickness_minimum = 100;     // nanometres, where the thickness texture is 0
  float anisotropy_strength = 0;                 // KHR_materials_anisotropy: [0,1] (0: isotropic)
  float anisotropy_rotation = 0;                 // radians, counter-clockwise from the tangent
  TextureRef layers[size_t(LayerSlot::kCount)];  // the layers' textures, by LayerSlot
  const TextureRef& layer(LayerSlot s) const { return layers[size_t(s)]; }
  TextureRef& layer(LayerSlot s) { return layers[size_t(s)]; }
  bool any_layer_texture() const {
    for (const TextureRef& t : layers)
      if (t.present()) return true;
    return false;
  }
  AlphaMode alpha_mode = AlphaMode::kOpaque;
  float alpha_cutoff = 0.5f;  // used when alpha_mode is kMask
  bool double_sided = false;  // render back faces
  bool unlit = false;         // KHR_materials_unlit
};

// Every texture reference of a material (base colour, the physically based channels, sheen
// colour, transmission, the layers), for code that visits or remaps image indices.
std::vector<const TextureRef*> texture_refs(const Material& m);
std::vector<TextureRef*> texture_refs(Material& m);

// An image: the bytes as they came (so unchanged images are passed through, not re-encoded)
// and, when decoding succeeded, RGBA8 pixels.
struct Image {
  std::string name;              // for messages; the uri or the glTF image name
  std::string mime_type;         // e.g. "image/png"; as detected from the bytes
  std::vector<uint8_t> encoded;  // original file bytes; may be empty for generated images
  int width = 0, height = 0;     // pixels; 0 when not decoded
  std::vector<uint8_t> rgba;     // width*height*4 bytes, row 0 at the top; empty when not decoded
  bool decoded() const { return width > 0 && height > 0 && !rgba.empty(); }
};

// Triangles sharing one material and one vertex layout (a glTF primitive, a COLLADA
// <triangles>/<polylist> block). Every attribute array is either empty or has one entry per
// vertex.
struct Primitive {
  std::vector<Vec3> positions;         // required
  std::vector<Vec3> normals;           // unit length; empty = to be generated
  std::vector<std::vector<Vec2>> uvs;  // uv sets TEXCOORD_0, TEXCOORD_1, ...
  std::vector<Vec4> colors;            // COLOR_0, linear RGBA
  std::vector<uint32_t> indices;       // 3 per triangle, counter-clockwise front faces
  int32_t material = -1;               // index into Scene::materials; -1 = default material
  bool flat = false;  // the source gave no normals, so viewers show it flat-shaded (glTF
                      // 3.7.2.1): normals are generated for our own use and not exported

  size_t vertex_count() const { return positions.size(); }
  size_t triangle_count() const { return indices.size() / 3; }
};

// A mesh: one or more primitives drawn together (a glTF mesh, a COLLADA <geometry>). Shared
// by every instance that references it.
struct Mesh {
  std::string name;
  std::vector<Primitive> primitives;
};

// Points and line segments (glTF's POINTS, LINES, LINE_STRIP and LINE_LOOP; COLLADA's <lines>
// and <linestrips>, which three.js's ColladaLoader draws and Gazebo's loads as LINES submeshes),
// carried beside the triangles and drawn as glTF viewers draw them (one pixel
// wide, in their material's colour, unlit): placed in the world at import (their nodes'
// transforms applied), never cleaned, simplified, baked or refined; model.glb and the base
// carry them whole.
struct LineSet {
  std::string name;               // for messages
  std::vector<Vec3> positions;    // world space
  std::vector<Vec4> colors;       // COLOR_0, linear RGBA; empty = none
  std::vector<uint32_t> indices;  // 2 per segment, or 1 per point
  bool points = false;            // points, not segments
  Vec4 color{1, 1, 1, 1};         // the material's base colour factor, linear RGBA
};

// One placement of a mesh in the world. Hierarchies are flattened into these.
struct Instance {
  uint32_t mesh = 0;  // index into Scene::meshes
  Mat4 world;         // mesh space → world space
  std::string name;   // the node's name, for messages and round trips
};

struct Scene {
  std::vector<Mesh> meshes;
  std::vector<Material> materials;
  std::vector<Image> images;
  std::vector<Instance> instances;
  std::vector<LineSet> lines;  // points and lines, in world space (every stage hands them on)
  std::string source;          // file the scene came from, for messages ("" for generated scenes)
  // Set by clean(): multiply world positions by this to give the scene a bounding-box
  // diagonal of 1, the unit in which later stages measure geometric error. 1 until then.
  double normalization_scale = 1;
};

// Meshes with at least this many instances count as one instanced draw per primitive
// (EXT_mesh_gpu_instancing); the exporter uses the same threshold.
constexpr size_t kMinGpuInstances = 4;

struct SceneStats {
  size_t meshes = 0;              // meshes referenced or not
  size_t primitives = 0;          // over all meshes
  size_t instances = 0;           // placements
  uint64_t scene_triangles = 0;   // every instance expanded
  uint64_t unique_triangles = 0;  // every mesh counted once
  uint64_t vertices = 0;          // every mesh counted once
  size_t materials = 0;
  size_t textures = 0;          // images referenced by any material
  uint64_t texture_pixels = 0;  // sum of width*height over referenced, decoded images
  uint64_t draw_calls = 0;      // see kMinGpuInstances
};

SceneStats compute_stats(const Scene& scene);

// A scene with `scene`'s materials, images (unless `with_images` is false: a stage that moves
// them across or never reads them), lines, source and normalization scale, and no meshes or
// instances: where a stage rebuilds the geometry (flattening, the record's reference).
Scene empty_like(const Scene& scene, bool with_images = true);

// Number of instances per mesh.
std::vector<size_t> instance_counts(const Scene& scene);

// World-space bounds over every instance. O(total instanced vertices).
Bounds scene_bounds(const Scene& scene);

// Bounds of one mesh in its own space.
Bounds mesh_bounds(const Mesh& mesh);

// Checks every index is in range, every attribute array has the vertex count, triangles come
// in threes, transforms and positions are finite. Messages name the element, prefixed with
// `stage`: "validate: mesh 3 primitive 1: index 7 out of range (5 vertices)".
Status validate(const Scene& scene, const std::string& stage = "validate");

}  // namespace meshmux
