// Loads the OpenImageIO module (image/oiio/oiio_codec.h) on first use and decodes through it.
// The module is looked for in $MESHMUX_OIIO_MODULE (a path) when set, then beside the running
// executable, then in the build tree it was built in (tests run from build/tests/). Loading
// happens once per process (thread-safe); a missing module is an error naming where it looked.
#pragma once

#include <cstdint>
#include <string>

#include "scene/scene.h"

namespace meshmux {

// Decodes image.encoded (OpenImageIO format name `format`) into image.rgba/width/height.
// Errors name image.name; `over_limit` is set when the only failure is the pixel limit.
Status oiio_decode(Image& image, const std::string& format, uint64_t max_pixels, bool* over_limit);

// True once the module has been loaded in this process (for tests of the fast paths).
bool oiio_module_loaded();

}  // namespace meshmux
