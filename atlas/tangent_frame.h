// Tangent frames for baking normal maps into the atlas. glTF viewers without a
// TANGENT attribute build the frame from the uv derivatives; three.js does so per pixel
// (normalmap_pars_fragment.glsl getTangentFrame: T and B are the surface gradients of u and v
// projected on the shading normal's plane, both scaled by one factor so the longer is unit;
// GLTFLoader then negates the map's y, as glTF's +y points up the image, against +v). For a
// triangle those derivatives are constant, so the frame is exact from its edges and uvs. The
// atlas stores, per texel, the map value that gives the source's shaded normal in the atlas's
// own frame: the same light response from a different parameterization.
#pragma once

#include "scene/dvec3.h"
#include "scene/math.h"

namespace meshmux {

struct TangentFrame {
  DVec3 t, b, n;  // three.js's tbn columns: T and B scaled as it scales them, N unit
};

// The frame of a triangle with edges e1 = p1 − p0, e2 = p2 − p0 (counter-clockwise seen from
// the front) and uv differences duv1 = uv1 − uv0, duv2 = uv2 − uv0, at a point whose unit
// shading normal is `n`. T = B = 0 when the uvs are degenerate.
TangentFrame derivative_frame(DVec3 e1, DVec3 e2, Vec2 duv1, Vec2 duv2, DVec3 n);

// The unit normal a map value m (2 · texel − 1, normalScale applied) gives in the frame, as
// three.js shades a glTF model: normalize(T · m.x − B · m.y + N · m.z). N when the result is 0.
DVec3 apply_normal_map(const TangentFrame& f, DVec3 m);

// The inverse: the unit map value m (z ≥ 0 unless the normal faces away) with
// apply_normal_map(f, m) = `normal`; (0, 0, 1) when the frame is singular.
DVec3 encode_normal_map(const TangentFrame& f, DVec3 normal);

}  // namespace meshmux
