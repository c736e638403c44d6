#include "image/encode.h"

#include <png.h>

#include <csetjmp>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

namespace meshmux {

namespace {

std::string image_label(const Image& image) {
  return image.name.empty() ? std::string("image") : "image '" + image.name + "'";
}

// `rows` of w × h pixels of `channels` (3 or 4) bytes as a PNG appended to `out`: zlib level 6
// and libpng's adaptive filter choice among Up and Paeth only (of libpng's five: on baked atlases
// the bytes of all five within ±0.02%, in 60-80% of the time: 4096×2048 RGBA 0.58 → 0.51 s and
// 0.44 → 0.34 s); alpha straight, as PNG stores it. False on a libpng error. Nothing here
// changes after setjmp.
bool write_png(const uint8_t* pixels, size_t w, size_t h, int channels, std::vector<uint8_t>& out) {
  png_structp png = png_create_write_struct(
      PNG_LIBPNG_VER_STRING, nullptr, [](png_structp p, png_const_charp) { png_longjmp(p, 1); },
      [](png_structp, png_const_charp) {});
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  std::vector<png_bytep> rows(h);
  for (size_t y = 0; y < h; ++y) rows[y] = const_cast<png_bytep>(pixels + y * w * size_t(channels));
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(
      png, &out,
      [](png_structp p, png_bytep data, png_size_t n) {
        auto* o = static_cast<std::vector<uint8_t>*>(png_get_io_ptr(p));
        o->insert(o->end(), data, data + n);
      },
      [](png_structp) {});
  png_set_compression_level(png, 6);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP | PNG_FILTER_PAETH);
  png_set_IHDR(png, info, png_uint_32(w), png_uint_32(h), 8,
               channels == 4 ? PNG_COLOR_TYPE_RGB_ALPHA : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_write_image(png, rows.data());
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

std::vector<uint8_t> encode_as_top_level(const Image& image, int quality, bool alpha,
                                         std::string* mime_type) {
  if (!image.decoded()) return {};
  bool opaque = true;
  for (size_t i = 3; alpha && opaque && i < image.rgba.size(); i += 4)
    opaque = image.rgba[i] == 255;
  const bool png = alpha && !opaque;
  auto bytes = png ? encode_png(image) : encode_jpeg(image, quality);
  if (!bytes.ok()) return {};
  if (mime_type) *mime_type = png ? "image/png" : "image/jpeg";
  return bytes.take();
}

size_t encoded_size(const Image& image, int quality, bool alpha) {
  return encode_as_top_level(image, quality, alpha, nullptr).size();
}

Result<std::vector<uint8_t>> encode_png(const Image& image, EncodeCounts* counts) {
  const std::string where = "png encode: " + image_label(image);
  if (!image.decoded()) return Status::error(where + ": not decoded", ErrorKind::kInternal);
  const size_t w = size_t(image.width), h = size_t(image.height);
  if (image.rgba.size() != w * h * 4)
    return Status::error(where + ": pixel buffer size " + std::to_string(image.rgba.size()) +
                             " does not match " + std::to_string(w) + "x" + std::to_string(h),
                         ErrorKind::kInternal);
  try {
    bool opaque = true;
    for (size_t i = 3; i < image.rgba.size(); i += 4)
      if (image.rgba[i] != 255) {
        opaque = false;
        break;
      }
    const int channels = opaque ? 3 : 4;
    std::vector<uint8_t> pixels;
    const uint8_t* src = image.rgba.data();
    if (opaque) {
      pixels.resize(w * h * 3);
      for (size_t i = 0, n = w * h; i < n; ++i) std::memcpy(&pixels[i * 3], &src[i * 4], 3);
      src = pixels.data();
    }

    std::vector<uint8_t> bytes;
    if (!write_png(src, w, h, channels, bytes))
      return Status::error(where + ": the PNG writer failed", ErrorKind::kInternal);
    if (bytes.size() < 8)
      return Status::error(where + ": writer produced no data", ErrorKind::kInternal);
    count(counts, &EncodeCounts::images);
    return bytes;
  } catch (const std::exception& e) {
    return Status::error(where + ": " + e.what(), ErrorKind::kInternal);
  }
}

}  // namespace meshmux
