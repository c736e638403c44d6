// Viewpoints on a viewing sphere (Yang, Shen and Kuo, "Progressive coding of 3D textured graphic
// model via joint mesh-texture optimization" §3): a tetrahedron whose triangles are subdivided
// layer by layer, each new midpoint pushed out to the sphere; the camera sits on the sphere looking
// at the model's centre, at a distance where the model's bounding sphere fills `fill` of the
// viewport's smaller side. Also Yang, Shen and Kuo's interpolation: the rate-distortion table of an
// arbitrary view is the barycentric blend of the tables at the three vertices of the viewing-mesh
// triangle its direction passes through.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "multiplex/render.h"
#include "scene/scene.h"

namespace meshmux {

struct ViewingSphere {
  std::vector<Vec3> directions;                    // unit vectors from the centre to each view
  std::vector<std::array<uint32_t, 3>> triangles;  // the viewing mesh, outward winding
};

// layers = 0: the 4 tetrahedron vertices; each further layer splits every triangle in four
// (4, 10, 34, 130, ... directions). Deterministic.
ViewingSphere viewing_sphere(int layers);

// The framing the multiplexer measures with; written into the package table ("view"), which
// the web viewer reads, so the two never disagree.
struct ViewOptions {
  float fov_y_degrees = 45;       // vertical field of view
  float fill = 0.8f;              // fraction of the viewport's smaller side the bounding
                                  // sphere spans
  Vec3 direction{1, 0.6f, 1.4f};  // the first view: from the centre towards the eye
  float clip_margin = 1.5f;       // near/far at distance ∓ clip_margin × bounding radius
};

// A camera on direction `d` (unit) looking at the centre of `bounds`, framed as ViewOptions
// says for a viewport of aspect width/height.
Camera camera_for(Vec3 d, const Bounds& bounds, float aspect, const ViewOptions& options = {});

// Barycentric weights of direction `d` over the viewing-mesh triangle it passes through: (triangle
// index, weights summing to 1). Yang, Shen and Kuo's interpolation blends the three vertices'
// tables with these weights.
std::pair<uint32_t, std::array<float, 3>> locate_view(const ViewingSphere& sphere, Vec3 d);

// Blends per-vertex tables (one value per table entry) for direction d.
std::vector<double> interpolate_table(const ViewingSphere& sphere,
                                      const std::vector<std::vector<double>>& tables, Vec3 d);

}  // namespace meshmux
