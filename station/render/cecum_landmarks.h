#pragma once

// The landmarks by which a colonoscopist confirms the cecum (docs/views.md,
// "The cecum"): the three taeniae coli converge on the cecal pole in the
// triradiate fold ("Mercedes-Benz sign"), the appendiceal orifice is a small
// crescent-rimmed pit where they meet, and the ileocaecal valve is a pair of
// lips on the medial wall a few centimetres before the pole. They are shapes
// of the colon's surface (colon_mesh.h), so every view mode draws them and
// the endoscope's light falls on them as on the rest of the wall.
namespace ves::render {

// The valve as endoscopists see it: a thickened cushion on the medial wall,
// this far (arc length) before the cecal pole's rim, flat-topped over this
// half-length along the colon and rounded (Gaussian) around the wall, and
// split across its middle by a slit (the "fish-mouth") between two lips
// that stand about 0.34 R into the lumen (11 mm in a 32 mm cecum).
inline constexpr double kValveFromPole_m = 0.035;
inline constexpr double kValveHeight = 0.42;         // of the radius, the cushion's top
inline constexpr double kValveHalfLength_m = 0.009;  // the cushion, along the colon
inline constexpr double kValveHalfWidth_rad = 0.45;  // the cushion's sigma around the wall
inline constexpr double kValveSlitHalfWidth_m = 0.0025;   // the slit's sigma along the colon
inline constexpr double kValveSlitDepth = 0.75;      // share of the cushion it cuts away
inline constexpr double kValveSlitHalfLength_rad = 0.3;   // the slit's sigma around the wall
// Beyond this arc before the pole's rim the valve leaves the wall as it is.
inline constexpr double kValveReach_m = kValveFromPole_m + 2.0 * kValveHalfLength_m;

// Radius factor of the ileocaecal valve at arc `from_pole_m` before the
// pole's rim (>= 0) and `angle_from_medial_rad` around the wall from the
// medial side: 1 away from the valve, down to about 1 - 0.82 kValveHeight
// on the lips, back up by kValveSlitDepth of the cushion in the slit.
double IleocaecalValveFactor(double from_pole_m, double angle_from_medial_rad);

// Whether that point of the wall is on the valve (raised by more than a
// tenth of its height): the wireframe draws every ring and sector there, so
// its sparse loops (one a centimetre) do not step over the lips and slit.
bool OnIleocaecalValve(double from_pole_m, double angle_from_medial_rad);

// How far the cecal pole's surface moves into the lumen (m; negative: out
// of it, the orifice's pit) at dome latitude `phi_rad` (0 at the rim, pi/2
// at the pole), angle `angle_rad` in the tube's frame (the taeniae at
// cos(3 angle) = -1, as HaustralFoldFactor has them) and the dome's radius.
// The fold's three ridges run from the rim to the orifice; the orifice is a
// pit at the pole with a raised crescent rim.
double CecalPoleRelief_m(double phi_rad, double angle_rad, double radius_m);

}  // namespace ves::render
