#include "image/encode.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <atomic>
#include <cstring>
#include <exception>
#include <string>

namespace meshmux {

namespace {

std::atomic<uint64_t> g_images_encoded{0};

std::string image_label(const Image& image) {
  return image.name.empty() ? std::string("image") : "image '" + image.name + "'";
}

}  // namespace

uint64_t images_encoded() { return g_images_encoded.load(); }
void count_image_encoded() { ++g_images_encoded; }

Result<std::vector<uint8_t>> encode_png(const Image& image) {
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

    std::vector<unsigned char> bytes;
    OIIO::Filesystem::IOVecOutput proxy(bytes);
    auto out = OIIO::ImageOutput::create("image.png", &proxy);
    if (!out)
      return Status::error(where + ": no PNG writer: " + OIIO::geterror(), ErrorKind::kInternal);
    if (!out->supports("ioproxy"))
      return Status::error(where + ": PNG writer cannot write to memory", ErrorKind::kInternal);
    OIIO::ImageSpec spec(image.width, image.height, channels, OIIO::TypeDesc::UINT8);
    // Our pixels carry straight alpha, as PNG does: without this OpenImageIO takes them for
    // premultiplied and divides RGB by alpha on the way out (grey glass became white).
    spec.attribute("oiio:UnassociatedAlpha", 1);
    if (!out->set_ioproxy(&proxy) || !out->open("image.png", spec))
      return Status::error(where + ": " + out->geterror(), ErrorKind::kInternal);
    if (!out->write_image(OIIO::TypeDesc::UINT8, src)) {
      std::string err = out->geterror();
      out->close();
      return Status::error(where + ": " + err, ErrorKind::kInternal);
    }
    if (!out->close()) return Status::error(where + ": " + out->geterror(), ErrorKind::kInternal);
    out.reset();
    if (bytes.size() < 8)
      return Status::error(where + ": writer produced no data", ErrorKind::kInternal);
    count_image_encoded();
    return std::vector<uint8_t>(bytes.begin(), bytes.end());
  } catch (const std::exception& e) {
    return Status::error(where + ": " + e.what(), ErrorKind::kInternal);
  }
}

}  // namespace meshmux
