// Image decoding from memory, so glTF's embedded and data-URI images and files on disk take the
// same path: JPEG through libjpeg-turbo's TurboJPEG API, PNG through libpng, KTX2 through the
// Basis transcoder in a child process (image/ktx2_transcode.h), everything else through
// OpenImageIO (a module loaded on first use, image/oiio_loader.h). The atlas bakes from
// these pixels (Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of 3D
// models for interactive metaverses" §4.3).
#include "image/decode.h"

#include <png.h>
#include <turbojpeg.h>

#include <algorithm>
#include <csetjmp>
#include <cstring>
#include <memory>

#include "core/file_io.h"
#include "image/ktx2_transcode.h"
#include "image/oiio_loader.h"

namespace meshmux {

namespace {

std::string lower_extension(const std::string& name) {
  size_t dot = name.find_last_of('.');
  size_t slash = name.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = name.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

// OpenImageIO format name for a MIME type or extension.
std::string oiio_format(const std::string& mime, const std::string& name) {
  if (mime == "image/png") return "png";
  if (mime == "image/jpeg") return "jpeg";
  if (mime == "image/webp") return "webp";
  if (mime == "image/bmp") return "bmp";
  if (mime == "image/gif") return "gif";
  if (mime == "image/tiff") return "tiff";
  if (mime == "image/x-tga") return "targa";
  if (mime == "image/vnd.radiance") return "hdr";
  if (mime == "image/x-exr") return "openexr";
  if (mime == "image/ktx2") return "ktx2";
  std::string ext = lower_extension(name);
  if (ext == "tga") return "targa";
  return ext;
}

// What a direct decoder made of the bytes: pixels, a size over the limit, or a refusal (the
// caller then asks OpenImageIO, whose message the user sees).
enum class DirectResult { kDecoded, kOverLimit, kRefused };

// Baseline and progressive JPEG, grey or YCbCr, to RGBA8 (TurboJPEG's default accurate DCT and
// smooth upsampling, as libjpeg's defaults that OpenImageIO uses). CMYK/YCCK refuse.
// `declared` receives the size the header names (for the over-limit message).
DirectResult decode_jpeg(Image& image, uint64_t max_pixels, int declared[2]) {
  std::unique_ptr<void, int (*)(tjhandle)> tj(tjInitDecompress(), tjDestroy);
  if (!tj) return DirectResult::kRefused;
  int w = 0, h = 0, subsampling = 0, colorspace = 0;
  if (tjDecompressHeader3(tj.get(), image.encoded.data(), (unsigned long)image.encoded.size(), &w,
                          &h, &subsampling, &colorspace) != 0 ||
      w <= 0 || h <= 0)
    return DirectResult::kRefused;
  if (colorspace == TJCS_CMYK || colorspace == TJCS_YCCK) return DirectResult::kRefused;
  if (uint64_t(w) * uint64_t(h) > max_pixels) {
    declared[0] = w, declared[1] = h;
    return DirectResult::kOverLimit;
  }
  image.rgba.resize(size_t(w) * size_t(h) * 4);
  // Any complaint, a warning included (a truncated scan), refuses: OpenImageIO then gives the
  // verdict users always had for damaged files.
  if (tjDecompress2(tj.get(), image.encoded.data(), (unsigned long)image.encoded.size(),
                    image.rgba.data(), w, w * 4, h, TJPF_RGBA, 0) != 0)
    return DirectResult::kRefused;
  image.width = w;
  image.height = h;
  return DirectResult::kDecoded;
}

// PNG of any bit depth and colour type to RGBA8: palette and grey expanded, tRNS to alpha,
// 16-bit scaled (rounded) to 8. No gamma conversion: glTF takes texel values as stored (normal
// and roughness maps are data), as OpenImageIO returned them.
struct PngRead {
  const uint8_t* data;
  size_t size, at;
};
DirectResult decode_png(Image& image, uint64_t max_pixels, int declared[2]) {
  png_structp png = png_create_read_struct(
      PNG_LIBPNG_VER_STRING, nullptr, [](png_structp p, png_const_charp) { png_longjmp(p, 1); },
      [](png_structp, png_const_charp) {});
  if (!png) return DirectResult::kRefused;
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    return DirectResult::kRefused;
  }
  PngRead src{image.encoded.data(), image.encoded.size(), 0};
  std::vector<png_bytep> rows;
  // Everything below may longjmp back here on a libpng error; only PODs and vectors whose
  // storage is set up before the first libpng call that can fail live across it.
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return DirectResult::kRefused;
  }
  png_set_read_fn(png, &src, [](png_structp p, png_bytep out, png_size_t n) {
    auto* r = static_cast<PngRead*>(png_get_io_ptr(p));
    if (n > r->size - r->at) png_error(p, "truncated");
    std::memcpy(out, r->data + r->at, n);
    r->at += n;
  });
  png_set_user_limits(png, 0x7fffffff, 0x7fffffff);
  png_read_info(png, info);
  const png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
  if (w == 0 || h == 0) {
    png_destroy_read_struct(&png, &info, nullptr);
    return DirectResult::kRefused;
  }
  if (uint64_t(w) * uint64_t(h) > max_pixels) {
    declared[0] = int(w), declared[1] = int(h);
    png_destroy_read_struct(&png, &info, nullptr);
    return DirectResult::kOverLimit;
  }
  const int color = png_get_color_type(png, info);
  png_set_expand(png);  // palette → RGB, grey < 8 bits → 8, tRNS → alpha
  png_set_scale_16(png);
  if (color == PNG_COLOR_TYPE_GRAY || color == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(png);
  png_set_add_alpha(png, 0xFF, PNG_FILLER_AFTER);  // no effect when alpha is present
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  if (png_get_rowbytes(png, info) != size_t(w) * 4) {
    png_destroy_read_struct(&png, &info, nullptr);
    return DirectResult::kRefused;
  }
  image.rgba.resize(size_t(w) * size_t(h) * 4);
  rows.resize(h);
  for (png_uint_32 y = 0; y < h; ++y) rows[y] = &image.rgba[size_t(y) * size_t(w) * 4];
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  image.width = int(w);
  image.height = int(h);
  return DirectResult::kDecoded;
}

}  // namespace

std::string sniff_image_mime(const std::vector<uint8_t>& b, const std::string& name_hint) {
  auto starts = [&](std::initializer_list<uint8_t> sig, size_t at = 0) {
    if (b.size() < at + sig.size()) return false;
    size_t i = at;
    for (uint8_t c : sig)
      if (b[i++] != c) return false;
    return true;
  };
  if (starts({0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A})) return "image/png";
  if (starts({0xFF, 0xD8, 0xFF})) return "image/jpeg";
  if (starts({'R', 'I', 'F', 'F'}) && starts({'W', 'E', 'B', 'P'}, 8)) return "image/webp";
  if (starts({'G', 'I', 'F', '8'})) return "image/gif";
  if (starts({'B', 'M'})) return "image/bmp";
  if (starts({'I', 'I', 42, 0}) || starts({'M', 'M', 0, 42})) return "image/tiff";
  if (starts({0xAB, 'K', 'T', 'X', ' ', '2', '0'})) return "image/ktx2";
  if (starts({'#', '?'})) return "image/vnd.radiance";
  if (starts({0x76, 0x2F, 0x31, 0x01})) return "image/x-exr";
  std::string ext = lower_extension(name_hint);
  if (ext == "tga") return "image/x-tga";
  if (ext == "dds") return "image/vnd-ms.dds";
  return "";
}

Status decode_image(Image& image, uint64_t max_pixels, bool* over_limit) {
  if (over_limit) *over_limit = false;
  image.rgba.clear();
  image.width = image.height = 0;
  const std::string& name = image.name;
  if (image.encoded.empty()) return Status::error(name + ": image is empty", ErrorKind::kInput);
  if (image.mime_type.empty()) image.mime_type = sniff_image_mime(image.encoded, name);
  std::string format = oiio_format(image.mime_type, name);
  if (format.empty()) return Status::error(name + ": unknown image format", ErrorKind::kInput);
  if (format == "ktx2") {  // Basis Universal, through the transcoder in a child process
    Ktx2TranscodeOptions options;
    options.max_pixels = max_pixels;
    Ktx2Transcoded t = transcode_ktx2_images({&image}, options);
    if (over_limit) *over_limit = t.images[0].over_limit;
    return t.images[0].status;
  }

  // JPEG and PNG (nearly every texture) directly; anything else, or a JPEG/PNG these refuse
  // (CMYK JPEG, a damaged file), through OpenImageIO, loaded on first use (oiio_loader.h).
  if (format == "jpeg" || format == "png") {
    int declared[2] = {0, 0};
    const DirectResult r = format == "jpeg" ? decode_jpeg(image, max_pixels, declared)
                                            : decode_png(image, max_pixels, declared);
    if (r == DirectResult::kDecoded) {
      if (image.mime_type.empty()) image.mime_type = "image/" + format;
      return Status::ok();
    }
    image.rgba.clear();
    image.width = image.height = 0;
    if (r == DirectResult::kOverLimit) {
      if (over_limit) *over_limit = true;
      return Status::error(name + ": image is " + std::to_string(declared[0]) + "x" +
                               std::to_string(declared[1]) + ", over the limit of " +
                               std::to_string(max_pixels) + " pixels",
                           ErrorKind::kInput);
    }
  }
  Status s = oiio_decode(image, format, max_pixels, over_limit);
  if (!s) {
    image.rgba.clear();
    image.width = image.height = 0;
    return s;
  }
  if (image.mime_type.empty()) image.mime_type = "image/" + format;
  return Status::ok();
}

Result<Image> load_image_file(const std::string& path) {
  auto bytes = read_whole_file(path);
  if (!bytes.ok()) return bytes.status();
  Image image;
  image.name = path;
  image.encoded = bytes.take();
  image.mime_type = sniff_image_mime(image.encoded, path);
  Status s = decode_image(image);
  if (!s) return s;
  return image;
}

}  // namespace meshmux
