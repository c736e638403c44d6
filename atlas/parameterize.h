// Chart parameterization (Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion
// of 3D models for interactive metaverses" §4.3, after Sander, Snyder, Gortler and Hoppe 2001,
// "Texture mapping progressive meshes"): a conformal start by least-squares conformal maps (Lévy
// et al. 2002; Eigen's sparse solver), then L2-stretch minimization by per-vertex line search, with
// no triangle allowed to flip. The result is scaled so its uv area equals the chart's 3D surface
// area (uv units = the mesh's length units), so sizes compare across charts.
// A flat-colour chart needs no parameterization: every corner maps to (0, 0), size (0, 0).
// Charts that are not discs (several boundary loops, or closed) are still mapped: LSCM with two
// pinned vertices handles them, possibly with overlap; `valid` reports whether any face flipped
// or overlapped after optimization, and the atlas splits such charts.
#pragma once

#include <vector>

#include "atlas/charts.h"
#include "scene/scene.h"

namespace meshmux {

struct ChartUv {
  std::vector<Vec2> corner_uv;  // 3 per chart face, in chart.faces order; min corner at (0, 0)
  Vec2 size{0, 0};              // extent of corner_uv
  double area_3d = 0;           // chart surface area (mesh units²)
  double stretch_l2 = 1;        // Sander's L2 stretch of the whole chart (1 = isometric)
  double stretch_linf = 1;      // largest singular value over faces
  bool valid = true;            // no flipped or zero-area uv triangle
};

struct ParameterizeOptions {
  int stretch_iterations = 10;  // rounds of per-vertex stretch optimization (0: LSCM only)
};

ChartUv parameterize_chart(const Scene& scene, const Chart& chart,
                           const ParameterizeOptions& options = {});

}  // namespace meshmux
