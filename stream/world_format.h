// world.json, the file that places many converted packages in one scene (streamed under one
// budget by the web library's MeshmuxWorld), and the layout file `meshmux batch --layout` reads:
// their spec, limits, writer and validating readers, beside the package format (stream/format.h).
// `meshmux batch` writes world.json (batch/summary.cpp, placed by batch/world.h); the browser reads
// it with viewers/web/world_plan.js (validateWorld: the same rules and limits, checked against
// these by tests/stream/format_test.cpp); `meshmux info world.json` reads it with parse_world.
//
// world.json (version kWorldVersion):
//   {"meshmux_world": 1,
//    "packages": [{"name": "Duck", "url": "Duck/model.mmxp",
//                  "bounds": [minx, miny, minz, maxx, maxy, maxz],   // world box, model units
//                  "bytes": 34149,                                   // the package's size
//                  "head_bytes": 18602}, ...],   // optional: its header, table and base
//    "placements": [{"package": 0, "matrix": [16 numbers, column-major]}, ...]}
// A package may be placed several times (and need not be placed). URLs are relative to the
// world file's folder and stay inside it: no scheme, no leading '/', no '\', no ".." segment
// (also percent-encoded, any case), no query, fragment, space or control character
// (WorldLimits::allow_external_urls lifts that for trusted worlds).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/status.h"

namespace meshmux {

struct WorldPackage {
  std::string name;                // for messages and the page (≤ 256 bytes)
  std::string url;                 // relative to the world's folder
  std::array<double, 6> bounds{};  // world-space box of the package's full detail
  uint64_t bytes = 0;              // the package file's size (0: unknown)
  uint64_t head_bytes = 0;  // bytes from the file's start through the end of its base (header,
                            // table, base): one range request shows the package (0: unknown)
};

struct WorldPlacement {
  uint32_t package = 0;             // index into World::packages
  std::array<double, 16> matrix{};  // column-major affine transform, world from package
};

struct World {
  std::vector<WorldPackage> packages;
  std::vector<WorldPlacement> placements;
};

constexpr int kWorldVersion = 1;                // "meshmux_world"
constexpr size_t kWorldMaxBytes = 16u << 20;    // a world or layout file's size
constexpr size_t kWorldMaxPackages = 10000;     // entries of "packages"
constexpr size_t kWorldMaxPlacements = 100000;  // entries of "placements"
constexpr double kWorldMaxCoordinate = 1e15;  // beyond this a float32 GPU transform is meaningless

struct WorldLimits {
  size_t max_bytes = kWorldMaxBytes;            // the file's size
  size_t max_packages = kWorldMaxPackages;      // entries of "packages"
  size_t max_placements = kWorldMaxPlacements;  // entries of "placements"
  bool allow_external_urls = false;  // URLs outside the world's folder (trusted worlds only)
};

// The identity, as a column-major 4x4.
std::array<double, 16> identity_matrix();

// Whether `url` stays inside the world's folder (see the header comment). "" → false.
bool world_url_is_inside(const std::string& url);

// world.json's text for `world` (deterministic: the same world gives the same bytes).
std::string world_json(const World& world);

// Parses and validates world.json text. Errors (kInput) name `file` and the element:
// "world.json: packages[3].url \"../x.mmxp\" leaves the world's folder".
Result<World> parse_world(const std::string& text, const std::string& file,
                          const WorldLimits& limits = {});

// Whether `m` is an affine placement (last row 0 0 0 1, an invertible 3x3 part).
bool world_matrix_is_affine(const std::array<double, 16>& m);

// A layout file: where named packages go. JSON: {"placements": [{"name": "Duck", and either
// "matrix": [16 numbers, column-major] or any of "translation": [x, y, z], "scale": s or
// [sx, sy, sz], "rotation_y_degrees": r (applied scale, then rotation, then translation)}]}.
// A name may be placed several times.
struct LayoutEntry {
  std::string name;
  std::array<double, 16> matrix{};
};

// Reads and validates a layout file (limits as for worlds). Errors (kInput) name the file and
// the entry.
Result<std::vector<LayoutEntry>> read_layout(const std::string& path,
                                             const WorldLimits& limits = {});

}  // namespace meshmux
