#pragma once

// The landmarks by which a colonoscopist confirms the cecum (docs/views.md,
// "The cecum"): the three taeniae coli converge on the cecal pole in the
// triradiate fold ("Mercedes-Benz sign"), the appendiceal orifice is a small
// crescent-rimmed pit where they meet, and the ileocaecal valve is a pair of
// lips on the medial wall a few centimetres before the pole. They are shapes
// of the colon's surface (colon_mesh.h), so every view mode draws them and
// the endoscope's light falls on them as on the rest of the wall.
namespace ves::render {

// The valve's centre, this far (arc length) before the cecal pole's rim,
// and its size: two lips this far apart along the colon, each a ridge of
// this share of the radius over this much of the wall's circumference.
inline constexpr double kValveFromPole_m = 0.035;
inline constexpr double kValveLipGap_m = 0.010;
inline constexpr double kValveLipSpread_m = 0.004;  // Gaussian sigma along the colon
inline constexpr double kValveDepth = 0.30;         // of the radius, into the lumen
inline constexpr double kValveHalfWidth_rad = 0.55; // Gaussian sigma around the wall

// Radius factor of the ileocaecal valve at arc `from_pole_m` before the
// pole's rim (>= 0) and `angle_from_medial_rad` around the wall from the
// medial side: 1 away from the valve, down to 1 - kValveDepth on a lip.
double IleocaecalValveFactor(double from_pole_m, double angle_from_medial_rad);

// How far the cecal pole's surface moves into the lumen (m; negative: out
// of it, the orifice's pit) at dome latitude `phi_rad` (0 at the rim, pi/2
// at the pole), angle `angle_rad` in the tube's frame (the taeniae at
// cos(3 angle) = -1, as HaustralFoldFactor has them) and the dome's radius.
// The fold's three ridges run from the rim to the orifice; the orifice is a
// pit at the pole with a raised crescent rim.
double CecalPoleRelief_m(double phi_rad, double angle_rad, double radius_m);

}  // namespace ves::render
