// The split-sum environment BRDF table (see dfg_lut.h). Reference: Karis 2013, "Real Shading in
// Unreal Engine 4" (ImportanceSampleGGX and IntegrateBRDF); the visibility term is Heitz's
// height-correlated Smith G2 in the form V = G2 / (4 N·L N·V) (Lagarde and de Rousiers 2014,
// "Moving Frostbite to PBR", listing 2), roughness α = perceptual roughness².
#include "multiplex/dfg_lut.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/parallel.h"

namespace meshmux {
namespace {

double radical_inverse(uint32_t bits) {
  bits = (bits << 16u) | (bits >> 16u);
  bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
  bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
  bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
  bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
  return double(bits) * 2.3283064365386963e-10;
}

double visibility(double alpha, double nl, double nv) {
  const double a2 = alpha * alpha;
  const double gv = nl * std::sqrt(a2 + (1 - a2) * nv * nv);
  const double gl = nv * std::sqrt(a2 + (1 - a2) * nl * nl);
  return 0.5 / std::max(gv + gl, 1e-12);
}

}  // namespace

std::vector<float> dfg_lut(int samples) {
  const int n = kDfgLutSize;
  samples = std::max(1, samples);
  std::vector<float> out(size_t(n) * n * 2);
  const double pi = 3.14159265358979323846;
  // The Hammersley points' cos φ and u2 are the same for every texel: computed once.
  std::vector<double> cos_phi(static_cast<size_t>(samples)), u2s(static_cast<size_t>(samples));
  for (int k = 0; k < samples; ++k) {
    cos_phi[size_t(k)] = std::cos(2 * pi * ((k + 0.5) / samples));
    u2s[size_t(k)] = radical_inverse(uint32_t(k));
  }
  // Rows on every core: each writes its own texels.
  parallel_chunks(size_t(n), 1, [&](size_t row_begin, size_t row_end) {
    for (int j = int(row_begin); j < int(row_end); ++j)
      for (int i = 0; i < n; ++i) {
        const double roughness = (i + 0.5) / n, nv = (j + 0.5) / n;
        const double alpha = roughness * roughness, a2 = alpha * alpha;
        const double vx = std::sqrt(1 - nv * nv), vz = nv;  // view direction, N = +z
        double scale = 0, bias = 0;
        for (int k = 0; k < samples; ++k) {
          const double u2 = u2s[size_t(k)];
          const double cos_t = std::sqrt((1 - u2) / (1 + (a2 - 1) * u2));
          const double sin_t = std::sqrt(std::max(0.0, 1 - cos_t * cos_t));
          const double hx = sin_t * cos_phi[size_t(k)], hz = cos_t;  // H's y does not enter
          const double vh = vx * hx + vz * hz;
          const double lz = 2 * vh * hz - vz;  // L = 2 (V·H) H − V, its z is N·L
          const double nl = std::clamp(lz, 0.0, 1.0), nh = std::clamp(hz, 0.0, 1.0);
          if (nl <= 0 || nh <= 0) continue;
          const double vh_c = std::clamp(vh, 0.0, 1.0);
          // f · N·L / pdf with pdf = D · N·H / (4 V·H): the D cancels.
          const double g_vis = 4 * visibility(alpha, nl, nv) * nl * vh_c / nh;
          const double fc = std::pow(1 - vh_c, 5);
          scale += (1 - fc) * g_vis;
          bias += fc * g_vis;
        }
        out[(size_t(j) * n + size_t(i)) * 2 + 0] = float(scale / samples);
        out[(size_t(j) * n + size_t(i)) * 2 + 1] = float(bias / samples);
      }
  });
  return out;
}

}  // namespace meshmux
