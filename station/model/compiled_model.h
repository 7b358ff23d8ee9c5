#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "station/model/experiments.h"

namespace ves::model {

struct ModelParams;

// Three arrays, one per coordinate (x, y, z) of each point.
using CoordinateArrays = std::array<std::vector<double>, 3>;

// Arrays of the colon solver hold this many entries past the last point:
// its loops take four points (or pairs) at a time, and the last group may
// run past the end (those lanes are computed and never read).
inline constexpr int kColonLanePadding = 4;

// The model's constants, derived once from the params (the case's rest
// geometry and tissue, the step size) and never written by Step: the split
// of a compiled model from the per-step data (ModelState, Scratch's work
// arrays). Per-point arrays are indexed by colon point i, per-pair arrays by
// the pair (i, i+1); all are padded by kColonLanePadding and laid out one
// coordinate per array so that the colon solver's loops take four points at
// a time (docs/model.md, "Speed").
struct CompiledModel {
  // Each point's own terms of the colon system (paper §3.3.2).
  std::array<std::vector<double>, 6> own_diag;  // D_c h_i I + dt K_c h_i P_i (upper triangle)
  std::vector<double> suspension_rhs_factor;    // -(dt K_c h_i)
  std::vector<double> relax_factor;             // dt / (suspension relaxation + dt), 0: none
  CoordinateArrays rest_tangent;                // t_i at rest, the normal of P_i
  std::vector<Eigen::Vector3d> rest_position_m;  // the points' (kept together: read every step)
  std::vector<double> length_m;                  // h_i, the tube a point stands for
  std::vector<std::uint8_t> mobile;              // 1 where the tissue is mobile
  // The mesentery tether (docs/model.md, "Mesentery").
  CoordinateArrays tether_anchor_m;
  CoordinateArrays tether_root_direction;
  CoordinateArrays tether_side;
  std::vector<double> has_tether_side;  // 1 where tether_side is set, else 0
  std::vector<double> tether_length_m;  // its reach
  std::vector<double> tether_N_per_m;   // mesentery stiffness * h_i

  // Each pair's axial link and kink tension (docs/model.md, "Axial links").
  std::vector<double> pair_gap_m;                // natural rest distance of points i, i+1
  std::vector<double> pair_kink_N_per_m;         // T / natural gap
  std::vector<double> pair_pleat_limit;          // smaller pleat_limit of i, i+1
  std::vector<double> pair_toe_N;                // the toe's stiffness
  std::vector<double> pair_toe_strain;           // where the toe ends, as a strain
  // The material length where the gap has a gathered reserve (its toe then
  // ends there, also after its folds have set), else 0.
  std::vector<double> pair_reserve_end_m;
  std::vector<double> inverse_material_gap;      // 1 / the gap's material length
  CoordinateArrays pair_rest_direction;          // unit, i -> i+1 at rest
  CoordinateArrays pair_rest_mean_tangent;       // mean of i's and i+1's rest tangents

  // ModelParams::tracking_arc_ratio as used: at least 1.2 over the smallest
  // pleat limit (of material length) of the colon; 0: no limit.
  double tracking_arc_ratio{0.0};

  ModelExperiments experiments;
};

// Validates the experiments against the params; throws std::invalid_argument
// naming the bad field and value.
void ValidateExperiments(const ModelExperiments& experiments);

// The compiled model of params (validated by the caller: MakeInitialState)
// with the given experiments (validated here).
CompiledModel CompileModel(const ModelParams& params, const ModelExperiments& experiments = {});

}  // namespace ves::model
