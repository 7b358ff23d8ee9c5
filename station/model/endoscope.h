#pragma once

#include <vector>

// The endoscope of paper §3.2 (Fig. 7): n rigid links graded shorter toward
// the distal tip, a 2-DOF viscoelastic bending joint (pitch, yaw) at the
// proximal end of every link but the first, and a base with thrust and roll at
// the anus. The defaults describe a standard adult colonoscope; their sources
// are in docs/model.md.
namespace ves::model {

inline constexpr double kPi = 3.14159265358979323846;

struct EndoscopeParams {
  double working_length_m{1.68};          // Olympus CF-H180AL/CF-HQ190L ("L": 1680 mm)
  double outer_diameter_m{0.0128};        // same instrument, insertion tube
  int link_count{48};                     // n >= 3
  double tip_link_length_m{0.010};        // distal link
  double link_growth_ratio{1.06};         // each link toward the base is this much longer
  double flexural_rigidity_N_m2{0.030};   // EI of the insertion tube (CF-140S: 0.026-0.040)
  double joint_damping_N_m_s_per_rad{0.02};  // D in eq. (2), every bending joint
  double linear_mass_kg_per_m{0.20};      // for G(q), eq. (6)
  double bending_section_length_m{0.09};  // distal links whose rest angles the knobs set
  double angulation_up_rad{kPi};          // 180 deg
  double angulation_down_rad{kPi};        // 180 deg
  double angulation_left_rad{160.0 * kPi / 180.0};
  double angulation_right_rad{160.0 * kPi / 180.0};
  double bending_section_rigidity_N_m2{0.010};  // softer than the insertion tube
  // A flaccid, passively bending segment just behind the bending section
  // (0: uniform tube): it lets the shaft follow the tip round a flexure
  // instead of pushing the flexure away (docs/model.md).
  double passive_section_length_m{0.15};
  double passive_section_rigidity_N_m2{0.010};
  bool operator==(const EndoscopeParams&) const = default;
};

// Throws std::invalid_argument naming the first bad field and its value.
void ValidateEndoscope(const EndoscopeParams& scope);

// Link lengths from the base (index 0) to the tip (index n-1): the tip link is
// tip_link_length_m, each link toward the base link_growth_ratio times longer,
// all scaled so they sum to working_length_m.
std::vector<double> CalcLinkLengths_m(const EndoscopeParams& scope);

// Index of the first link of the bending section: the distal links whose
// lengths add up to about bending_section_length_m (at least the tip link).
int CalcFirstBendingLink(const EndoscopeParams& scope, const std::vector<double>& lengths_m);

}  // namespace ves::model
