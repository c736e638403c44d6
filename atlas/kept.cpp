// Materials kept beside the atlas (see kept.h).
#include "atlas/kept.h"

#include <algorithm>

#include "atlas/tiled.h"
#include "image/encode.h"

namespace meshmux {

namespace {

// A kept image is re-encoded as JPEG where that costs at most this share of its bytes.
constexpr double kKeptJpegShare = 0.9;

// GL's filters that sample one mip level only: minification without mipmaps shows the
// texture's own texel grid (aliasing and all), and NEAREST magnification its blocks. So does
// NEAREST within a mip level (NEAREST_MIPMAP_NEAREST or _LINEAR) of an image whose sides are not
// powers of two: the atlas and the texture levels must resample it to powers of two, and the
// resampled grid's texels no longer fall where the source's did (BoxTexturedNonPowerOfTwo's 211²
// palette: 29.4 dB unlit resampled to 256² and filtered trilinear, 27.4 dB resampled and kept
// NEAREST_MIPMAP_LINEAR, 35.5 dB kept as it came). A power-of-two image keeps its grid where the
// atlas reuses it as it is (atlas/source_atlas.h), its filter with it.
bool grid_filter(const Sampler& s, const Image& image) {
  constexpr int kNearest = 9728, kLinear = 9729;
  constexpr int kNearestMipmapNearest = 9984, kNearestMipmapLinear = 9986;
  auto pow2 = [](int v) { return v > 0 && (v & (v - 1)) == 0; };
  const bool nearest_in_level =
      s.min_filter == kNearestMipmapNearest || s.min_filter == kNearestMipmapLinear;
  return s.min_filter == kNearest || s.min_filter == kLinear || s.mag_filter == kNearest ||
         (nearest_in_level && !(pow2(image.width) && pow2(image.height)));
}

}  // namespace

size_t encode_kept_images(Scene& scene, size_t kept_materials, int quality, EncodeCounts* counts) {
  std::vector<char> kept(scene.images.size(), 0);
  const size_t first = scene.materials.size() - std::min(kept_materials, scene.materials.size());
  for (size_t m = first; m < scene.materials.size(); ++m)
    for (const TextureRef* t : texture_refs(scene.materials[m]))
      if (t->present() && size_t(t->image) < kept.size()) kept[size_t(t->image)] = 1;
  size_t saved = 0;
  for (size_t i = 0; i < scene.images.size(); ++i) {
    Image& img = scene.images[i];
    if (!kept[i] || !img.decoded() || img.encoded.empty()) continue;
    bool opaque = true;
    for (size_t k = 3; k < img.rgba.size() && opaque; k += 4) opaque = img.rgba[k] == 255;
    if (!opaque) continue;
    auto jpeg = encode_jpeg(img, quality, counts);
    if (!jpeg.ok() || double(jpeg->size()) > kKeptJpegShare * double(img.encoded.size())) continue;
    saved += img.encoded.size() - jpeg->size();
    img.encoded = jpeg.take();
    img.mime_type = "image/jpeg";
  }
  return saved;
}

std::vector<KeptReason> find_kept_materials(const Scene& scene, double periods) {
  std::vector<KeptReason> kept(scene.materials.size(), KeptReason::kNone);
  const std::vector<char> tiled =
      periods > 0 ? find_tiled_materials(scene, periods) : std::vector<char>();
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    const Material& m = scene.materials[i];
    if (i < tiled.size() && tiled[i]) {
      kept[i] = KeptReason::kTiled;
      continue;
    }
    if (m.any_layer_texture() || m.transmission.present() || m.anisotropy_strength > 0) {
      kept[i] = KeptReason::kLayers;
      continue;
    }
    for (const TextureRef* t : texture_refs(m))
      if (t->present() && size_t(t->image) < scene.images.size() &&
          scene.images[size_t(t->image)].decoded() &&
          grid_filter(t->sampler, scene.images[size_t(t->image)]))
        kept[i] = KeptReason::kTexelGrid;
  }
  return kept;
}

KeptSplit split_kept(const Scene& scene, const std::vector<KeptReason>& kept) {
  KeptSplit out;
  out.rest = scene;
  out.kept.source = scene.source;
  out.kept.normalization_scale = scene.normalization_scale;
  auto is_kept = [&](const Primitive& p) {
    return p.material >= 0 && size_t(p.material) < kept.size() &&
           kept[size_t(p.material)] != KeptReason::kNone;
  };
  std::vector<int32_t> material_map(scene.materials.size(), -1), image_map(scene.images.size(), -1);
  // Per source mesh, the kept meshes its instances also place.
  std::vector<std::vector<uint32_t>> kept_parts(scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    std::vector<Primitive>& rest_prims = out.rest.meshes[m].primitives;
    rest_prims.erase(std::remove_if(rest_prims.begin(), rest_prims.end(), is_kept),
                     rest_prims.end());
    for (const Primitive& p : scene.meshes[m].primitives) {
      if (!is_kept(p) || p.indices.empty()) continue;
      int32_t& mat = material_map[size_t(p.material)];
      if (mat < 0) {
        Material copy = scene.materials[size_t(p.material)];
        for (TextureRef* ref : texture_refs(copy)) {
          if (!ref->present() || size_t(ref->image) >= scene.images.size()) {
            ref->image = -1;
            continue;
          }
          int32_t& img = image_map[size_t(ref->image)];
          if (img < 0) {
            img = int32_t(out.kept.images.size());
            out.kept.images.push_back(scene.images[size_t(ref->image)]);
          }
          ref->image = img;
        }
        mat = int32_t(out.kept.materials.size());
        out.kept.materials.push_back(std::move(copy));
      }
      Mesh part;
      part.name = scene.meshes[m].name + " (kept)";
      part.primitives.push_back(p);
      part.primitives.back().material = mat;
      kept_parts[m].push_back(uint32_t(out.kept.meshes.size()));
      out.kept.meshes.push_back(std::move(part));
    }
  }
  for (const Instance& inst : scene.instances)
    if (inst.mesh < kept_parts.size())
      for (uint32_t part : kept_parts[inst.mesh]) {
        Instance copy = inst;
        copy.mesh = part;
        out.kept.instances.push_back(std::move(copy));
      }
  for (size_t i = 0; i < kept.size(); ++i)
    if (kept[i] != KeptReason::kNone)
      out.rest.materials[i] = Material{};  // unused now: its textures not counted
  out.kept_materials = out.kept.materials.size();
  return out;
}

void append_scene(Scene& out, Scene extra) {
  const int32_t image_base = int32_t(out.images.size());
  const int32_t material_base = int32_t(out.materials.size());
  const uint32_t mesh_base = uint32_t(out.meshes.size());
  out.images.insert(out.images.end(), std::make_move_iterator(extra.images.begin()),
                    std::make_move_iterator(extra.images.end()));
  for (Material m : extra.materials) {
    for (TextureRef* ref : texture_refs(m))
      if (ref->present()) ref->image += image_base;
    out.materials.push_back(std::move(m));
  }
  for (Mesh mesh : extra.meshes) {
    for (Primitive& p : mesh.primitives)
      if (p.material >= 0) p.material += material_base;
    out.meshes.push_back(std::move(mesh));
  }
  for (Instance inst : extra.instances) {
    inst.mesh += mesh_base;
    out.instances.push_back(std::move(inst));
  }
}

}  // namespace meshmux
