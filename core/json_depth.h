// Bracket nesting depth of JSON text, strings (and their escapes) skipped, found without
// parsing. JSON libraries recurse per level (nlohmann's and tinygltf's parsers, copies and
// destructors), so hostile nesting (15,000 arrays in 31 kB overflowed the stack) is refused by
// its depth before any of them sees the text. O(n).
#pragma once

#include <cstddef>
#include <cstdint>

namespace meshmux {

// The deepest nesting in `text`, or the first depth past `stop_after` (the scan stops there).
int json_depth(const uint8_t* text, size_t n, int stop_after = 1 << 30);

}  // namespace meshmux
