// Where `meshmux batch` places its streamed conversions in world.json (the format:
// stream/world_format.h): on a grid, or where a layout file puts them.
#pragma once

#include <string>
#include <vector>

#include "stream/world_format.h"

namespace meshmux {

// The packages on a square-ish grid in list order: each scaled so its box diagonal is 1,
// centred on its cell in x and z and standing on y = 0, cells 1.5 apart. A package whose box is
// empty or not finite keeps unit scale. O(packages).
World grid_world(std::vector<WorldPackage> packages);

// The world of `packages` placed as `layout` says (in layout order). Names the layout gives
// that no package has are returned in *missing (not placed); packages the layout does not
// name are not placed.
World apply_layout(std::vector<WorldPackage> packages, const std::vector<LayoutEntry>& layout,
                   std::vector<std::string>* missing);

}  // namespace meshmux
