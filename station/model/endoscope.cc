#include "station/model/endoscope.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace ves::model {
namespace {

void Require(bool ok, const char* field, double value, const char* rule) {
  if (!ok) {
    throw std::invalid_argument(std::string("endoscope: ") + field + " = " +
                                std::to_string(value) + " (" + rule + ")");
  }
}

}  // namespace

void ValidateEndoscope(const EndoscopeParams& s) {
  Require(std::isfinite(s.working_length_m) && s.working_length_m > 0.05 &&
              s.working_length_m <= 5.0,
          "working_length_m", s.working_length_m, "must be in (0.05, 5] m");
  Require(std::isfinite(s.outer_diameter_m) && s.outer_diameter_m > 0.0 &&
              s.outer_diameter_m < 0.05,
          "outer_diameter_m", s.outer_diameter_m, "must be in (0, 0.05) m");
  Require(s.link_count >= 3 && s.link_count <= 512, "link_count", s.link_count,
          "must be in [3, 512]");
  Require(std::isfinite(s.tip_link_length_m) && s.tip_link_length_m > 0.0, "tip_link_length_m",
          s.tip_link_length_m, "must be > 0");
  Require(std::isfinite(s.link_growth_ratio) && s.link_growth_ratio >= 1.0 &&
              s.link_growth_ratio <= 2.0,
          "link_growth_ratio", s.link_growth_ratio, "must be in [1, 2]");
  Require(std::isfinite(s.flexural_rigidity_N_m2) && s.flexural_rigidity_N_m2 > 0.0 &&
              s.flexural_rigidity_N_m2 <= 100.0,
          "flexural_rigidity_N_m2", s.flexural_rigidity_N_m2, "must be in (0, 100]");
  Require(std::isfinite(s.bending_section_rigidity_N_m2) &&
              s.bending_section_rigidity_N_m2 > 0.0 && s.bending_section_rigidity_N_m2 <= 100.0,
          "bending_section_rigidity_N_m2", s.bending_section_rigidity_N_m2,
          "must be in (0, 100]");
  Require(std::isfinite(s.joint_damping_N_m_s_per_rad) && s.joint_damping_N_m_s_per_rad > 0.0 &&
              s.joint_damping_N_m_s_per_rad <= 1.0e3,
          "joint_damping_N_m_s_per_rad", s.joint_damping_N_m_s_per_rad, "must be in (0, 1000]");
  Require(std::isfinite(s.linear_mass_kg_per_m) && s.linear_mass_kg_per_m >= 0.0 &&
              s.linear_mass_kg_per_m <= 10.0,
          "linear_mass_kg_per_m", s.linear_mass_kg_per_m, "must be in [0, 10]");
  Require(std::isfinite(s.bending_section_length_m) && s.bending_section_length_m >= 0.0 &&
              s.bending_section_length_m < s.working_length_m,
          "bending_section_length_m", s.bending_section_length_m,
          "must be in [0, working_length_m)");
  Require(std::isfinite(s.passive_section_length_m) && s.passive_section_length_m >= 0.0 &&
              s.passive_section_length_m + s.bending_section_length_m < s.working_length_m,
          "passive_section_length_m", s.passive_section_length_m,
          "must be >= 0 and leave room for the rest of the tube");
  Require(std::isfinite(s.passive_section_rigidity_N_m2) && s.passive_section_rigidity_N_m2 > 0.0 &&
              s.passive_section_rigidity_N_m2 <= 100.0,
          "passive_section_rigidity_N_m2", s.passive_section_rigidity_N_m2, "must be in (0, 100]");
  const double angles[] = {s.angulation_up_rad, s.angulation_down_rad, s.angulation_left_rad,
                           s.angulation_right_rad};
  const char* names[] = {"angulation_up_rad", "angulation_down_rad", "angulation_left_rad",
                         "angulation_right_rad"};
  for (int i = 0; i < 4; ++i) {
    Require(std::isfinite(angles[i]) && angles[i] >= 0.0 && angles[i] <= 1.5 * kPi, names[i],
            angles[i], "must be in [0, 1.5*pi] rad");
  }
}

std::vector<double> CalcLinkLengths_m(const EndoscopeParams& scope) {
  const int n = scope.link_count;
  std::vector<double> lengths_m(n);
  double length = scope.tip_link_length_m;
  double sum = 0.0;
  for (int k = n - 1; k >= 0; --k) {
    lengths_m[k] = length;
    sum += length;
    length *= scope.link_growth_ratio;
  }
  const double scale = scope.working_length_m / sum;
  for (double& l : lengths_m) l *= scale;
  return lengths_m;
}

int CalcFirstBendingLink(const EndoscopeParams& scope, const std::vector<double>& lengths_m) {
  const int n = static_cast<int>(lengths_m.size());
  int first = n - 1;
  double covered_m = lengths_m[n - 1];
  // Add links while that brings the covered length closer to the section's length.
  while (first > 1 && std::abs(covered_m + lengths_m[first - 1] - scope.bending_section_length_m) <
                          std::abs(covered_m - scope.bending_section_length_m)) {
    --first;
    covered_m += lengths_m[first];
  }
  return first;
}

}  // namespace ves::model
