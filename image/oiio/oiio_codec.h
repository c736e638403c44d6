// The OpenImageIO decoder as a loadable module (libmeshmux_oiio.so), behind a C interface.
// OpenImageIO links about 260 shared libraries (codecs for every format it knows); binding them
// costs every meshmux process ~0.3 s and ~130 MB before main() runs. JPEG and PNG, nearly every
// texture people upload, are decoded directly (image/decode.cpp); this module is loaded with
// dlopen (image/oiio_loader.h) only for the other formats (WebP, TGA, BMP, GIF, TIFF, ...) and
// for JPEG/PNG files the direct decoders refuse, so its messages stay the ones users saw.
// Only plain C types cross this boundary; OpenImageIO's stay in oiio_codec.cpp.
#pragma once

#include <cstddef>
#include <cstdint>

extern "C" {

// A decoded image: RGBA8, row 0 at the top, straight alpha; rgba from malloc (free it with
// meshmux_oiio_free).
struct MeshmuxOiioImage {
  int width;
  int height;
  uint8_t* rgba;
};

enum MeshmuxOiioResult {
  kMeshmuxOiioOk = 0,
  kMeshmuxOiioError = 1,      // not decodable: `error` says why
  kMeshmuxOiioOverLimit = 2,  // more than max_pixels pixels: `error` says how many
};

// Decodes `size` bytes of an image in OpenImageIO format `format` ("webp", "targa", "png", ...).
// `error` receives a NUL-terminated message (without the image's name) on failure. Never throws.
int meshmux_oiio_decode(const uint8_t* data, size_t size, const char* format, uint64_t max_pixels,
                        MeshmuxOiioImage* out, char* error, size_t error_size);
void meshmux_oiio_free(uint8_t* rgba);

// The name the loader resolves, for its messages.
#define MESHMUX_OIIO_MODULE "libmeshmux_oiio.so"
}
