// What a step reports (StepOutput): the wall force and deformation at each
// colon point, the mesentery stretch (paper §3.3.1), the pleat ratio, their
// peaks, the tip's place along the colon and the speed of everything.
#include <algorithm>
#include <cmath>

#include "station/model/internal.h"

namespace ves::model::internal {
namespace {

// The contacts' normal forces shared onto the colon points (a sample's
// between its segment's two points, a ring's onto its point) and the largest
// radial deformation at each point.
void ShareWallForces(ModelState* s, const Scratch& sc, StepOutput* out) {
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
  for (int j = 0; j < sc.ring_contact_count; ++j) {
    const RingContact& rc = sc.ring_contacts[j];
    out->wall_force_N[rc.point] += rc.force_N;
    s->wall_deformation_m[rc.point] = std::max(s->wall_deformation_m[rc.point], rc.penetration_m);
  }
}

// Where the tip is now, along the colon's material (tracked on a copy of
// its contact memory, which itself moves on at the next step's evaluation).
double CalcTipArc(const ModelParams& params, const ModelState& s) {
  const auto& pts = params.colon.points;
  const int samples = static_cast<int>(s.samples.size());
  SampleContact tip = s.contact[samples - 1];
  if (!tip.inside) return 0.0;
  TrackSegment(s, params.contact_search_window, s.p_WSample[samples - 1], &tip);
  const int k = tip.segment;
  const double t = CalcSegmentHit(params, s, k, s.p_WSample[samples - 1]).t;
  const double a0 = pts[k].arc_m;
  return a0 + t * (pts[k + 1].arc_m - a0);
}

}  // namespace

double WriteStepOutputs(const ModelParams& params, const CompiledModel& model,
                        double sample_speed2, ModelState* s, const Scratch* sc,
                        StepOutput* out) {
  const auto& pts = params.colon.points;
  const int N = static_cast<int>(pts.size());
  ShareWallForces(s, *sc, out);
  double speed2 = sample_speed2;
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
  // The points' constants from the compiled model's compact arrays: the
  // points themselves are large and this loop visits every one.
  for (int i = 0; i < N; ++i) {
    const double moved2_m2 = s->colon_displacement_m[i].squaredNorm();
    colon_sum_m2 += moved2_m2;
    speed2 += s->colon_velocity_m_per_s[i].squaredNorm();
    // Mesentery stretch: how far the tether is pulled beyond its reach.
    const double stretch = std::max(0.0, s->colon_tether_distance_m[i] - model.tether_length_m[i]);
    out->stretch_m[i] = stretch;
    if (stretch > peak_stretch_m) {
      peak_stretch_m = stretch;
      peak_stretch_arc_m = pts[i].arc_m;
    }
    if (model.mobile[i] == 0) {
      peak_fixed_moved2_m2 = std::max(peak_fixed_moved2_m2, moved2_m2);
    }
    peak_wall_force_N = std::max(peak_wall_force_N, out->wall_force_N[i]);
    // Pleat ratio: the tube's current length over its rest length around r_i.
    const double gap_ahead_m = i + 1 < N ? s->colon_gap_m[i] : 0.0;
    peak_material_ratio =
        std::max(peak_material_ratio, gap_ahead_m * model.inverse_material_gap[i]);
    const double rest_m = model.length_m[i];  // half of each neighbouring gap at rest
    out->pleat_ratio[i] = 0.5 * (gap_ahead_m + gap_behind_m) / rest_m;
    gap_behind_m = gap_ahead_m;
  }
  out->peak_stretch_m = peak_stretch_m;
  out->peak_stretch_arc_m = peak_stretch_arc_m;
  out->peak_wall_force_N = peak_wall_force_N;
  out->peak_fixed_displacement_m = std::sqrt(peak_fixed_moved2_m2);
  out->peak_wall_strain = peak_material_ratio - 1.0;
  s->tip_arc_m = CalcTipArc(params, *s);
  out->velocity_norm_m_per_s = std::sqrt(speed2);
  return colon_sum_m2;
}

}  // namespace ves::model::internal
