// Contact between the scope samples and the colon (paper §3.5, eqs. 9-17).
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
// the current positions. With one point each way, where the pulled sigmoid
// folded against the fixed rectum, neighbouring planes stood 80-90 degrees
// apart and crossed inside the lumen; a scope sample there changed segment in
// a 5-step cycle and a colon point held it as a ring with 14-16 N on two steps
// of five (mobile-descending, 2026-12-02; docs/model.md, "Contact").
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
  // a sample on the axis as half their offset difference off it, so sliding
  // along a tilted segment read as centimetres of penetration in one step.
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
// a sample sitting on a plane that the moving colon carries back and forth
// otherwise changed segment every step, and with it which colon points took
// its load as a ring (measured 2026-12-02: point 12 of standard-adult 14 N and
// 3 N on alternate steps, the scope's thrust +-80 um, for 30 s of pulling).
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

void EvaluateContacts(const ModelParams& params, ModelState* s, Scratch* sc, StepOutput* out) {
  const int samples = static_cast<int>(s->samples.size());
  const double dt = params.dt_s;
  const double k_t = params.friction_stiffness_N_per_m;
  const int segments = static_cast<int>(params.colon.points.size()) - 1;
  out->contact_count = 0;
  // The inside samples are a suffix; samples before both the old and the new
  // first inside one were outside and stay so (nothing to do for them).
  int first = std::clamp(s->first_inside_sample, 0, samples);
  while (first > 0 && s->samples[first - 1].arc_from_tip_m < s->inserted_m) --first;
  while (first < samples && !(s->samples[first].arc_from_tip_m < s->inserted_m)) ++first;
  const int from = std::min(first, s->first_inside_sample);
  s->first_inside_sample = first;
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
    const int tracked_before = c.segment;
    TrackSegment(&planes, params.contact_search_window, p, &c);
    if (i > 0 && s->contact[i - 1].inside && sc->tracking_arc_ratio > 0.0) {
      // Continuity along the scope (ModelParams::tracking_arc_ratio): the
      // proximal neighbour was tracked first, this step.
      const int neighbour = s->contact[i - 1].segment;
      const int lowest = neighbour - 2;
      if (c.segment < lowest || c.segment > neighbour + 2) {  // else within any reach
        const double scope_gap_m =
            s->samples[i - 1].arc_from_tip_m - s->samples[i].arc_from_tip_m;
        const int highest = neighbour + 2 + static_cast<int>(std::ceil(
            sc->tracking_arc_ratio * scope_gap_m / params.colon.points[neighbour].length_m));
        if (c.segment < lowest || c.segment > highest) {
          c.segment =
              std::clamp(tracked_before, std::max(lowest, 0), std::min(highest, segments - 1));
        }
      }
    }
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
    const TissueParams& tissue = wall.tissue;
    const WallResponse response =
        CalcWallResponse(tissue, params.wall_hardening_ratio, hit.penetration_m);
    const Eigen::Vector3d& n = sc->sample_normal_W[i];
    const double f_n = response.force_N;
    const Eigen::Vector3d f_n_vec = -f_n * n;  // pushes the scope back toward the axis
    // Elastic stick spring: the tangential force that would hold the contact.
    c.slip_m -= c.slip_m.dot(n) * n;
    const Eigen::Vector3d f_t = -k_t * c.slip_m;
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
      if (f_t_norm > r0) c.slip_m *= r0 / f_t_norm;
    }
    c.sliding = alpha > 0.0;
    const Eigen::Vector3d F = f_n_vec + F_t;
    sc->sample_force_W_N[i] = F;
    sc->sample_friction_W_N[i] = F_t;
    sc->sample_normal_force_N[i] = f_n;
    // Linearised stiffness: wall slope + implicit wall damping D_d/dt along n,
    // the stick spring across it. The stick spring stays in even while the
    // contact slides: dropping it at every slip/stick switch makes the
    // linearisation flip from step to step (chatter); the force itself is
    // still capped by the cone at the next evaluation.
    const double k_n = response.slope_N_per_m + tissue.wall_damping_N_s_per_m / dt;
    sc->sample_normal_stiffness_N_per_m[i] = k_n;
    sc->sample_normal_slope_N_per_m[i] = response.slope_N_per_m;

    Contact& out_c = out->contacts[out->contact_count++];
    out_c.sample = i;
    out_c.segment = c.segment;
    const double arc0 = params.colon.points[c.segment].arc_m;
    out_c.colon_arc_m = arc0 + hit.t * (params.colon.points[c.segment + 1].arc_m - arc0);
    out_c.scope_arc_from_tip_m = s->samples[i].arc_from_tip_m;
    out_c.p_W = p;
    out_c.normal_W = n;
    out_c.penetration_m = hit.penetration_m;
    out_c.normal_force_N = f_n;
    out_c.force_on_scope_W_N = F;
    out_c.alpha = alpha;
    out_c.beyond_threshold = response.beyond_threshold;
  }
  EvaluateRingContacts(params, s, sc);
}

void EvaluateRingContacts(const ModelParams& params, ModelState* s, Scratch* sc) {
  // Colon points between the segments two neighbouring samples track (the
  // colon pleated onto the scope there) have no sample of their own: their
  // rings must still contain the scope piece between the samples, or the
  // colon could fold away from the scope and the scope cut across the fold.
  const int samples = static_cast<int>(s->samples.size());
  const int last_point = static_cast<int>(params.colon.points.size()) - 1;
  const double scope_radius_m = 0.5 * params.scope.outer_diameter_m;
  int count = 0;  // (a local: the stores into each RingContact could alias the member)
  std::fill(sc->ring_held.begin(), sc->ring_held.end(), std::uint8_t{0});
  const double onset_rate = params.ring_onset_s > 0.0 ? params.dt_s / params.ring_onset_s : 1.0;
  for (int i = s->first_inside_sample; i + 1 < samples; ++i) {
    const int from = std::max(s->contact[i].segment + 2, 1);
    const int to = std::min(s->contact[i + 1].segment - 1, last_point);
    if (to < from) continue;
    const Eigen::Vector3d& a = s->p_WSample[i];
    const Eigen::Vector3d ab = s->p_WSample[i + 1] - a;
    const double ab2 = std::max(ab.squaredNorm(), 1e-12);
    for (int m = from; m <= to; ++m) {
      const ColonPoint& ring = params.colon.points[m];
      const Eigen::Vector3d& x = s->p_WColon[m];
      const double t = std::clamp((x - a).dot(ab) / ab2, 0.0, 1.0);
      const Eigen::Vector3d q = a + t * ab;
      const Eigen::Vector3d w = q - x;
      const double d = w.norm();
      const double penetration_m = d + scope_radius_m - s->colon_lumen_radius_m[m];
      if (!(penetration_m > 0.0) || d < 1e-12) continue;
      const WallResponse r =
          CalcWallResponse(ring.tissue, params.wall_hardening_ratio, penetration_m);
      RingContact& rc = sc->ring_contacts[count++];
      rc.point = m;
      rc.sample = i;
      rc.piece_t = t;
      rc.p_W = q;
      rc.normal_W = w / d;
      rc.penetration_m = penetration_m;
      // A point handed from a sample's segment to the piece between two
      // samples takes its ring load over ring_onset_s: where the colon folds
      // sharply it arrives millimetres inside (docs/model.md, "Ring contacts").
      const double onset = std::min(1.0, s->ring_onset[m] + onset_rate);
      s->ring_onset[m] = onset;
      sc->ring_held[m] = 1;
      rc.onset = onset;
      rc.force_N = onset * r.force_N;
      rc.slope_N_per_m = onset * r.slope_N_per_m;
      rc.stiffness_N_per_m =
          onset * (r.slope_N_per_m + ring.tissue.wall_damping_N_s_per_m / params.dt_s);
    }
  }
  sc->ring_contact_count = count;
  for (size_t m = 0; m < sc->ring_held.size(); ++m) {
    if (!sc->ring_held[m]) s->ring_onset[m] = 0.0;
  }
}

}  // namespace ves::model::internal
