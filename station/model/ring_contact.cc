// Ring contacts (docs/model.md, "Ring contacts"): colon points the scope
// runs through between two of its samples, held around the scope piece
// between them; their wall response is eqs. (9)-(10) (contact.cc).
#include <algorithm>
#include <cmath>

#include "station/model/internal.h"

namespace ves::model::internal {

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
