// Texture levels: the power-of-two pyramid of one texture (the atlas), each level encoded on
// its own so a client can show any level without the others (docs/ARCHITECTURE.md "Texture
// levels").
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace meshmux {

// A further material channel's map at a level's resolution ("normal",
// "occlusion_roughness_metallic", "emissive"): a texture step may carry several, one per
// physically based channel.
struct TextureMap {
  std::string channel;           // the glTF channel it stands for
  std::string mime_type;         // "image/jpeg" or "image/png"
  std::vector<uint8_t> encoded;  // independently decodable
};

// An image of a material kept beside the atlas (tiled, layer textures, texel grids: atlas/kept.h)
// at a level's scale: the level's share of that image's detail, so that the base carries it
// small and the levels bring it up with the atlas (the finest shipped level: as it came).
struct KeptMap {
  int32_t image = -1;            // the scene's image it stands for (the base .glb tags it so)
  int width = 0, height = 0;     // pixels
  std::string mime_type;         // as the image came: "image/jpeg" or "image/png"
  std::vector<uint8_t> encoded;  // independently decodable
};

struct TextureLevel {
  int width = 0, height = 0;           // pixels
  std::string mime_type;               // "image/jpeg", or "image/png" when the texture has alpha
  std::vector<uint8_t> encoded;        // the base colour map's file bytes, independently decodable
  std::vector<TextureMap> other_maps;  // further channels at the same size
  std::vector<KeptMap> kept;           // kept materials' images at this level's scale
};

// A level that was built and not shipped, and why (for report.json).
struct DroppedTextureLevel {
  int width = 0, height = 0;
  uint64_t bytes = 0;
  std::string why;
};

struct TextureLevels {
  std::vector<TextureLevel> levels;  // smallest first; levels.back() is the full size
  std::vector<DroppedTextureLevel> dropped;
  int32_t material = -1;  // the scene's material whose texture set the levels stand for (the
                          // atlas's; the other materials' images ride as kept maps); -1: none
};

}  // namespace meshmux
