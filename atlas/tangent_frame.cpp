// Tangent frames for normal-map baking (see tangent_frame.h). Implements three.js's derivative
// frame (r1xx normalmap_pars_fragment.glsl, getTangentFrame; "cotangent frame", Schüler 2013)
// for one triangle: with q0 = e1, q1 = e2 standing for dFdx/dFdy of the position and the uv
// differences for dFdx/dFdy of the uv (any basis of the triangle's plane with the front face's
// orientation gives the same frame up to one positive factor, which the scaling removes).
#include "atlas/tangent_frame.h"

#include <algorithm>
#include <cmath>

namespace meshmux {

TangentFrame derivative_frame(DVec3 e1, DVec3 e2, Vec2 duv1, Vec2 duv2, DVec3 n) {
  const DVec3 q1perp = cross(e2, n), q0perp = cross(n, e1);
  DVec3 t = add(mul(q1perp, duv1.x), mul(q0perp, duv2.x));
  DVec3 b = add(mul(q1perp, duv1.y), mul(q0perp, duv2.y));
  const double det = std::max(dot(t, t), dot(b, b));
  const double scale = det > 0 && std::isfinite(det) ? 1 / std::sqrt(det) : 0;
  return {mul(t, scale), mul(b, scale), n};
}

DVec3 apply_normal_map(const TangentFrame& f, DVec3 m) {
  const DVec3 v = add(add(mul(f.t, m.x), mul(f.b, -m.y)), mul(f.n, m.z));
  const DVec3 u = normalize(v);
  return length(u) > 0 ? u : f.n;
}

DVec3 encode_normal_map(const TangentFrame& f, DVec3 normal) {
  // Solve [T, −B, N] m = normal by Cramer's rule.
  const DVec3 c0 = f.t, c1 = mul(f.b, -1), c2 = f.n;
  const double det = dot(c0, cross(c1, c2));
  if (!(std::fabs(det) > 1e-12) || !std::isfinite(det)) return {0, 0, 1};
  DVec3 m{dot(normal, cross(c1, c2)) / det, dot(c0, cross(normal, c2)) / det,
          dot(c0, cross(c1, normal)) / det};
  m = normalize(m);
  if (!(length(m) > 0) || !std::isfinite(m.x + m.y + m.z)) return {0, 0, 1};
  return m;
}

}  // namespace meshmux
