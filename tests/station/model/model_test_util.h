#pragma once

// Synthetic geometry and a driver loop shared by the model tests.
#include <cmath>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "station/model/model.h"

namespace ves::model::testing {

// Straight tube along +z from the anus, one point every spacing_m.
inline ColonSpec MakeStraightTube(double length_m, double spacing_m, double radius_m,
                                  const TissueParams& tissue) {
  std::vector<Eigen::Vector3d> points;
  const int count = static_cast<int>(std::round(length_m / spacing_m)) + 1;
  for (int i = 0; i < count; ++i) points.emplace_back(0.0, 0.0, i * spacing_m);
  return MakeColonFromPoints(points, radius_m, tissue);
}

// Straight entry along +z, a circular bend of angle theta (radius of
// curvature bend_radius_m) turning toward +y, then a straight exit.
inline ColonSpec MakeBendTube(double entry_m, double theta_rad, double bend_radius_m,
                              double exit_m, double spacing_m, double radius_m,
                              const TissueParams& tissue) {
  std::vector<Eigen::Vector3d> points;
  const int entry_count = static_cast<int>(std::round(entry_m / spacing_m));
  for (int i = 0; i < entry_count; ++i) points.emplace_back(0.0, 0.0, i * spacing_m);
  const Eigen::Vector3d center(0.0, bend_radius_m, entry_m);
  const double arc_m = theta_rad * bend_radius_m;
  const int arc_count = static_cast<int>(std::round(arc_m / spacing_m));
  for (int i = 0; i < arc_count; ++i) {
    const double phi = i * (arc_m / arc_count) / bend_radius_m;
    points.push_back(center + bend_radius_m * Eigen::Vector3d(0.0, -std::cos(phi), std::sin(phi)));
  }
  const Eigen::Vector3d end =
      center + bend_radius_m * Eigen::Vector3d(0.0, -std::cos(theta_rad), std::sin(theta_rad));
  const Eigen::Vector3d dir(0.0, std::sin(theta_rad), std::cos(theta_rad));
  const int exit_count = static_cast<int>(std::round(exit_m / spacing_m));
  for (int i = 0; i <= exit_count; ++i) points.push_back(end + (i * spacing_m) * dir);
  return MakeColonFromPoints(points, radius_m, tissue);
}

// A wall that does not move: fixed (no mesentery, no pleating), very stiff
// suspension, no threshold effect.
inline TissueParams RigidTissue(double mu_s, double mu_d) {
  TissueParams t;
  t.mobile = false;
  t.mesentery_length_m = 0.0;
  t.mesentery_stiffness_N_per_m2 = 1.0e6;
  t.pleat_limit = 1.0;
  t.suspension_stiffness_N_per_m2 = 1.0e6;
  t.suspension_damping_N_s_per_m2 = 1.0e3;
  t.wall_stiffness_N_per_m = 5000.0;
  t.wall_damping_N_s_per_m = 0.5;
  t.deformation_threshold_m = 0.05;
  t.static_friction = mu_s;
  t.dynamic_friction = mu_d;
  t.neighbor_tension_N = 1.0;
  return t;
}

// Holds params, state, scratch and output; Run() steps with an input rule.
struct Sim {
  explicit Sim(ModelParams p, const ModelExperiments& experiments = {})
      : params(std::move(p)),
        state(MakeInitialState(params)),
        scratch(MakeScratch(params, experiments)),
        out(MakeStepOutput(params)) {}

  void StepOnce(const StepInput& input) { Step(params, input, &state, &scratch, &out); }

  // Steps until the time reaches t_end_s; returns false on a non-finite state.
  bool RunUntil(double t_end_s, const std::function<StepInput(const Sim&)>& rule) {
    while (state.time_s < t_end_s - 1e-9) {
      StepOnce(rule(*this));
      if (!out.finite) return false;
    }
    return true;
  }

  ModelParams params;
  ModelState state;
  Scratch scratch;
  StepOutput out;
};

}  // namespace ves::model::testing
