// JPEG encoding through libjpeg-turbo's TurboJPEG API (declared in image/encode.h).
#include <turbojpeg.h>

#include <memory>

#include "image/encode.h"

namespace meshmux {

Result<std::vector<uint8_t>> encode_jpeg(const Image& image, int quality, EncodeCounts* counts) {
  if (!image.decoded())
    return Status::error("jpeg: " + image.name + ": image is not decoded", ErrorKind::kInternal);
  if (quality < 1 || quality > 100)
    return Status::error("jpeg: quality " + std::to_string(quality) + " is outside 1..100",
                         ErrorKind::kInternal);
  std::unique_ptr<void, int (*)(tjhandle)> handle(tjInitCompress(), tjDestroy);
  if (!handle) return Status::error("jpeg: cannot start the encoder", ErrorKind::kInternal);
  unsigned char* buf = nullptr;
  unsigned long size = 0;
  int rc = tjCompress2(handle.get(), image.rgba.data(), image.width, image.width * 4, image.height,
                       TJPF_RGBA, &buf, &size, TJSAMP_420, quality, TJFLAG_ACCURATEDCT);
  if (rc != 0) {
    std::string why = tjGetErrorStr2(handle.get());
    if (buf) tjFree(buf);
    return Status::error("jpeg: " + image.name + ": " + why, ErrorKind::kInternal);
  }
  std::vector<uint8_t> out(buf, buf + size);
  tjFree(buf);
  count(counts, &EncodeCounts::images);
  return out;
}

}  // namespace meshmux
