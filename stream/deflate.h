// zlib (RFC 1950) around the package's JSON table and base .glb: browsers inflate them with
// DecompressionStream("deflate"). zlib does the work; this only bounds what inflating may
// produce, so a small hostile package cannot expand into gigabytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/status.h"

namespace meshmux {

// zlib-compresses `in` at level 9. O(n). Empty on a zlib failure (it has none for level 9).
std::vector<uint8_t> deflate_bytes(const std::vector<uint8_t>& in);
// Inflates `size` bytes at `data`, producing at most `limit` bytes. Errors (kInput): past the
// limit ("inflates past its limit of N bytes"), or not one complete zlib stream (truncated,
// corrupt, or followed by other bytes). O(output).
Result<std::vector<uint8_t>> inflate_bytes(const uint8_t* data, size_t size, uint64_t limit);

}  // namespace meshmux
