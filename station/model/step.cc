// Step: one time step of the endoscope-colon model (docs/model.md, "Time step").
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

// The assistant's hand presses in and lets go gradually
// (ModelParams::abdominal_pressure_ramp_s).
void UpdatePressureLevels(const ModelParams& params, const StepInput& input, ModelState* s) {
  const double press_step = params.abdominal_pressure_ramp_s > 0.0
                                ? params.dt_s / params.abdominal_pressure_ramp_s
                                : 1.0;
  for (std::size_t r = 0; r < s->abdominal_pressure_level.size(); ++r) {
    const double asked =
        input.abdominal_pressure[r] > 0.0 ? std::min(input.abdominal_pressure[r], 1.0) : 0.0;
    double& level = s->abdominal_pressure_level[r];
    level = std::clamp(asked, level - press_step, level + press_step);
  }
}

// Friction memory: the stick spring stretches by the tangential relative
// displacement of scope surface and wall during the step (the surface also
// turned with the spin). The friction round the shaft is a torque the hand
// holds: a (n x F_t) . t about each sample's axis t. Leaves each inside
// sample's move in sample_delta_m and returns the sum of their squares.
double UpdateFrictionMemory(const ModelParams& params, double spin_rad, ModelState* s,
                            Scratch* sc, StepOutput* out) {
  const double dt = params.dt_s;
  const auto& pts = params.colon.points;
  const double scope_radius_m = 0.5 * params.scope.outer_diameter_m;
  const int samples = static_cast<int>(s->samples.size());
  double moved2_m2 = 0.0;
  for (int i = s->first_inside_sample; i < samples; ++i) {
    SampleContact& c = s->contact[i];
    const Eigen::Vector3d dp = s->p_WSample[i] - sc->sample_delta_m[i];
    sc->sample_delta_m[i] = dp;
    moved2_m2 += dp.squaredNorm();
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
  return moved2_m2;
}

}  // namespace

void Step(const ModelParams& params, const StepInput& input, ModelState* s, Scratch* sc,
          StepOutput* out) {
  const CompiledModel& model = sc->compiled;
  const double dt = params.dt_s;
  SetKnobRestAngles(params, input, s);
  // The roll turns the shaft in place; its surface slides round by spin * a.
  const double spin_rad = input.roll_rad - s->roll_rad;
  internal::SpinScope(params, input.roll_rad, s);

  // 1. Contacts at the current shapes (eqs. 9-17).
  internal::EvaluateContacts(params, model, s, sc, out);
  const int samples = static_cast<int>(s->samples.size());
  // The inside samples' positions before the scope moves (SolveColon reads them too).
  for (int i = s->first_inside_sample; i < samples; ++i) sc->sample_delta_m[i] = s->p_WSample[i];

  // 2. Scope: eq. (6), linearly implicit, O(n).
  internal::SolveScope(params, input, input.insertion_m, s, sc, out);
  internal::UpdateScopeKinematics(params, s);

  // 3. Colon: suspension, mesentery, axial links, contacts, linearly implicit, O(N).
  UpdatePressureLevels(params, input, s);
  internal::SolveColon(params, model, input, s, sc);

  // 4. Friction memory (eqs. 16-17's stick spring).
  const double sample_speed2 = UpdateFrictionMemory(params, spin_rad, s, sc, out) / (dt * dt);

  // 5. Outputs.
  const double colon_sum_m2 = internal::WriteStepOutputs(params, model, sample_speed2, s, sc, out);
  s->time_s += dt;
  ++s->step_count;
  out->X_WTip = s->X_WTip;
  out->tip_arc_m = s->tip_arc_m;
  out->inserted_m = s->inserted_m;
  out->finite = AllFinite(*s, *out, colon_sum_m2);
}

}  // namespace ves::model
