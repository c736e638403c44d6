// The block build's parameters for a memory cap: `--max-memory` is honoured by choosing when a
// mesh is built as blocks, how large a block is and how far the block levels go, not by
// refusing (the block hierarchy after Ponchio and Dellepiane, "Multiresolution and fast
// decompression for optimal web-based rendering" (Nexus), §3: blocks simplified independently
// in bounded memory).
#pragma once

#include <cstdint>

#include "simplify/simplify.h"

namespace meshmux {

// Measured working sets (bench/scale.sh, the scan-like meshes): the whole-mesh loop holds about
// this many bytes per face it simplifies (a 4M scan took 2.0 GB that way), and a block being
// simplified about this many per position (two faces each).
inline constexpr uint64_t kWholeLoopBytesPerFace = 500;
inline constexpr uint64_t kBlockBytesPerPosition = 1000;
// The blocks the cap's quarter is sized for. Not the thread count: the output must not depend on
// it (the same input and options give the same bytes on any machine).
inline constexpr uint64_t kBlocksSizedFor = 2;

// `o` fitted to a cap of `memory_mb` megabytes (0: no cap, `o` as it is): half the cap for the
// whole-mesh loop (meshes with more faces than fit there take the block levels first, and the
// block levels run until that many faces are left) and a quarter for kBlocksSizedFor blocks
// (positions per block, at least 1024). Never raises a parameter: a cap only makes blocks come
// sooner and smaller. O(1).
SimplifyOptions fit_simplify_to_memory(SimplifyOptions o, uint64_t memory_mb);

}  // namespace meshmux
