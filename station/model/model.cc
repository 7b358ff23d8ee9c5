// Construction of the model's state, scratch and output (all allocation
// happens here, never in Step).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "station/model/internal.h"
#include "station/model/model.h"

namespace ves::model {
namespace {

void Require(bool ok, const char* field, double value, const char* rule) {
  if (!ok) {
    throw std::invalid_argument(std::string("model params: ") + field + " = " +
                                std::to_string(value) + " (" + rule + ")");
  }
}

bool InRange(double x, double lo, double hi) { return std::isfinite(x) && x >= lo && x <= hi; }

int PiecesOfLink(double length_m, double spacing_m) {
  return std::max(1, static_cast<int>(std::ceil(length_m / spacing_m - 1e-9)));
}

// Samples: the pieces of every link plus the tip.
size_t CountSamples(const ModelParams& params) {
  size_t samples = 1;
  for (double l : CalcLinkLengths_m(params.scope)) {
    samples += PiecesOfLink(l, params.sample_spacing_m);
  }
  return samples;
}

}  // namespace

void ValidateParams(const ModelParams& p) {
  ValidateEndoscope(p.scope);
  ValidateColon(p.colon);
  Require(InRange(p.dt_s, 1e-5, 0.01), "dt_s", p.dt_s, "must be in [1e-5, 0.01] s");
  Require(p.gravity_W_m_per_s2.allFinite() && p.gravity_W_m_per_s2.norm() <= 100.0,
          "gravity_W_m_per_s2.norm", p.gravity_W_m_per_s2.norm(), "must be finite and <= 100");
  Require(InRange(p.thrust_damping_N_s_per_m, 1e-3, 1e6), "thrust_damping_N_s_per_m",
          p.thrust_damping_N_s_per_m, "must be in [1e-3, 1e6]");
  Require(InRange(p.sample_spacing_m, 1e-3, 0.5), "sample_spacing_m", p.sample_spacing_m,
          "must be in [0.001, 0.5] m");
  Require(InRange(p.wall_hardening_ratio, 1.0, 1e4), "wall_hardening_ratio",
          p.wall_hardening_ratio, "must be in [1, 1e4]");
  Require(InRange(p.friction_stiffness_N_per_m, 1.0, 1e7), "friction_stiffness_N_per_m",
          p.friction_stiffness_N_per_m, "must be in [1, 1e7]");
  Require(InRange(p.outer_cone_ratio, 1.01, 100.0), "outer_cone_ratio", p.outer_cone_ratio,
          "must be in [1.01, 100]");
  Require(InRange(p.colon_tension_stiffness_N, 1.0, 1e5), "colon_tension_stiffness_N",
          p.colon_tension_stiffness_N, "must be in [1, 1e5] N");
  Require(InRange(p.colon_toe_stiffness_N, 0.0, p.colon_tension_stiffness_N),
          "colon_toe_stiffness_N", p.colon_toe_stiffness_N,
          "must be in [0, colon_tension_stiffness_N]");
  Require(InRange(p.colon_toe_strain, 0.0, 2.0), "colon_toe_strain", p.colon_toe_strain,
          "must be in [0, 2]");
  Require(InRange(p.colon_linear_mass_kg_per_m, 0.0, 10.0), "colon_linear_mass_kg_per_m",
          p.colon_linear_mass_kg_per_m, "must be in [0, 10] kg/m");
  Require(InRange(p.abdominal_pressure_stiffness_N_per_m2, 0.0, 1e6),
          "abdominal_pressure_stiffness_N_per_m2", p.abdominal_pressure_stiffness_N_per_m2,
          "must be in [0, 1e6] N/m^2");
  Require(InRange(p.abdominal_pressure_slack_m, 0.0, 0.2), "abdominal_pressure_slack_m",
          p.abdominal_pressure_slack_m, "must be in [0, 0.2] m");
  Require(InRange(p.abdominal_pressure_ramp_s, 0.0, 60.0), "abdominal_pressure_ramp_s",
          p.abdominal_pressure_ramp_s, "must be in [0, 60] s");
  Require(InRange(p.colon_straighten_stiffness_N, 0.0, p.colon_tension_stiffness_N),
          "colon_straighten_stiffness_N", p.colon_straighten_stiffness_N,
          "must be in [0, colon_tension_stiffness_N]");
  Require(InRange(p.ring_onset_s, 0.0, 1.0), "ring_onset_s", p.ring_onset_s, "must be in [0, 1] s");
  Require(InRange(p.colon_pleat_stiffness_N, 0.0, p.colon_tension_stiffness_N),
          "colon_pleat_stiffness_N", p.colon_pleat_stiffness_N,
          "must be in [0, colon_tension_stiffness_N]");
  Require(InRange(p.colon_packed_stiffness_N, 1.0, 1e5), "colon_packed_stiffness_N",
          p.colon_packed_stiffness_N, "must be in [1, 1e5] N");
  Require(InRange(p.colon_pleat_set_s, 0.0, 1e6), "colon_pleat_set_s", p.colon_pleat_set_s,
          "must be in [0, 1e6] s (0: never)");
  Require(InRange(p.colon_pleat_release_s, 0.0, 1e6), "colon_pleat_release_s",
          p.colon_pleat_release_s, "must be in [0, 1e6] s (0: at once)");
  Require(p.tracking_arc_ratio == 0.0 || InRange(p.tracking_arc_ratio, 1.0, 25.0),
          "tracking_arc_ratio", p.tracking_arc_ratio, "must be 0 (no limit) or in [1, 25]");
  Require(p.contact_search_window >= 1 && p.contact_search_window <= 64, "contact_search_window",
          p.contact_search_window, "must be in [1, 64]");
}

ModelState MakeInitialState(const ModelParams& params) {
  ValidateParams(params);
  const EndoscopeParams& scope = params.scope;
  const int n = scope.link_count;
  ModelState s;
  s.link_length_m = CalcLinkLengths_m(scope);
  s.first_bending_link = CalcFirstBendingLink(scope, s.link_length_m);
  s.joint_stiffness_N_m_per_rad.assign(n, 0.0);
  // Arc from each joint to the start of the bending section, for the passive section.
  std::vector<double> behind_bending_m(n, 0.0);
  for (int k = s.first_bending_link - 1; k >= 1; --k) {
    behind_bending_m[k] = behind_bending_m[k + 1] + s.link_length_m[k];
  }
  for (int k = 1; k < n; ++k) {
    // A joint stands for the half links on either side: K = EI / length.
    double EI = k >= s.first_bending_link ? scope.bending_section_rigidity_N_m2
                                          : scope.flexural_rigidity_N_m2;
    if (k < s.first_bending_link && behind_bending_m[k] <= scope.passive_section_length_m) {
      EI = scope.passive_section_rigidity_N_m2;
    }
    s.joint_stiffness_N_m_per_rad[k] = EI / (0.5 * (s.link_length_m[k - 1] + s.link_length_m[k]));
  }
  s.bend_rad.assign(n, Eigen::Vector2d::Zero());
  s.bend_rest_rad.assign(n, Eigen::Vector2d::Zero());
  s.bend_rate_rad_per_s.assign(n, Eigen::Vector2d::Zero());
  s.X_WLink.assign(n, Eigen::Isometry3d::Identity());

  // Samples at the middle of equal pieces of every link (they carry the mass),
  // plus a massless one at the very tip.
  double arc_from_tip_m = scope.working_length_m;
  for (int k = 0; k < n; ++k) {
    const double l = s.link_length_m[k];
    const int pieces = PiecesOfLink(l, params.sample_spacing_m);
    for (int j = 0; j < pieces; ++j) {
      ScopeSample sample;
      sample.link = k;
      sample.offset_m = (j + 0.5) * l / pieces;
      sample.arc_from_tip_m = arc_from_tip_m - sample.offset_m;
      sample.mass_kg = scope.linear_mass_kg_per_m * l / pieces;
      s.samples.push_back(sample);
    }
    arc_from_tip_m -= l;
  }
  ScopeSample tip;
  tip.link = n - 1;
  tip.offset_m = s.link_length_m[n - 1];
  tip.arc_from_tip_m = 0.0;
  s.samples.push_back(tip);
  s.p_WSample.assign(s.samples.size(), Eigen::Vector3d::Zero());
  s.contact.assign(s.samples.size(), SampleContact{});
  s.first_inside_sample = static_cast<int>(s.samples.size());  // none yet

  const int N = static_cast<int>(params.colon.points.size());
  s.colon_displacement_m.assign(N, Eigen::Vector3d::Zero());
  s.colon_pair_rest_gap_m.assign(N, 1.0);
  for (int i = 0; i + 1 < N; ++i) {
    s.colon_pair_rest_gap_m[i] =
        (params.colon.points[i + 1].rest_position_m - params.colon.points[i].rest_position_m).norm();
  }
  s.colon_reference_m.resize(N);
  for (int i = 0; i < N; ++i) s.colon_reference_m[i] = params.colon.points[i].rest_position_m;
  s.colon_velocity_m_per_s.assign(N, Eigen::Vector3d::Zero());
  s.ring_onset.assign(N, 0.0);
  s.p_WColon.resize(N);
  s.colon_tangent.resize(N);
  for (int i = 0; i < N; ++i) {
    s.p_WColon[i] = params.colon.points[i].rest_position_m;
    s.colon_tangent[i] = params.colon.points[i].rest_tangent;
  }
  s.colon_lumen_radius_m.resize(N);
  for (int i = 0; i < N; ++i) s.colon_lumen_radius_m[i] = params.colon.points[i].radius_m;
  s.colon_gap_m.assign(N, 0.0);
  s.colon_tether_distance_m.resize(N);
  internal::UpdateColonDerived(params, 0, N - 1, &s);
  s.wall_deformation_m.assign(N, 0.0);
  internal::UpdateScopeKinematics(params, &s);
  return s;
}

Scratch MakeScratch(const ModelParams& params, const ModelExperiments& experiments) {
  const int n = params.scope.link_count;
  Scratch sc;
  sc.compiled = CompileModel(params, experiments);
  sc.articulated_stiffness.resize(n);
  sc.articulated_bias.resize(n);
  sc.motion_subspace.resize(n);
  sc.u_matrix.resize(n);
  sc.d_inverse.resize(n);
  sc.u_vector.resize(n);
  sc.joint_increment.resize(n);
  sc.body_displacement.resize(n);
  const size_t samples = CountSamples(params);
  sc.sample_force_W_N.assign(samples, Eigen::Vector3d::Zero());
  sc.sample_normal_stiffness_N_per_m.assign(samples, 0.0);
  sc.sample_normal_W.assign(samples, Eigen::Vector3d::Zero());
  sc.sample_friction_W_N.assign(samples, Eigen::Vector3d::Zero());
  sc.sample_normal_force_N.assign(samples, 0.0);
  sc.sample_normal_slope_N_per_m.assign(samples, 0.0);
  sc.sample_delta_m.assign(samples, Eigen::Vector3d::Zero());
  sc.ring_contacts.assign(params.colon.points.size(), RingContact{});
  sc.ring_held.assign(params.colon.points.size(), 0);
  sc.lumen_normal_W.assign(params.colon.points.size(), Eigen::Vector3d::Zero());
  sc.lumen_normal_known.assign(params.colon.points.size(), 0);
  const size_t N = params.colon.points.size();
  sc.colon_system.Resize(static_cast<int>(N));
  sc.colon_arrays.Resize(static_cast<int>(N));
  return sc;
}

void ColonSolverArrays::Resize(int points) {
  const size_t size = static_cast<size_t>(points) + kColonLanePadding;
  for (CoordinateArrays* xyz : {&position_m, &reference_m, &tangent, &pair_impulse}) {
    for (auto& v : *xyz) v.assign(size, 0.0);
  }
  for (auto& v : pair_block) v.assign(size, 0.0);
  rest_gap_m.assign(size, 1.0);
  tether_distance_m.assign(size, 0.0);
  gap_m.assign(size + 1, 0.0);
}

void ColonSystem::Resize(int points) {
  const size_t size = static_cast<size_t>(points) + kColonLanePadding;
  for (auto& a : diag) a.assign(size, 0.0);
  for (auto& a : upper) a.assign(size, 0.0);
  for (auto& a : rhs) a.assign(size, 0.0);
  gain.assign(12 * size, 0.0);
  solution.assign(4 * size, 0.0);
}

StepOutput MakeStepOutput(const ModelParams& params) {
  StepOutput out;
  const size_t N = params.colon.points.size();
  out.wall_force_N.assign(N, 0.0);
  out.stretch_m.assign(N, 0.0);
  out.pleat_ratio.assign(N, 1.0);
  out.contacts.resize(CountSamples(params));
  return out;
}

}  // namespace ves::model
