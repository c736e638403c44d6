#include "simplify/memory_fit.h"

#include <algorithm>

namespace meshmux {

SimplifyOptions fit_simplify_to_memory(SimplifyOptions o, uint64_t memory_mb) {
  if (memory_mb == 0) return o;
  const uint64_t bytes = memory_mb * 1000000;
  const uint64_t whole_faces = bytes / 2 / kWholeLoopBytesPerFace;
  o.block_above = std::min<uint64_t>(o.block_above, whole_faces);
  o.block_until = std::min<uint64_t>(o.block_until, whole_faces);
  const uint64_t positions = bytes / 4 / (kBlocksSizedFor * kBlockBytesPerPosition);
  o.block_positions =
      uint32_t(std::min<uint64_t>(o.block_positions, std::max<uint64_t>(1024, positions)));
  return o;
}

}  // namespace meshmux
