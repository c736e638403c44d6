// Image decoding through OpenImageIO, from memory (IOProxy) so glTF's embedded and data-URI
// images and files on disk take the same path. Paper 000 §4.3 bakes from these pixels.
#include "image/decode.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>

#include "scene/file_io.h"

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
  std::string ext = lower_extension(name);
  if (ext == "tga") return "targa";
  return ext;
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
  if (format == "ktx2")
    return Status::error(name + ": KTX2 images are not supported", ErrorKind::kInput);

  OIIO::Filesystem::IOMemReader proxy(image.encoded.data(), image.encoded.size());
  std::string pseudo_name = "image." + (format == "targa" ? std::string("tga") : format);
  std::string tmp_path;
  try {
    auto in = OIIO::ImageInput::create(OIIO::string_view(format), false, nullptr, nullptr);
    if (!in)
      return Status::error(name + ": no decoder for " + format + " images", ErrorKind::kInput);
    bool ok;
    // Straight alpha, as PNG, TGA and WebP store it: without this OpenImageIO premultiplies
    // RGB by alpha on the way in.
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    if (in->supports("ioproxy")) {
      in->set_ioproxy(&proxy);
      OIIO::ImageSpec spec;
      ok = in->open(pseudo_name, spec, config);
    } else {
      // Readers without in-memory support get a private temporary file.
      char tmpl[] = "/tmp/meshmux-image-XXXXXX";
      int fd = mkstemp(tmpl);
      if (fd < 0)
        return Status::error(name + ": cannot create a temporary file", ErrorKind::kInternal);
      close(fd);
      tmp_path = std::string(tmpl) + "." + lower_extension(pseudo_name);
      std::rename(tmpl, tmp_path.c_str());
      Status w = write_file_atomic(tmp_path, image.encoded);
      if (!w) return Status::error(name + ": " + w.message(), ErrorKind::kInternal);
      OIIO::ImageSpec spec;
      ok = in->open(tmp_path, spec, config);
    }
    if (!ok) {
      std::string e = in->geterror();
      if (!tmp_path.empty()) unlink(tmp_path.c_str());
      return Status::error(
          name + ": cannot decode " + format + " image: " + (e.empty() ? "unreadable" : e),
          ErrorKind::kInput);
    }
    const OIIO::ImageSpec& spec = in->spec();
    int w = spec.width, h = spec.height, ch = spec.nchannels;
    if (w <= 0 || h <= 0 || ch <= 0) {
      if (!tmp_path.empty()) unlink(tmp_path.c_str());
      return Status::error(name + ": image has no pixels", ErrorKind::kInput);
    }
    if (uint64_t(w) * uint64_t(h) > max_pixels) {
      if (!tmp_path.empty()) unlink(tmp_path.c_str());
      if (over_limit) *over_limit = true;
      return Status::error(name + ": image is " + std::to_string(w) + "x" + std::to_string(h) +
                               ", over the limit of " + std::to_string(max_pixels) + " pixels",
                           ErrorKind::kInput);
    }
    std::vector<uint8_t> pixels(size_t(w) * size_t(h) * size_t(ch));
    ok = in->read_image(0, 0, 0, ch, OIIO::TypeDesc::UINT8, pixels.data());
    std::string e = ok ? "" : in->geterror();
    in->close();
    if (!tmp_path.empty()) unlink(tmp_path.c_str());
    if (!ok)
      return Status::error(name + ": cannot decode " + format + " image: " + e, ErrorKind::kInput);
    image.width = w;
    image.height = h;
    image.rgba.resize(size_t(w) * size_t(h) * 4);
    size_t n = size_t(w) * size_t(h);
    for (size_t i = 0; i < n; ++i) {
      const uint8_t* s = &pixels[i * size_t(ch)];
      uint8_t* d = &image.rgba[i * 4];
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
    if (image.mime_type.empty()) image.mime_type = "image/" + format;
    return Status::ok();
  } catch (const std::exception& ex) {
    if (!tmp_path.empty()) unlink(tmp_path.c_str());
    image.rgba.clear();
    image.width = image.height = 0;
    return Status::error(name + ": cannot decode image: " + ex.what(), ErrorKind::kInput);
  }
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
