#include "station/render/cecum_landmarks.h"

#include <algorithm>
#include <cmath>

namespace ves::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

double Gauss(double x, double sigma) { return std::exp(-0.5 * (x / sigma) * (x / sigma)); }

// 1 on |x| well inside `half`, e^-1 at |x| = half, falling steeply beyond.
double Plateau(double x, double half) {
  const double s = (x / half) * (x / half);
  return std::exp(-s * s);
}

// The angle's distance to the nearest taenia (cos(3 angle) = -1: pi/3, pi, 5pi/3).
double FromTaenia(double angle_rad) {
  const double third = 2.0 * kPi / 3.0;
  double a = std::fmod(angle_rad - kPi / 3.0, third);
  if (a < 0.0) a += third;
  return std::min(a, third - a);
}

// The orifice and the fold, in the dome's radius share.
constexpr double kOrificeRadius = 0.14;     // the pit's Gaussian radius, share of the dome's
constexpr double kOrificeDepth = 0.30;      // how deep the pit goes out of the lumen
constexpr double kOrificeRimHeight = 0.10;  // its crescent rim, into the lumen
constexpr double kFoldHeight = 0.22;        // the ridges' height at mid-dome
constexpr double kFoldHalfWidth_rad = 0.13; // the ridges' Gaussian sigma around the pole

}  // namespace

double IleocaecalValveFactor(double from_pole_m, double angle_from_medial_rad) {
  const double a = std::remainder(angle_from_medial_rad, 2.0 * kPi);
  const double d = from_pole_m - kValveFromPole_m;
  // Flat-topped along the colon, so it reads as a thick cushion rather than
  // a fold; Gaussian around the wall, whose sectors are too coarse (11.25
  // degrees) for steeper flanks without a sawtooth edge.
  const double cushion = Gauss(a, kValveHalfWidth_rad) * Plateau(d, kValveHalfLength_m);
  const double slit =
      kValveSlitDepth * Gauss(d, kValveSlitHalfWidth_m) * Gauss(a, kValveSlitHalfLength_rad);
  return 1.0 - kValveHeight * cushion * (1.0 - slit);
}

bool OnIleocaecalValve(double from_pole_m, double angle_from_medial_rad) {
  return IleocaecalValveFactor(from_pole_m, angle_from_medial_rad) < 1.0 - 0.1 * kValveHeight;
}

double CecalPoleRelief_m(double phi_rad, double angle_rad, double radius_m) {
  // Distance from the pole across the dome, as a share of its radius.
  const double r = std::cos(phi_rad);
  // The fold: three ridges on the taeniae's meridians, rising from the rim
  // and ending on the orifice's rim.
  const double along = std::sin(kPi * std::clamp(r, 0.0, 1.0));
  const double fold = kFoldHeight * along * Gauss(FromTaenia(angle_rad), kFoldHalfWidth_rad);
  // The orifice: a pit, and a crescent rim on one side (the side away from
  // the first taenia), as the appendix's opening usually looks.
  const double pit = -kOrificeDepth * Gauss(r, kOrificeRadius);
  const double crescent = kOrificeRimHeight * Gauss(r - 2.0 * kOrificeRadius, 0.35 * kOrificeRadius) *
                          (0.5 + 0.5 * std::cos(angle_rad - 4.0 * kPi / 3.0 + kPi));
  return radius_m * (fold + pit + crescent);
}

}  // namespace ves::render
