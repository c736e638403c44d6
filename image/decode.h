// Image decoding for both importers: JPEG through libjpeg-turbo, PNG through libpng, KTX2
// (Basis Universal) through three.js's transcoder under node (image/ktx2_transcode.h: one child
// process per call; the glTF importer batches a model's KTX2 images into one), and TGA,
// WebP, BMP and whatever else the installed OpenImageIO reads through its module (loaded only
// when such an image is met, image/oiio_loader.h). One path for every image so that glTF and
// COLLADA textures behave the same.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "scene/scene.h"

namespace meshmux {

// The MIME type of encoded image bytes from their signature ("image/png", "image/jpeg",
// "image/webp", "image/x-tga" by extension hint only, ...); "" when unknown. `name_hint` is a
// file name whose extension is used when the bytes carry no signature (TGA has none).
std::string sniff_image_mime(const std::vector<uint8_t>& bytes, const std::string& name_hint = "");

// Decodes image.encoded into image.rgba (RGBA8, row 0 at the top; grey, grey+alpha and RGB
// expanded; 16-bit and float images converted). Fills width, height and mime_type. On failure
// leaves rgba empty and returns an error naming image.name and the cause. Refuses images over
// `max_pixels` (a hostile header must not make us allocate gigabytes).
// `over_limit` (optional) is set when the failure is only that the image has more than
// `max_pixels` pixels (the caller may name the option that raises its limit).
Status decode_image(Image& image, uint64_t max_pixels = uint64_t(1) << 28,
                    bool* over_limit = nullptr);

// Reads a file into an Image (encoded bytes, name = path) and decodes it. A missing or
// unreadable file is an error; so is a file that fails to decode.
Result<Image> load_image_file(const std::string& path);

}  // namespace meshmux
