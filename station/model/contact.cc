// Contact between the scope samples and the colon (paper §3.5, eqs. 9-17):
// the lumen's planes, the tracking of each sample's colon segment, the wall's
// response and the friction cone. Ring contacts are in ring_contact.cc.
#include <algorithm>
#include <cmath>

#include "station/model/internal.h"

namespace ves::model::internal {

LumenPlanes::LumenPlanes(const ModelState& state, Scratch* cache)
    : state_(state),
      normal_(cache->lumen_normal_W.data()),
      known_(cache->lumen_normal_known.data()) {
  std::fill(cache->lumen_normal_known.begin(), cache->lumen_normal_known.end(), std::uint8_t{0});
}

// Normal of the lumen's plane at point i for the contacts: the tube's
// direction over two points each way (the chords i-1..i+1 and i-2..i+2), from
// the current positions. Over one point each way, where a pulled sigmoid
// folds against the fixed rectum, neighbouring planes stand 80-90 degrees
// apart and cross inside the lumen: a scope sample there changes segment in
// a cycle of a few steps and a colon point holds it as a ring with a force
// that comes and goes (docs/model.md, "Contact").
Eigen::Vector3d LumenPlanes::Normal(int i) {
  if (known_ != nullptr && known_[i] != 0) return normal_[i];
  const auto& p = state_.p_WColon;
  const int N = static_cast<int>(p.size());
  const Eigen::Vector3d chord = p[std::min(i + 1, N - 1)] - p[std::max(i - 1, 0)] +
                                p[std::min(i + 2, N - 1)] - p[std::max(i - 2, 0)];
  const double length = chord.norm();
  const Eigen::Vector3d normal =
      length > 1e-12 ? Eigen::Vector3d(chord / length) : state_.colon_tangent[i];
  if (known_ != nullptr) {
    normal_[i] = normal;
    known_[i] = 1;
  }
  return normal;
}

WallResponse CalcWallResponse(const TissueParams& tissue, double hardening_ratio, double l_m) {
  WallResponse r;
  if (!(l_m > 0.0)) return r;
  const double K_d = tissue.wall_stiffness_N_per_m;
  const double L = tissue.deformation_threshold_m;
  if (l_m <= L) {
    // paper eq. (9), radial term: the wall alone deforms, K_d ||l||.
    r.force_N = K_d * l_m;
    r.slope_N_per_m = K_d;
  } else {
    // paper eq. (10): beyond L the wall stops yielding and the segment point
    // itself is pushed; the much stiffer wall hands the load to the suspension.
    const double K_hard = hardening_ratio * K_d;
    r.force_N = K_d * L + K_hard * (l_m - L);
    r.slope_N_per_m = K_hard;
    r.beyond_threshold = true;
  }
  return r;
}

SegmentHit CalcSegmentHit(const ModelParams& params, LumenPlanes* planes, int k,
                          const Eigen::Vector3d& p) {
  // The lumen is the circles of radius R_i centred on the current r_i, in the
  // planes normal to the tube's current tangents (paper §3.3.2, with the
  // planes following the moving colon): measure the sample in the two planes
  // that bracket it and blend by its axial position between them.
  const ModelState& s = planes->state();
  const auto& pts = params.colon.points;
  const int last = static_cast<int>(pts.size()) - 1;
  const Eigen::Vector3d pa = p - s.p_WColon[k];
  const Eigen::Vector3d pb = p - s.p_WColon[k + 1];
  const Eigen::Vector3d ta = planes->Normal(k);
  const Eigen::Vector3d tb = planes->Normal(k + 1);
  const double da = pa.dot(ta);   // >= 0 past plane k
  const double db = pb.dot(tb);   // < 0 before plane k+1
  SegmentHit hit;
  hit.t = da - db > 1e-12 ? std::clamp(da / (da - db), 0.0, 1.0) : 0.5;
  const Eigen::Vector3d wa = pa - da * ta;
  const Eigen::Vector3d wb = pb - db * tb;
  // The sample's offset from the lumen centre interpolated at t. Its norm, not
  // the blend of the two in-plane distances: when neighbouring points are
  // displaced differently (a stretched sigmoid) the blend of distances counts
  // a sample on the axis as half their offset difference off it, and sliding
  // along a tilted segment would read as centimetres of penetration in one
  // step.
  const Eigen::Vector3d w = (1.0 - hit.t) * wa + hit.t * wb;
  const double w_norm = w.norm();
  const double rho = w_norm;
  hit.normal = w_norm > 1e-12 ? Eigen::Vector3d(w * (1.0 / w_norm)) : ta.unitOrthogonal();
  const double radius_a_m = s.colon_lumen_radius_m[k], radius_b_m = s.colon_lumen_radius_m[k + 1];
  hit.radius_m = radius_a_m + hit.t * (radius_b_m - radius_a_m);
  const double scope_radius_m = 0.5 * params.scope.outer_diameter_m;
  hit.penetration_m = rho + scope_radius_m - hit.radius_m;
  if (k + 1 == last && db > 0.0) {
    // Past the deepest point: the closed end (cecum pole) stops the tip.
    const double axial_m = db + scope_radius_m;
    if (axial_m > hit.penetration_m) {
      hit.penetration_m = axial_m;
      hit.normal = tb;
      hit.end_cap = true;
    }
  }
  return hit;
}

// Local search: step plane by plane toward the sample, never more than
// `window` segments, so two loops that touch in space cannot swap a sample.
// A sample changes segment only once it is kTrackingHysteresis_m past the
// plane between them (within it the hit is measured in that plane, t clamped):
// without it, a sample sitting on a plane that the moving colon carries back
// and forth changes segment every step, and with it which colon points take
// its load as a ring (a force alternating between about 14 N and 3 N from
// one step to the next while the scope is pulled).
void TrackSegment(LumenPlanes* planes, int window, const Eigen::Vector3d& p, SampleContact* c) {
  const ModelState& s = planes->state();
  const int segments = static_cast<int>(s.p_WColon.size()) - 1;
  int k = std::clamp(c->segment, 0, segments - 1);
  int direction = 0;
  for (int step = 0; step < window; ++step) {
    const double past_next = (p - s.p_WColon[k + 1]).dot(planes->Normal(k + 1));
    const double past_this = (p - s.p_WColon[k]).dot(planes->Normal(k));
    if (past_next >= kTrackingHysteresis_m && k + 1 < segments && direction >= 0) {
      ++k;
      direction = 1;
    } else if (past_this < -kTrackingHysteresis_m && k > 0 && direction <= 0) {
      --k;
      direction = -1;
    } else {
      break;
    }
  }
  c->segment = k;
}

namespace {

// The inside samples are a suffix: moves first_inside_sample to where the
// scope is now and returns the first sample to visit (samples before both
// the old and the new first inside one were outside and stay so).
int UpdateFirstInsideSample(ModelState* s) {
  const int samples = static_cast<int>(s->samples.size());
  int first = std::clamp(s->first_inside_sample, 0, samples);
  while (first > 0 && s->samples[first - 1].arc_from_tip_m < s->inserted_m) --first;
  while (first < samples && !(s->samples[first].arc_from_tip_m < s->inserted_m)) ++first;
  const int from = std::min(first, s->first_inside_sample);
  s->first_inside_sample = first;
  return from;
}

// Moves sample i's tracked segment (TrackSegment), then keeps it within
// reach of its proximal neighbour's, tracked first this step
// (ModelParams::tracking_arc_ratio).
void TrackSample(const ModelParams& params, const CompiledModel& model, LumenPlanes* planes,
                 const ModelState& s, int i, SampleContact* c) {
  const int segments = static_cast<int>(params.colon.points.size()) - 1;
  const int tracked_before = c->segment;
  TrackSegment(planes, params.contact_search_window, s.p_WSample[i], c);
  if (i == 0 || !s.contact[i - 1].inside || !(model.tracking_arc_ratio > 0.0)) return;
  const int neighbour = s.contact[i - 1].segment;
  const int lowest = neighbour - 2;
  if (c->segment >= lowest && c->segment <= neighbour + 2) return;  // within any reach
  const double scope_gap_m = s.samples[i - 1].arc_from_tip_m - s.samples[i].arc_from_tip_m;
  const int highest = neighbour + 2 + static_cast<int>(std::ceil(
      model.tracking_arc_ratio * scope_gap_m / params.colon.points[neighbour].length_m));
  if (c->segment < lowest || c->segment > highest) {
    c->segment = std::clamp(tracked_before, std::max(lowest, 0), std::min(highest, segments - 1));
  }
}

// The force of a touching sample's contact on the scope, eqs. (9)-(17): the
// wall's normal response and the friction of its stick spring, blended
// between the cones (eq. 16); writes the sample's force, friction and
// linearised stiffness into scratch and returns alpha.
double EvaluateSampleForce(const ModelParams& params, const TissueParams& tissue,
                           const WallResponse& response, int i, SampleContact* c, Scratch* sc) {
  const double k_t = params.friction_stiffness_N_per_m;
  const Eigen::Vector3d& n = sc->sample_normal_W[i];
  const double f_n = response.force_N;
  const Eigen::Vector3d f_n_vec = -f_n * n;  // pushes the scope back toward the axis
  // Elastic stick spring: the tangential force that would hold the contact.
  c->slip_m -= c->slip_m.dot(n) * n;
  const Eigen::Vector3d f_t = -k_t * c->slip_m;
  const double f_t_norm = f_t.norm();
  const double mu_s = tissue.static_friction;
  const double mu_d = tissue.dynamic_friction;
  const double inner = mu_s * f_n;
  const double r0 = params.outer_cone_ratio * inner;
  double alpha = 0.0;
  Eigen::Vector3d F_t = f_t;
  if (f_t_norm > inner) {
    // paper eq. (16): alpha = (||f_t|| - F_s||f_n||) / (r0 - F_s||f_n||) between the cones.
    alpha = f_t_norm >= r0 ? 1.0 : (f_t_norm - inner) / (r0 - inner);
    // paper eq. (17): F = (1-alpha) f + alpha (F_d ||f_n|| f_t/||f_t|| + f_n).
    F_t = (1.0 - alpha) * f_t + (alpha * mu_d * f_n / f_t_norm) * f_t;
    // The spring rides the outer cone: further slip keeps alpha = 1 (mu_d);
    // a reversal brings it back through the blend, without a jump.
    if (f_t_norm > r0) c->slip_m *= r0 / f_t_norm;
  }
  c->sliding = alpha > 0.0;
  sc->sample_force_W_N[i] = f_n_vec + F_t;
  sc->sample_friction_W_N[i] = F_t;
  sc->sample_normal_force_N[i] = f_n;
  // Linearised stiffness: wall slope + implicit wall damping D_d/dt along n,
  // the stick spring across it. The stick spring stays in even while the
  // contact slides: dropped at every slip/stick switch, the linearisation
  // would flip from step to step (chatter); the force itself is still
  // capped by the cone at the next evaluation.
  sc->sample_normal_stiffness_N_per_m[i] =
      response.slope_N_per_m + tissue.wall_damping_N_s_per_m / params.dt_s;
  sc->sample_normal_slope_N_per_m[i] = response.slope_N_per_m;
  return alpha;
}

}  // namespace

void EvaluateContacts(const ModelParams& params, const CompiledModel& model, ModelState* s,
                      Scratch* sc, StepOutput* out) {
  const int samples = static_cast<int>(s->samples.size());
  out->contact_count = 0;
  const int from = UpdateFirstInsideSample(s);
  const int first = s->first_inside_sample;
  LumenPlanes planes(*s, sc);  // the colon points stay put until SolveColon
  for (int i = from; i < samples; ++i) {
    SampleContact& c = s->contact[i];
    const bool inside = i >= first;
    // Still outside the anus: everything below was zeroed when it came out.
    if (!inside && !c.inside) continue;
    sc->sample_force_W_N[i].setZero();
    sc->sample_normal_stiffness_N_per_m[i] = 0.0;
    sc->sample_normal_force_N[i] = 0.0;
    if (!inside) {
      c = SampleContact{};
      continue;
    }
    if (!c.inside) {
      c = SampleContact{};
      c.inside = true;  // enters at the anus: segment 0
    }
    const Eigen::Vector3d& p = s->p_WSample[i];
    TrackSample(params, model, &planes, *s, i, &c);
    const SegmentHit hit = CalcSegmentHit(params, &planes, c.segment, p);
    c.segment_t = hit.t;
    c.penetration_m = hit.penetration_m;
    sc->sample_normal_W[i] = hit.normal;
    if (!(hit.penetration_m > 0.0)) {
      c.touching = false;
      c.sliding = false;
      c.slip_m.setZero();
      continue;
    }
    c.touching = true;
    if (params.contacts_across_scope && !hit.end_cap && i + 1 < samples) {
      // The wall presses on the scope's side, so across its axis. Where the
      // colon is folded askew the lumen's plane is tilted against the scope
      // and its normal would hold the shaft along its length like a barb.
      // (An offset almost along the axis gives no side to push on: kept.)
      const Eigen::Vector3d axis = s->X_WLink[s->samples[i].link].linear().col(2);
      const Eigen::Vector3d across = hit.normal - hit.normal.dot(axis) * axis;
      const double across_norm = across.norm();
      if (across_norm > 1e-3) sc->sample_normal_W[i] = across / across_norm;
    }
    const ColonPoint& wall = params.colon.points[hit.t < 0.5 ? c.segment : c.segment + 1];
    const WallResponse response =
        CalcWallResponse(wall.tissue, params.wall_hardening_ratio, hit.penetration_m);
    const double alpha = EvaluateSampleForce(params, wall.tissue, response, i, &c, sc);

    Contact& out_c = out->contacts[out->contact_count++];
    out_c.sample = i;
    out_c.segment = c.segment;
    const double arc0 = params.colon.points[c.segment].arc_m;
    out_c.colon_arc_m = arc0 + hit.t * (params.colon.points[c.segment + 1].arc_m - arc0);
    out_c.scope_arc_from_tip_m = s->samples[i].arc_from_tip_m;
    out_c.p_W = p;
    out_c.normal_W = sc->sample_normal_W[i];
    out_c.penetration_m = hit.penetration_m;
    out_c.normal_force_N = response.force_N;
    out_c.force_on_scope_W_N = sc->sample_force_W_N[i];
    out_c.alpha = alpha;
    out_c.beyond_threshold = response.beyond_threshold;
  }
  EvaluateRingContacts(params, s, sc);
}

}  // namespace ves::model::internal
