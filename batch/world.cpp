// Placing a batch's packages in a world (see world.h).
#include "batch/world.h"

#include <algorithm>
#include <cmath>

namespace meshmux {

World grid_world(std::vector<WorldPackage> packages) {
  World world;
  const size_t n = packages.size();
  const size_t columns = std::max<size_t>(1, size_t(std::ceil(std::sqrt(double(n)))));
  constexpr double kPitch = 1.5;
  for (size_t i = 0; i < n; ++i) {
    const std::array<double, 6>& b = packages[i].bounds;
    const double dx = b[3] - b[0], dy = b[4] - b[1], dz = b[5] - b[2];
    const double diagonal = std::sqrt(dx * dx + dy * dy + dz * dz);
    const double s = diagonal > 0 && std::isfinite(diagonal) && 1 / diagonal < kWorldMaxCoordinate
                         ? 1 / diagonal
                         : 1.0;
    const double cx = 0.5 * (b[0] + b[3]), cz = 0.5 * (b[2] + b[5]);
    const double x = double(i % columns) * kPitch, z = double(i / columns) * kPitch;
    std::array<double, 16> m = identity_matrix();
    m[0] = m[5] = m[10] = s;
    m[12] = x - s * cx, m[13] = std::isfinite(b[1]) ? -s * b[1] : 0.0, m[14] = z - s * cz;
    world.placements.push_back({uint32_t(i), m});
  }
  world.packages = std::move(packages);
  return world;
}

World apply_layout(std::vector<WorldPackage> packages, const std::vector<LayoutEntry>& layout,
                   std::vector<std::string>* missing) {
  World world;
  for (const LayoutEntry& e : layout) {
    auto it = std::find_if(packages.begin(), packages.end(),
                           [&](const WorldPackage& p) { return p.name == e.name; });
    if (it == packages.end()) {
      if (missing && std::find(missing->begin(), missing->end(), e.name) == missing->end())
        missing->push_back(e.name);
      continue;
    }
    world.placements.push_back({uint32_t(it - packages.begin()), e.matrix});
  }
  world.packages = std::move(packages);
  return world;
}

}  // namespace meshmux
