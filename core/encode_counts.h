// What a conversion encodes, counted where it is encoded: image files (PNG or JPEG) and
// vertex-split parts. An observer the caller hands in (pipeline/convert.h ConvertOptions::counts)
// to check that each thing is encoded once; nothing is counted where none is given.
// Thread-safe: the stages encode on every core.
#pragma once

#include <atomic>
#include <cstdint>

namespace meshmux {

struct EncodeCounts {
  std::atomic<uint64_t> images{0};      // PNG or JPEG files written (measures are not counted)
  std::atomic<uint64_t> mesh_parts{0};  // vertex-split parts encoded (stream/mesh_stream.h)
};

// Adds one to `*field` of `counts` when there is an observer.
inline void count(EncodeCounts* counts, std::atomic<uint64_t> EncodeCounts::*field) {
  if (counts) ++(counts->*field);
}

}  // namespace meshmux
