// libFuzzer target: the stream package reader (stream/package_read) on arbitrary bytes,
// and, when the table reads, every mesh-part decoder it leads to (the codecs
// that run on bytes a server sends).
#include <cstdint>
#include <vector>

#include "stream/package.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> bytes(data, data + size);
  auto package = meshmux::read_package(bytes);
  if (!package.ok()) return 0;
  // Base vertices and faces come from the base .glb (at most one per byte of the file); zeros
  // stand in (degenerate faces), so every part decodes against a state of the table's sizes.
  std::vector<meshmux::Result<meshmux::VsplitMesh>> clients;
  for (size_t m = 0; m < package->meshes.size(); ++m) {
    const meshmux::PackageMesh& pm = package->meshes[m];
    if (pm.base_vertices > size || pm.base_faces > size) {
      clients.push_back(meshmux::Status::error("base", meshmux::ErrorKind::kInput));
      continue;
    }
    clients.push_back(meshmux::decode_base(*package, m,
                                           std::vector<meshmux::QuantizedVertex>(pm.base_vertices),
                                           std::vector<uint32_t>(size_t(pm.base_faces) * 3, 0)));
  }
  for (const meshmux::PackageChunk& chunk : package->chunks)
    for (size_t p = 0; p < chunk.parts.size(); ++p) {
      uint32_t m = chunk.parts[p].mesh;
      if (m >= clients.size() || !clients[m].ok()) continue;
      meshmux::Status s = meshmux::decode_part(bytes, *package, chunk, p, *clients[m]);
      if (!s.is_ok()) clients[m] = s;
    }
  return 0;
}
