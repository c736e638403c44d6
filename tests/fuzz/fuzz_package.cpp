// libFuzzer target: the stream package reader (exporters/package_read) on arbitrary bytes,
// and, when the table reads, every base-index and mesh-part decoder it leads to (the codecs
// that run on bytes a server sends).
#include <cstdint>
#include <vector>

#include "exporters/package.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> bytes(data, data + size);
  auto package = meshmux::read_package(bytes);
  if (!package.ok()) return 0;
  for (size_t m = 0; m < package->meshes.size(); ++m)
    (void)meshmux::decode_base_indices(bytes, *package, m);
  for (const meshmux::PackageChunk& chunk : package->chunks)
    for (size_t p = 0; p < chunk.parts.size(); ++p)
      (void)meshmux::decode_part(bytes, *package, chunk, p);
  return 0;
}
