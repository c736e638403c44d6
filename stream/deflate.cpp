#include "stream/deflate.h"

#include <zlib.h>

#include <string>

namespace meshmux {

std::vector<uint8_t> deflate_bytes(const std::vector<uint8_t>& in) {
  uLongf size = compressBound(uLong(in.size()));
  std::vector<uint8_t> out(size);
  if (compress2(out.data(), &size, in.data(), uLong(in.size()), 9) != Z_OK) return {};
  out.resize(size);
  return out;
}

Result<std::vector<uint8_t>> inflate_bytes(const uint8_t* data, size_t size, uint64_t limit) {
  z_stream z{};
  if (inflateInit(&z) != Z_OK)
    return Status::error("zlib: cannot initialize", ErrorKind::kInternal);
  std::vector<uint8_t> out;
  z.next_in = const_cast<Bytef*>(data);
  z.avail_in = uInt(size);
  int r = Z_OK;
  uint8_t buffer[16384];
  while (r == Z_OK) {
    z.next_out = buffer;
    z.avail_out = sizeof buffer;
    r = inflate(&z, Z_NO_FLUSH);
    if (r != Z_OK && r != Z_STREAM_END) break;
    size_t got = sizeof buffer - z.avail_out;
    if (out.size() + got > limit) {
      inflateEnd(&z);
      return Status::error("inflates past its limit of " + std::to_string(limit) + " bytes",
                           ErrorKind::kInput);
    }
    out.insert(out.end(), buffer, buffer + got);
    if (r == Z_OK && got == 0 && z.avail_in == 0) break;  // truncated
  }
  bool done = r == Z_STREAM_END && z.avail_in == 0;
  inflateEnd(&z);
  if (!done) return Status::error("not a complete zlib stream", ErrorKind::kInput);
  return out;
}

}  // namespace meshmux
