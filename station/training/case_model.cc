#include "station/training/case_model.h"

#include <algorithm>
#include <cctype>

#include <stdexcept>

namespace ves::training {
namespace {

namespace m = ves::model;

m::Region RegionFromProto(ves::v1::Region region) {
  const int value = static_cast<int>(region);
  if (value < 0 || value > static_cast<int>(m::Region::kCecum)) return m::Region::kUnspecified;
  return static_cast<m::Region>(value);
}

double Or(double value, double fallback) { return value != 0.0 ? value : fallback; }

// A case's tissue; the mesentery and pleating fields it leaves unset take the
// defaults of the region's name (docs/model.md).
m::TissueParams TissueFromProto(const ves::v1::TissueParams& t, m::Region region) {
  m::TissueParams out;
  out.suspension_stiffness_N_per_m2 = t.suspension_stiffness_n_per_m2();
  out.suspension_damping_N_s_per_m2 = t.suspension_damping_n_s_per_m2();
  out.wall_stiffness_N_per_m = t.wall_stiffness_n_per_m();
  out.wall_damping_N_s_per_m = t.wall_damping_n_s_per_m();
  out.deformation_threshold_m = t.deformation_threshold_m();
  out.static_friction = t.static_friction();
  out.dynamic_friction = t.dynamic_friction();
  out.neighbor_tension_N = t.neighbor_tension_n();
  out.mobile = t.mobility() == ves::v1::MOBILITY_DEFAULT ? m::IsMobileByDefault(region)
                                                          : t.mobility() == ves::v1::MOBILITY_MOBILE;
  const m::MobilityDefaults defaults = m::DefaultMobility(region, out.mobile);
  out.mesentery_length_m = Or(t.mesentery_length_m(), defaults.mesentery_length_m);
  out.mesentery_stiffness_N_per_m2 =
      Or(t.mesentery_stiffness_n_per_m2(), defaults.mesentery_stiffness_N_per_m2);
  out.pleat_limit = Or(t.pleat_limit(), defaults.pleat_limit);
  out.suspension_relaxation_s = defaults.suspension_relaxation_s;
  out.gathered_reserve =
      t.has_gathered_reserve() ? t.gathered_reserve() : defaults.gathered_reserve;
  return out;
}

}  // namespace

std::string RegionNameAt(const m::ColonSpec& colon, double arc_m) {
  if (colon.points.empty()) return "unspecified";
  // Points are in arc order: the last one at or before arc_m.
  const auto after = std::upper_bound(
      colon.points.begin(), colon.points.end(), arc_m,
      [](double arc, const m::ColonPoint& point) { return arc < point.arc_m; });
  const m::ColonPoint& point = after == colon.points.begin() ? colon.points.front() : *(after - 1);
  // The proto's enum names, REGION_SPLENIC_FLEXURE -> "splenic-flexure".
  std::string name = ves::v1::Region_Name(static_cast<ves::v1::Region>(point.region));
  if (name.rfind("REGION_", 0) == 0) name.erase(0, 7);
  for (char& c : name) c = c == '_' ? '-' : static_cast<char>(std::tolower(c));
  return name.empty() ? "unspecified" : name;
}

m::ColonSpec ColonSpecFromCase(const ves::v1::ColonCase& colon_case,
                               const CaseModelOptions& options) {
  m::ColonCurve curve;
  for (const auto& p : colon_case.centerline()) {
    curve.control_points_m.emplace_back(p.x_m(), p.y_m(), p.z_m());
  }
  for (const auto& r : colon_case.radius_profile()) {
    curve.radius_profile.push_back({r.arc_m(), r.radius_m()});
  }
  for (const auto& span : colon_case.regions()) {
    const m::Region region = RegionFromProto(span.region());
    curve.regions.push_back(
        {region, span.start_arc_m(), span.end_arc_m(), TissueFromProto(span.tissue(), region)});
  }
  m::ColonSpec colon = m::ResampleColon(curve, options.segments);
  if (options.stiff_colon) m::MakeSuspensionStiff(&colon);
  return colon;
}

m::EndoscopeParams EndoscopeFromSpec(const ves::v1::EndoscopeSpec& spec) {
  m::EndoscopeParams p;
  p.working_length_m = Or(spec.working_length_m(), p.working_length_m);
  p.outer_diameter_m = Or(spec.outer_diameter_m(), p.outer_diameter_m);
  p.link_count = spec.link_count() != 0 ? static_cast<int>(spec.link_count()) : p.link_count;
  p.tip_link_length_m = Or(spec.tip_link_length_m(), p.tip_link_length_m);
  p.link_growth_ratio = Or(spec.link_growth_ratio(), p.link_growth_ratio);
  p.flexural_rigidity_N_m2 = Or(spec.flexural_rigidity_n_m2(), p.flexural_rigidity_N_m2);
  p.joint_damping_N_m_s_per_rad =
      Or(spec.joint_damping_n_m_s_per_rad(), p.joint_damping_N_m_s_per_rad);
  p.linear_mass_kg_per_m = Or(spec.linear_mass_kg_per_m(), p.linear_mass_kg_per_m);
  p.bending_section_length_m = Or(spec.bending_section_length_m(), p.bending_section_length_m);
  p.angulation_up_rad = Or(spec.angulation_up_rad(), p.angulation_up_rad);
  p.angulation_down_rad = Or(spec.angulation_down_rad(), p.angulation_down_rad);
  p.angulation_left_rad = Or(spec.angulation_left_rad(), p.angulation_left_rad);
  p.angulation_right_rad = Or(spec.angulation_right_rad(), p.angulation_right_rad);
  p.bending_section_rigidity_N_m2 =
      Or(spec.bending_section_rigidity_n_m2(), p.bending_section_rigidity_N_m2);
  p.passive_section_length_m =
      spec.passive_section_length_m() < 0.0 ? 0.0
                                             : Or(spec.passive_section_length_m(), p.passive_section_length_m);
  p.passive_section_rigidity_N_m2 =
      Or(spec.passive_section_rigidity_n_m2(), p.passive_section_rigidity_N_m2);
  m::ValidateEndoscope(p);
  return p;
}

ves::v1::EndoscopeSpec DefaultEndoscopeSpec() {
  const m::EndoscopeParams p;
  ves::v1::EndoscopeSpec spec;
  spec.set_id("adult-colonoscope");
  spec.set_title("Adult colonoscope (CF-H180AL class; docs/model.md)");
  spec.set_working_length_m(p.working_length_m);
  spec.set_outer_diameter_m(p.outer_diameter_m);
  spec.set_link_count(static_cast<uint32_t>(p.link_count));
  spec.set_tip_link_length_m(p.tip_link_length_m);
  spec.set_link_growth_ratio(p.link_growth_ratio);
  spec.set_flexural_rigidity_n_m2(p.flexural_rigidity_N_m2);
  spec.set_joint_damping_n_m_s_per_rad(p.joint_damping_N_m_s_per_rad);
  spec.set_linear_mass_kg_per_m(p.linear_mass_kg_per_m);
  spec.set_bending_section_length_m(p.bending_section_length_m);
  spec.set_angulation_up_rad(p.angulation_up_rad);
  spec.set_angulation_down_rad(p.angulation_down_rad);
  spec.set_angulation_left_rad(p.angulation_left_rad);
  spec.set_angulation_right_rad(p.angulation_right_rad);
  spec.set_bending_section_rigidity_n_m2(p.bending_section_rigidity_N_m2);
  spec.set_passive_section_length_m(p.passive_section_length_m);
  spec.set_passive_section_rigidity_n_m2(p.passive_section_rigidity_N_m2);
  return spec;
}

m::ModelParams MakeModelParams(const ves::v1::ColonCase& colon_case,
                               const ves::v1::EndoscopeSpec& scope,
                               const CaseModelOptions& options) {
  m::ModelParams params;
  params.colon = ColonSpecFromCase(colon_case, options);
  params.scope = EndoscopeFromSpec(scope);
  m::ValidateParams(params);
  return params;
}

}  // namespace ves::training
