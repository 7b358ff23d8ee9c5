// The compiled model: the constants Step reads, derived once from the params
// (compiled_model.h says what each holds).
#include "station/model/compiled_model.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "station/model/internal.h"
#include "station/model/model.h"

namespace ves::model {
namespace {

// A gap whose material is less than this longer than its rest gap has no
// reserve to straighten (a resampled curve's chord is a little shorter than
// its arc everywhere).
constexpr double kMinReserveStrain = 0.01;

// Sizes every array for N points (padded) with its neutral value.
void SizeArrays(const ModelParams& params, int N, CompiledModel* m) {
  const size_t size = static_cast<size_t>(N) + kColonLanePadding;
  for (CoordinateArrays* xyz :
       {&m->rest_tangent, &m->tether_anchor_m, &m->tether_root_direction, &m->tether_side}) {
    for (auto& v : *xyz) v.assign(size, 0.0);
  }
  for (auto& v : m->own_diag) v.assign(size, 0.0);
  for (std::vector<double>* v : {&m->suspension_rhs_factor, &m->has_tether_side,
                                 &m->tether_length_m, &m->length_m, &m->pair_kink_N_per_m}) {
    v->assign(size, 0.0);
  }
  m->mobile.assign(size, 0);
  m->rest_position_m.assign(size, Eigen::Vector3d::Zero());
  m->pair_pleat_limit.assign(size, 1.0);
  m->pair_toe_N.assign(size, params.colon_tension_stiffness_N);
  m->pair_toe_strain.assign(size, params.colon_toe_strain);
  m->inverse_material_gap.assign(size, 0.0);
  m->pair_reserve_end_m.assign(size, 0.0);
  for (CoordinateArrays* xyz : {&m->pair_rest_direction, &m->pair_rest_mean_tangent}) {
    (*xyz)[0].assign(size, 0.0);
    (*xyz)[1].assign(size, 0.0);
    (*xyz)[2].assign(size, 1.0);
  }
  m->tether_N_per_m.assign(size, 0.0);
  m->relax_factor.assign(size, 0.0);
  m->pair_gap_m.assign(size, 1.0);
}

// Each point's own constants: its suspension (paper §3.3.2: damping D_c h_i
// and K_c h_i in its rest plane P_i = I - t t^T, implicit over dt) and its
// mesentery tether.
void CompilePoints(const ModelParams& params, CompiledModel* m) {
  const auto& pts = params.colon.points;
  const int N = static_cast<int>(pts.size());
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  for (int i = 0; i < N; ++i) {
    const ColonPoint& p = pts[i];
    const TissueParams& t = p.tissue;
    const double h = p.length_m;
    const double K_c = t.suspension_stiffness_N_per_m2 * h;
    m->tether_N_per_m[i] = t.mesentery_stiffness_N_per_m2 * h;
    const Eigen::Matrix3d P = I - p.rest_tangent * p.rest_tangent.transpose();
    const Eigen::Matrix3d own = (t.suspension_damping_N_s_per_m2 * h) * I + (params.dt_s * K_c) * P;
    for (int e = 0; e < 6; ++e) {
      m->own_diag[e][i] = own(internal::kDiagEntry[e][0], internal::kDiagEntry[e][1]);
    }
    m->suspension_rhs_factor[i] = -(params.dt_s * K_c);
    if (t.suspension_relaxation_s > 0.0) {
      m->relax_factor[i] = params.dt_s / (t.suspension_relaxation_s + params.dt_s);
    }
    for (int c = 0; c < 3; ++c) {
      m->rest_tangent[c][i] = p.rest_tangent[c];
      m->tether_anchor_m[c][i] = p.tether_anchor_m[c];
      m->tether_root_direction[c][i] = p.tether_root_direction[c];
      m->tether_side[c][i] = p.tether_side[c];
    }
    m->has_tether_side[i] = p.tether_side.squaredNorm() > 0.5 ? 1.0 : 0.0;
    m->tether_length_m[i] = p.tether_length_m;
    m->length_m[i] = p.length_m;
    m->mobile[i] = t.mobile ? 1 : 0;
    m->rest_position_m[i] = p.rest_position_m;
  }
}

// Each pair's constants: its natural gap, kink tension, pleat limit, toe or
// gathered reserve and rest directions. Returns the least rest gap over
// material gap times pleat limit: how much material a pleated colon can
// pack onto a metre of scope.
double CompilePairs(const ModelParams& params, CompiledModel* m) {
  const auto& pts = params.colon.points;
  const int N = static_cast<int>(pts.size());
  double smallest_pleat_limit = 1.0;
  const auto has_toe = [&](Region r) {
    return ((params.colon_toe_regions >> static_cast<unsigned>(r)) & 1u) != 0;
  };
  for (int i = 0; i + 1 < N; ++i) {
    const double gap = (pts[i + 1].rest_position_m - pts[i].rest_position_m).norm();
    const double T =
        0.5 * (pts[i].tissue.neighbor_tension_N + pts[i + 1].tissue.neighbor_tension_N);
    m->pair_gap_m[i] = gap;
    m->pair_kink_N_per_m[i] = T / gap;
    m->pair_pleat_limit[i] = std::min(pts[i].tissue.pleat_limit, pts[i + 1].tissue.pleat_limit);
    if (has_toe(pts[i].region) && has_toe(pts[i + 1].region)) {
      m->pair_toe_N[i] = params.colon_toe_stiffness_N;
    }
    // The gathered reserve: the gap's material length is its rest arc,
    // longer than the gathered rest gap; it straightens up to it softly.
    const double material_m = std::max(pts[i].material_gap_m, gap);
    const double reserve_strain = material_m / gap - 1.0;
    double rest_over_material = 1.0;
    if (pts[i].tissue.gathered_reserve > 0.0 && pts[i + 1].tissue.gathered_reserve > 0.0 &&
        reserve_strain > kMinReserveStrain) {
      m->pair_toe_N[i] = params.colon_straighten_stiffness_N;
      m->pair_toe_strain[i] = reserve_strain;
      m->pair_reserve_end_m[i] = material_m;
      rest_over_material = gap / material_m;
    }
    m->inverse_material_gap[i] = 1.0 / material_m;
    smallest_pleat_limit =
        std::min(smallest_pleat_limit, m->pair_pleat_limit[i] * rest_over_material);
    const Eigen::Vector3d direction = (pts[i + 1].rest_position_m - pts[i].rest_position_m) / gap;
    const Eigen::Vector3d mean = pts[i].rest_tangent + pts[i + 1].rest_tangent;
    const Eigen::Vector3d mean_tangent =
        mean.norm() > 1e-6 ? Eigen::Vector3d(mean.normalized()) : direction;
    for (int c = 0; c < 3; ++c) {
      m->pair_rest_direction[c][i] = direction[c];
      m->pair_rest_mean_tangent[c][i] = mean_tangent[c];
    }
  }
  return smallest_pleat_limit;
}

void Require(bool ok, const char* field, double value, const char* rule) {
  if (!ok) {
    throw std::invalid_argument(std::string("model experiments: ") + field + " = " +
                                std::to_string(value) + " (" + rule + ")");
  }
}

bool InRange(double x, double lo, double hi) { return std::isfinite(x) && x >= lo && x <= hi; }

}  // namespace

void ValidateExperiments(const ModelExperiments& e) {
  Require(InRange(e.lumen_gather_pleat, 0.0, 0.99), "lumen_gather_pleat", e.lumen_gather_pleat,
          "must be in [0, 0.99] (0: off)");
  Require(InRange(e.lumen_gather_clearance_m, 0.0, 0.05), "lumen_gather_clearance_m",
          e.lumen_gather_clearance_m, "must be in [0, 0.05] m");
}

CompiledModel CompileModel(const ModelParams& params, const ModelExperiments& experiments) {
  ValidateExperiments(experiments);
  CompiledModel m;
  SizeArrays(params, static_cast<int>(params.colon.points.size()), &m);
  CompilePoints(params, &m);
  const double smallest_pleat_limit = CompilePairs(params, &m);
  m.tracking_arc_ratio = params.tracking_arc_ratio > 0.0
                             ? std::max(params.tracking_arc_ratio, 1.2 / smallest_pleat_limit)
                             : 0.0;
  m.experiments = experiments;
  return m;
}

}  // namespace ves::model
