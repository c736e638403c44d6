// KTX2 images of a glTF file (see ktx2_images.h).
#include "exporters/ktx2_images.h"

#include <algorithm>
#include <mutex>

#include "core/parallel.h"
#include "image/decode.h"

namespace meshmux {

std::vector<ImageUse> image_uses(const Scene& scene) {
  std::vector<ImageUse> uses(scene.images.size(), ImageUse::kNone);
  auto mark = [&](const TextureRef& t, ImageUse use) {
    if (!t.present() || size_t(t.image) >= uses.size()) return;
    ImageUse& u = uses[size_t(t.image)];
    // Colour wins over a normal map, a normal map over data: the stricter reading.
    if (u == ImageUse::kNone || (use == ImageUse::kColour) ||
        (use == ImageUse::kNormal && u == ImageUse::kData))
      u = use;
  };
  for (const Material& m : scene.materials) {
    for (const TextureRef* t : texture_refs(m)) mark(*t, ImageUse::kData);
    mark(m.normal, ImageUse::kNormal);
    mark(m.layer(LayerSlot::kClearcoatNormal), ImageUse::kNormal);
    for (const TextureRef* t :
         {&m.base_color, &m.emissive, &m.sheen_color, &m.layer(LayerSlot::kSpecularColor)})
      mark(*t, ImageUse::kColour);
  }
  return uses;
}

Result<std::vector<std::vector<uint8_t>>> encode_images_ktx2(const Scene& scene,
                                                             const std::vector<ImageUse>& uses,
                                                             const Ktx2EncodeOptions& base) {
  std::vector<size_t> todo;
  for (size_t i = 0; i < scene.images.size() && i < uses.size(); ++i)
    if (uses[i] != ImageUse::kNone && scene.images[i].mime_type != "image/ktx2")
      todo.push_back(i);  // a KTX2 image is written as it is
  std::vector<std::vector<uint8_t>> out(scene.images.size());
  std::vector<Status> errors(todo.size(), Status::ok());
  // Side by side, one encoder thread each; a lone image takes every core.
  const int threads = todo.size() > 1 ? 1 : 0;
  parallel_chunks(todo.size(), 1, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      const size_t i = todo[k];
      const Image& src = scene.images[i];
      const std::string label = "image " + std::to_string(i) + " '" + src.name + "'";
      Image copy;
      const Image* img = &src;
      if (!src.decoded()) {
        copy = src;
        if (Status s = decode_image(copy); !s) {
          errors[k] = s.with_prefix("ktx2: " + label);
          continue;
        }
        img = &copy;
      }
      Ktx2EncodeOptions o = base;
      o.threads = threads;
      o.mode =
          uses[i] == ImageUse::kColour && !base.colour_uastc ? Ktx2Mode::kEtc1s : Ktx2Mode::kUastc;
      o.srgb = uses[i] == ImageUse::kColour;
      o.normal_map = uses[i] == ImageUse::kNormal;
      auto r = encode_ktx2(*img, o);
      if (!r.ok()) {
        errors[k] = r.status().with_prefix("ktx2: " + label);
        continue;
      }
      out[i] = std::move(r->bytes);
    }
  });
  for (const Status& s : errors)
    if (!s) return s;
  return out;
}

}  // namespace meshmux
