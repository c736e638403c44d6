// Colour math shared by every stage that touches pixels.
//
// sRGB transfer (IEC 61966-2-1): byte ↔ linear, exact to the byte.
//
// Colour difference: CIEDE2000 (Sharma, Wu and Dalal 2005, "The CIEDE2000 color-difference
// formula: implementation notes") between two linear-RGB colours, through CIE L*a*b* (D65).
// Used by the atlas fidelity test and, later, the multiplexer's distortion measure.
#pragma once

#include <cstdint>

#include "scene/math.h"

namespace meshmux {

// sRGB-encoded byte → linear in [0, 1] (table lookup).
float srgb_to_linear(uint8_t v);
// The exact IEC 61966-2-1 decoding curve on [0, 1] (sRGB-encoded value → linear; clamped,
// NaN → 0): for colours given as display values (COLLADA's, for one).
double srgb_decode(double c);
// Linear → sRGB byte, rounding the exact encoding (clamped; NaN → 0). O(1), no pow.
uint8_t linear_to_srgb(float v);

struct Lab {
  double L = 0, a = 0, b = 0;
};

Lab linear_rgb_to_lab(double r, double g, double b);
double ciede2000(const Lab& x, const Lab& y);

}  // namespace meshmux
