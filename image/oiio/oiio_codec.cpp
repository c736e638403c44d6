// OpenImageIO decoding from memory (IOProxy), behind the C interface of oiio_codec.h. Built as
// its own shared module so that only the processes that meet such an image load OpenImageIO.
#include "image/oiio/oiio_codec.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace {

void set_error(char* error, size_t error_size, const std::string& text) {
  if (error && error_size > 0) std::snprintf(error, error_size, "%s", text.c_str());
}

// Writes `size` bytes to a private temporary file named like `pseudo_name` (readers without
// in-memory support open files by name). Empty on failure.
std::string temporary_copy(const uint8_t* data, size_t size, const std::string& extension) {
  char tmpl[] = "/tmp/meshmux-image-XXXXXX";
  int fd = mkstemp(tmpl);
  if (fd < 0) return "";
  bool ok = true;
  for (size_t at = 0; at < size && ok;) {
    ssize_t n = write(fd, data + at, size - at);
    ok = n > 0;
    if (ok) at += size_t(n);
  }
  close(fd);
  std::string path = std::string(tmpl) + "." + extension;
  if (!ok || std::rename(tmpl, path.c_str()) != 0) {
    unlink(tmpl);
    return "";
  }
  return path;
}

}  // namespace

extern "C" int meshmux_oiio_decode(const uint8_t* data, size_t size, const char* format_c,
                                   uint64_t max_pixels, MeshmuxOiioImage* out, char* error,
                                   size_t error_size) {
  out->width = out->height = 0;
  out->rgba = nullptr;
  const std::string format = format_c;
  OIIO::Filesystem::IOMemReader proxy(const_cast<uint8_t*>(data), size);
  const std::string extension = format == "targa" ? std::string("tga") : format;
  std::string tmp_path;
  auto fail = [&](int code, const std::string& text) {
    if (!tmp_path.empty()) unlink(tmp_path.c_str());
    set_error(error, error_size, text);
    return code;
  };
  try {
    auto in = OIIO::ImageInput::create(OIIO::string_view(format), false, nullptr, nullptr);
    if (!in) return fail(kMeshmuxOiioError, "no decoder for " + format + " images");
    bool ok;
    // Straight alpha, as PNG, TGA and WebP store it: without this OpenImageIO premultiplies
    // RGB by alpha on the way in.
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    OIIO::ImageSpec opened;
    if (in->supports("ioproxy")) {
      in->set_ioproxy(&proxy);
      ok = in->open("image." + extension, opened, config);
    } else {
      tmp_path = temporary_copy(data, size, extension);
      if (tmp_path.empty()) return fail(kMeshmuxOiioError, "cannot create a temporary file");
      ok = in->open(tmp_path, opened, config);
    }
    if (!ok) {
      std::string e = in->geterror();
      return fail(kMeshmuxOiioError,
                  "cannot decode " + format + " image: " + (e.empty() ? "unreadable" : e));
    }
    const OIIO::ImageSpec& spec = in->spec();
    int w = spec.width, h = spec.height, ch = spec.nchannels;
    if (w <= 0 || h <= 0 || ch <= 0) return fail(kMeshmuxOiioError, "image has no pixels");
    if (uint64_t(w) * uint64_t(h) > max_pixels)
      return fail(kMeshmuxOiioOverLimit, "image is " + std::to_string(w) + "x" + std::to_string(h) +
                                             ", over the limit of " + std::to_string(max_pixels) +
                                             " pixels");
    std::vector<uint8_t> pixels(size_t(w) * size_t(h) * size_t(ch));
    ok = in->read_image(0, 0, 0, ch, OIIO::TypeDesc::UINT8, pixels.data());
    std::string e = ok ? "" : in->geterror();
    in->close();
    if (!ok) return fail(kMeshmuxOiioError, "cannot decode " + format + " image: " + e);
    if (!tmp_path.empty()) unlink(tmp_path.c_str());
    const size_t n = size_t(w) * size_t(h);
    auto* rgba = static_cast<uint8_t*>(std::malloc(n * 4));
    if (!rgba) return fail(kMeshmuxOiioError, "out of memory for the pixels");
    for (size_t i = 0; i < n; ++i) {
      const uint8_t* s = &pixels[i * size_t(ch)];
      uint8_t* d = &rgba[i * 4];
      if (ch == 1) {
        d[0] = d[1] = d[2] = s[0];
        d[3] = 255;
      } else if (ch == 2) {
        d[0] = d[1] = d[2] = s[0];
        d[3] = s[1];
      } else {
        d[0] = s[0];
        d[1] = s[1];
        d[2] = s[2];
        d[3] = ch >= 4 ? s[3] : 255;
      }
    }
    out->width = w;
    out->height = h;
    out->rgba = rgba;
    return kMeshmuxOiioOk;
  } catch (const std::exception& ex) {
    return fail(kMeshmuxOiioError, std::string("cannot decode image: ") + ex.what());
  } catch (...) {
    return fail(kMeshmuxOiioError, "cannot decode image");
  }
}

extern "C" void meshmux_oiio_free(uint8_t* rgba) { std::free(rgba); }
