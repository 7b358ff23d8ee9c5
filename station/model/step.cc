// Step: one time step of the endoscope-colon model (docs/model.md §Time step).
#include <algorithm>
#include <cmath>

#include "station/model/internal.h"
#include "station/model/model.h"

namespace ves::model {
namespace {

// Below this relative speed a sliding contact sticks again.
constexpr double kRestickSpeed_m_per_s = 1e-4;
constexpr double kStaticRecovery_s = 0.05;  // time constant of static friction's return

// The knobs set the rest angles q0 of the bending section, shared evenly by
// its joints (a positive pitch turns +z toward -y, so "up" is negative pitch).
void SetKnobRestAngles(const ModelParams& params, const StepInput& input, ModelState* s) {
  const EndoscopeParams& scope = params.scope;
  const int n = scope.link_count;
  const int first = s->first_bending_link;
  const int joints = n - first;
  const double up = std::clamp(input.knob_up_rad, -scope.angulation_down_rad,
                               scope.angulation_up_rad);
  const double right = std::clamp(input.knob_right_rad, -scope.angulation_left_rad,
                                  scope.angulation_right_rad);
  for (int k = first; k < n; ++k) {
    s->bend_rest_rad[k] = Eigen::Vector2d(-up / joints, right / joints);
  }
}

// colon_sum_m2: the sum of the colon points' squared displacements, which is
// not finite if any displacement is not (the output loop takes them anyway;
// it overflows only past 1e154 m, a model long diverged).
bool AllFinite(const ModelState& s, const StepOutput& out, double colon_sum_m2) {
  if (!std::isfinite(s.inserted_m) || !std::isfinite(out.base_force_N) ||
      !std::isfinite(out.roll_torque_Nm) || !s.X_WTip.matrix().allFinite()) {
    return false;
  }
  for (const Eigen::Vector2d& q : s.bend_rad) {
    if (!q.allFinite()) return false;
  }
  return std::isfinite(colon_sum_m2);
}

}  // namespace

void Step(const ModelParams& params, const StepInput& input, ModelState* s, Scratch* sc,
          StepOutput* out) {
  const double dt = params.dt_s;
  SetKnobRestAngles(params, input, s);
  // The roll turns the shaft in place; its surface slides round by spin * a.
  const double spin_rad = input.roll_rad - s->roll_rad;
  internal::SpinScope(params, input.roll_rad, s);

  // 1. Contacts at the current shapes (eqs. 9-17).
  internal::EvaluateContacts(params, s, sc, out);
  const int samples = static_cast<int>(s->samples.size());
  const int first_inside = s->first_inside_sample;  // samples before it are outside
  // The inside samples' positions before the scope moves (SolveColon reads them too).
  for (int i = first_inside; i < samples; ++i) sc->sample_delta_m[i] = s->p_WSample[i];

  // 2. Scope: eq. (6), linearly implicit, O(n).
  internal::SolveScope(params, input, input.insertion_m, s, sc, out);
  internal::UpdateScopeKinematics(params, s);

  // 3. Colon: suspension, mesentery, axial links, contacts, linearly implicit, O(N).
  //    The assistant's hand presses in and lets go gradually.
  const double press_step =
      params.abdominal_pressure_ramp_s > 0.0 ? dt / params.abdominal_pressure_ramp_s : 1.0;
  for (std::size_t r = 0; r < s->abdominal_pressure_level.size(); ++r) {
    const double asked =
        input.abdominal_pressure[r] > 0.0 ? std::min(input.abdominal_pressure[r], 1.0) : 0.0;
    double& level = s->abdominal_pressure_level[r];
    level = std::clamp(asked, level - press_step, level + press_step);
  }
  internal::SolveColon(params, input, s, sc);

  // 4. Friction memory: the stick spring stretches by the tangential relative
  //    displacement of scope surface and wall during the step (the surface
  //    also turned with the spin). The friction round the shaft is a torque
  //    the hand holds: a (n x F_t) . t about each sample's axis t.
  double speed2 = 0.0;
  const auto& pts = params.colon.points;
  const double scope_radius_m = 0.5 * params.scope.outer_diameter_m;
  for (int i = first_inside; i < samples; ++i) {
    SampleContact& c = s->contact[i];
    const Eigen::Vector3d dp = s->p_WSample[i] - sc->sample_delta_m[i];
    sc->sample_delta_m[i] = dp;
    speed2 += dp.squaredNorm();
    if (!c.touching) continue;
    const int k = c.segment;
    const Eigen::Vector3d dc = (1.0 - c.segment_t) * sc->colon_system.Solution(k) +
                               c.segment_t * sc->colon_system.Solution(k + 1);
    const Eigen::Vector3d& n = sc->sample_normal_W[i];
    const Eigen::Vector3d axis = s->X_WLink[s->samples[i].link].linear().col(2);
    out->roll_torque_Nm -= scope_radius_m * n.cross(sc->sample_friction_W_N[i]).dot(axis);
    Eigen::Vector3d rel = dp + (spin_rad * scope_radius_m) * axis.cross(n) - dc;
    rel -= rel.dot(n) * n;
    if (c.sliding && rel.norm() < kRestickSpeed_m_per_s * dt) {
      // At rest, static friction recovers: the stick spring relaxes toward
      // the force it carries now (at most mu_s N), smoothly, so pushing on
      // needs mu_s N again without a jump in the contact force.
      const double cap_m = pts[k].tissue.static_friction * sc->sample_normal_force_N[i] /
                           params.friction_stiffness_N_per_m;
      Eigen::Vector3d target = -sc->sample_friction_W_N[i] / params.friction_stiffness_N_per_m;
      if (target.norm() > 0.99 * cap_m) target *= 0.99 * cap_m / target.norm();
      c.slip_m = target + std::exp(-dt / kStaticRecovery_s) * (c.slip_m - target);
    }
    c.slip_m += rel;
  }
  speed2 /= dt * dt;

  // 5. Outputs.
  const int N = static_cast<int>(pts.size());
  std::fill(out->wall_force_N.begin(), out->wall_force_N.end(), 0.0);
  std::fill(s->wall_deformation_m.begin(), s->wall_deformation_m.end(), 0.0);
  for (int j = 0; j < out->contact_count; ++j) {
    const Contact& contact = out->contacts[j];
    const SampleContact& c = s->contact[contact.sample];
    const int k = contact.segment;
    out->wall_force_N[k] += (1.0 - c.segment_t) * contact.normal_force_N;
    out->wall_force_N[k + 1] += c.segment_t * contact.normal_force_N;
    const int nearest = c.segment_t < 0.5 ? k : k + 1;
    s->wall_deformation_m[nearest] =
        std::max(s->wall_deformation_m[nearest], contact.penetration_m);
  }
  for (int j = 0; j < sc->ring_contact_count; ++j) {
    const RingContact& rc = sc->ring_contacts[j];
    out->wall_force_N[rc.point] += rc.force_N;
    s->wall_deformation_m[rc.point] = std::max(s->wall_deformation_m[rc.point], rc.penetration_m);
  }
  // The peaks in locals, written once after the loop: as members of *out they
  // could be any of the doubles the loop stores, and each point would read
  // them back from memory.
  double peak_stretch_m = 0.0;
  double peak_stretch_arc_m = 0.0;
  double peak_wall_force_N = 0.0;
  double peak_fixed_moved2_m2 = 0.0;  // squared: one square root for the peak
  double peak_material_ratio = 1.0;  // a gap over its material length, the largest
  double colon_sum_m2 = 0.0;
  // The gap behind point i and the one ahead of it (0 past the ends, where
  // the point's own is used).
  double gap_behind_m = 0.0;
  // The points' constants from the scratch's compact copies: the points
  // themselves are large and this loop visits every one.
  const ColonSolverArrays& constants = sc->colon_arrays;
  for (int i = 0; i < N; ++i) {
    const double moved2_m2 = s->colon_displacement_m[i].squaredNorm();
    colon_sum_m2 += moved2_m2;
    speed2 += s->colon_velocity_m_per_s[i].squaredNorm();
    // Mesentery stretch: how far the tether is pulled beyond its reach.
    const double stretch =
        std::max(0.0, s->colon_tether_distance_m[i] - constants.tether_length_m[i]);
    out->stretch_m[i] = stretch;
    if (stretch > peak_stretch_m) {
      peak_stretch_m = stretch;
      peak_stretch_arc_m = pts[i].arc_m;
    }
    if (constants.mobile[i] == 0) {
      peak_fixed_moved2_m2 = std::max(peak_fixed_moved2_m2, moved2_m2);
    }
    peak_wall_force_N = std::max(peak_wall_force_N, out->wall_force_N[i]);
    // Pleat ratio: the tube's current length over its rest length around r_i.
    const double gap_ahead_m = i + 1 < N ? s->colon_gap_m[i] : 0.0;
    peak_material_ratio =
        std::max(peak_material_ratio, gap_ahead_m * constants.inverse_material_gap[i]);
    const double rest_m = constants.length_m[i];  // half of each neighbouring gap at rest
    out->pleat_ratio[i] = 0.5 * (gap_ahead_m + gap_behind_m) / rest_m;
    gap_behind_m = gap_ahead_m;
  }
  out->peak_stretch_m = peak_stretch_m;
  out->peak_stretch_arc_m = peak_stretch_arc_m;
  out->peak_wall_force_N = peak_wall_force_N;
  out->peak_fixed_displacement_m = std::sqrt(peak_fixed_moved2_m2);
  out->peak_wall_strain = peak_material_ratio - 1.0;
  SampleContact tip = s->contact[samples - 1];
  if (tip.inside) {
    // Where the tip is now, along the colon's material (a copy: the contact
    // memory itself moves on at the next step's evaluation).
    internal::TrackSegment(*s, params.contact_search_window, s->p_WSample[samples - 1], &tip);
    const int k = tip.segment;
    const double t =
        internal::CalcSegmentHit(params, *s, k, s->p_WSample[samples - 1]).t;
    const double a0 = pts[k].arc_m;
    s->tip_arc_m = a0 + t * (pts[k + 1].arc_m - a0);
  } else {
    s->tip_arc_m = 0.0;
  }
  s->time_s += dt;
  ++s->step_count;
  out->X_WTip = s->X_WTip;
  out->tip_arc_m = s->tip_arc_m;
  out->inserted_m = s->inserted_m;
  out->velocity_norm_m_per_s = std::sqrt(speed2);
  out->finite = AllFinite(*s, *out, colon_sum_m2);
}

}  // namespace ves::model
