// Options shared by the importers.
#pragma once

#include <cstdint>

namespace meshmux {

struct ImportOptions {
  bool decode_images = true;  // decode images to RGBA8 (needed by the atlas)
  uint64_t max_image_pixels = uint64_t(1)
                              << 28;            // refuse to decode larger images (hostile headers)
  uint64_t max_file_bytes = uint64_t(4) << 30;  // refuse larger input files
};

}  // namespace meshmux
