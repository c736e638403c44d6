// Colour difference: CIEDE2000 (Sharma, Wu and Dalal 2005, "The CIEDE2000 color-difference
// formula: implementation notes") between two linear-RGB colours, through CIE L*a*b* (D65).
// Used by the atlas fidelity test and, later, the multiplexer's distortion measure.
#pragma once

#include "scene/math.h"

namespace meshmux {

struct Lab {
  double L = 0, a = 0, b = 0;
};

Lab linear_rgb_to_lab(double r, double g, double b);
double ciede2000(const Lab& x, const Lab& y);

}  // namespace meshmux
