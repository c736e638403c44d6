// Colour math shared by every stage (see color.h).
//
// References implemented:
// - sRGB transfer function: IEC 61966-2-1:1999 (the exact piecewise curve, 0.04045 / 12.92 /
//   ((c + 0.055) / 1.055)^2.4, and its inverse with 0.0031308).
// - Linear sRGB → CIE XYZ: the IEC 61966-2-1 primaries with the D65 white point (the usual
//   matrix 0.4124564 0.3575761 0.1804375 / 0.2126729 0.7151522 0.0721750 / 0.0193339 0.1191920
//   0.9503041); the reference white is the matrix's image of (1, 1, 1), so white maps to a* = b* =
//   0 exactly.
// - XYZ → L*a*b*: CIE 15:2004 (f(t) = t^(1/3) above (6/29)^3, linear below).
// - CIEDE2000: G. Sharma, W. Wu, E. N. Dalal, "The CIEDE2000 color-difference formula:
//   implementation notes, supplementary test data, and mathematical observations", Color Research
//   and Application 30(1), 2005 — equations (1)–(22), with kL = kC = kH = 1, including the notes
//   on hue when a chroma is zero and on the mean hue across the 0°/360° wrap.
#include "image/color.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace meshmux {
namespace {

// The IEC 61966-2-1 decoding curve, sRGB-encoded value in [0, 1] → linear.
double decode_exact(double c) {
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

std::array<float, 256> make_decode_table() {
  std::array<float, 256> t{};
  for (int i = 0; i < 256; ++i) {
    t[size_t(i)] = float(decode_exact(i / 255.0));
  }
  return t;
}

const std::array<float, 256>& decode_table() {
  static const std::array<float, 256> table = make_decode_table();
  return table;
}

// Encoding by table: byte k + 1 begins where the exact encoding curve (12.92 v below 0.0031308,
// 1.055 v^(1/2.4) − 0.055 above) reaches (k + ½) / 255, i.e. at linear decode_exact((k + ½) / 255)
// (the two curves are inverses). Equal to rounding the exact encoding, without a pow per call.
std::array<double, 255> make_encode_thresholds() {
  std::array<double, 255> t{};
  for (int k = 0; k < 255; ++k) t[size_t(k)] = decode_exact((k + 0.5) / 255.0);
  return t;
}

const std::array<double, 255>& encode_thresholds() {
  static const std::array<double, 255> table = make_encode_thresholds();
  return table;
}

// Where to start searching the thresholds for a value in [j / kEncodeBuckets, (j + 1) / ...):
// the byte of the bucket's lower end. Thresholds are at least 1 / (12.92 · 255) ≈ 3e-4 apart,
// more than a bucket, so at most one step remains.
constexpr int kEncodeBuckets = 4096;
std::array<uint8_t, kEncodeBuckets + 1> make_encode_start() {
  std::array<uint8_t, kEncodeBuckets + 1> s{};
  const auto& t = encode_thresholds();
  for (int j = 0; j <= kEncodeBuckets; ++j)
    s[size_t(j)] =
        uint8_t(std::upper_bound(t.begin(), t.end(), double(j) / kEncodeBuckets) - t.begin());
  return s;
}

const std::array<uint8_t, kEncodeBuckets + 1>& encode_start() {
  static const std::array<uint8_t, kEncodeBuckets + 1> table = make_encode_start();
  return table;
}

constexpr double kPi = 3.14159265358979323846;

constexpr double kM[3][3] = {{0.4124564, 0.3575761, 0.1804375},
                             {0.2126729, 0.7151522, 0.0721750},
                             {0.0193339, 0.1191920, 0.9503041}};

double lab_f(double t) {
  constexpr double d = 6.0 / 29.0;
  return t > d * d * d ? std::cbrt(t) : t / (3 * d * d) + 4.0 / 29.0;
}

double deg(double rad) { return rad * 180.0 / kPi; }
double rad(double deg) { return deg * kPi / 180.0; }

}  // namespace

double srgb_decode(double c) {
  if (!(c > 0)) return 0;  // also NaN
  return decode_exact(std::min(c, 1.0));
}

float srgb_to_linear(uint8_t v) { return decode_table()[v]; }

uint8_t linear_to_srgb(float v) {
  if (!(v > 0)) return 0;  // also NaN
  if (v >= 1) return 255;
  const auto& t = encode_thresholds();
  const double d = v;
  int b = encode_start()[size_t(d * kEncodeBuckets)];
  while (b < 255 && d >= t[size_t(b)]) ++b;
  return uint8_t(b);
}

Lab linear_rgb_to_lab(double r, double g, double b) {
  double xyz[3], white[3];
  for (int i = 0; i < 3; ++i) {
    xyz[i] = kM[i][0] * r + kM[i][1] * g + kM[i][2] * b;
    white[i] = kM[i][0] + kM[i][1] + kM[i][2];
  }
  double fx = lab_f(xyz[0] / white[0]);
  double fy = lab_f(xyz[1] / white[1]);
  double fz = lab_f(xyz[2] / white[2]);
  return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

double ciede2000(const Lab& x, const Lab& y) {
  // (2)–(7): a' from the chroma-dependent factor G, then C' and h' (degrees in [0, 360)).
  const double c1 = std::hypot(x.a, x.b), c2 = std::hypot(y.a, y.b);
  const double cbar = (c1 + c2) / 2;
  const double cbar7 = std::pow(cbar, 7);
  const double p25_7 = 6103515625.0;  // 25^7
  const double g = 0.5 * (1 - std::sqrt(cbar7 / (cbar7 + p25_7)));
  const double a1p = (1 + g) * x.a, a2p = (1 + g) * y.a;
  const double c1p = std::hypot(a1p, x.b), c2p = std::hypot(a2p, y.b);
  auto hue = [](double b, double ap) {
    if (b == 0 && ap == 0) return 0.0;
    double h = deg(std::atan2(b, ap));
    return h < 0 ? h + 360.0 : h;
  };
  const double h1p = hue(x.b, a1p), h2p = hue(y.b, a2p);

  // (8)–(11): differences.
  const double dLp = y.L - x.L;
  const double dCp = c2p - c1p;
  const double cprod = c1p * c2p;
  double dhp = 0;
  if (cprod != 0) {
    dhp = h2p - h1p;
    if (dhp > 180)
      dhp -= 360;
    else if (dhp < -180)
      dhp += 360;
  }
  const double dHp = 2 * std::sqrt(cprod) * std::sin(rad(dhp) / 2);

  // (12)–(22): means, weighting functions and the rotation term.
  const double Lbarp = (x.L + y.L) / 2;
  const double Cbarp = (c1p + c2p) / 2;
  double hbarp;
  if (cprod == 0) {
    hbarp = h1p + h2p;
  } else if (std::fabs(h1p - h2p) <= 180) {
    hbarp = (h1p + h2p) / 2;
  } else if (h1p + h2p < 360) {
    hbarp = (h1p + h2p + 360) / 2;
  } else {
    hbarp = (h1p + h2p - 360) / 2;
  }
  const double t = 1 - 0.17 * std::cos(rad(hbarp - 30)) + 0.24 * std::cos(rad(2 * hbarp)) +
                   0.32 * std::cos(rad(3 * hbarp + 6)) - 0.20 * std::cos(rad(4 * hbarp - 63));
  const double dtheta = 30 * std::exp(-((hbarp - 275) / 25) * ((hbarp - 275) / 25));
  const double cbarp7 = std::pow(Cbarp, 7);
  const double rc = 2 * std::sqrt(cbarp7 / (cbarp7 + p25_7));
  const double l50 = (Lbarp - 50) * (Lbarp - 50);
  const double sl = 1 + 0.015 * l50 / std::sqrt(20 + l50);
  const double sc = 1 + 0.045 * Cbarp;
  const double sh = 1 + 0.015 * Cbarp * t;
  const double rt = -std::sin(rad(2 * dtheta)) * rc;

  const double tl = dLp / sl, tc = dCp / sc, th = dHp / sh;
  const double sum = tl * tl + tc * tc + th * th + rt * tc * th;
  return std::sqrt(sum > 0 ? sum : 0);
}

}  // namespace meshmux
