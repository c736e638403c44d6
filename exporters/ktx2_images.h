// The images a glTF file embeds, encoded as KTX2 (Basis Universal, KHR_texture_basisu) for
// `meshmux convert -o X.glb --textures ktx2`: each in the mode its uses ask (ETC1S in sRGB for
// colour maps, UASTC for normal maps and linear data), on every core.
#pragma once

#include <cstdint>
#include <vector>

#include "core/status.h"
#include "image/ktx2_encode.h"
#include "scene/scene.h"

namespace meshmux {

// How an image is read by the materials that sample it.
enum class ImageUse : uint8_t { kNone, kColour, kNormal, kData };

// Per scene image, its use: colour where any material samples it as base colour, emissive,
// sheen or specular colour (sRGB); else a normal map where one samples it as a normal or
// clearcoat normal; else data (occlusion, roughness-metallic, the layers' factors: linear);
// kNone where no material samples it.
std::vector<ImageUse> image_uses(const Scene& scene);

// KTX2 bytes for every image whose use is not kNone and that is not KTX2 already (empty entries
// elsewhere: a KTX2 image, as uploaded or as the texture levels made it, is written as it is).
// Images that hold only their encoded bytes are decoded first (a copy: the scene is not changed).
// `base` gives the encoder's quality settings; mode, colour space and thread count are chosen here
// (images encoded side by side use one encoder thread each). Errors: the encoder's (a missing one
// names its npm package), an image that cannot be decoded (naming it). Deterministic.
Result<std::vector<std::vector<uint8_t>>> encode_images_ktx2(const Scene& scene,
                                                             const std::vector<ImageUse>& uses,
                                                             const Ktx2EncodeOptions& base = {});

}  // namespace meshmux
