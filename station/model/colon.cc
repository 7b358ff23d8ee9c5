#include "station/model/colon.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

namespace ves::model {
namespace {

void Require(bool ok, const std::string& what, double value, const char* rule) {
  if (!ok) {
    throw std::invalid_argument("colon: " + what + " = " + std::to_string(value) + " (" + rule +
                                ")");
  }
}

bool InRange(double x, double lo, double hi) { return std::isfinite(x) && x >= lo && x <= hi; }

// A mobile point hanging less than this far from its root has no side.
constexpr double kMinHang_m = 0.01;

// Rotation-minimising plane bases, so (u, v) turn smoothly along the colon.
void CalcPlaneBases(ColonSpec* colon) {
  Eigen::Vector3d u = colon->points[0].rest_tangent.unitOrthogonal();
  for (ColonPoint& p : colon->points) {
    u -= u.dot(p.rest_tangent) * p.rest_tangent;
    if (u.norm() < 1e-6) u = p.rest_tangent.unitOrthogonal();
    u.normalize();
    p.plane_u = u;
    p.plane_v = p.rest_tangent.cross(u);
  }
}

// The path through points [a, b] with those in (a, b) drawn toward their
// anchors: anchor + scale (rest - anchor).
double GatheredPathLength(const ColonSpec& colon, int a, int b, double scale) {
  const auto& pts = colon.points;
  auto at = [&](int k) -> Eigen::Vector3d {
    if (k == a || k == b) return pts[k].rest_position_m;
    return pts[k].tether_anchor_m + scale * (pts[k].rest_position_m - pts[k].tether_anchor_m);
  };
  double length_m = 0.0;
  for (int k = a; k < b; ++k) length_m += (at(k + 1) - at(k)).norm();
  return length_m;
}

// A gathered run's path is at least this much longer than its root: drawn
// onto the root it would have no room to fold.
constexpr double kMinGatheredPathOverRoot = 1.05;

}  // namespace

bool IsMobileByDefault(Region region) {
  return region == Region::kSigmoid || region == Region::kTransverse;
}

MobilityDefaults DefaultMobility(Region region, bool mobile) {
  if (!mobile) {
    // Retroperitoneal: held elastically at its place, a few millimetres of
    // travel under the loads of insertion.
    return {.mesentery_length_m = 0.0,
            .mesentery_stiffness_N_per_m2 = 1.0e5,
            .pleat_limit = 0.9,
            .suspension_relaxation_s = 0.0,
            .gathered_reserve = 0.0};
  }
  // Mesocolon height 6.3 cm (sigmoid) and 7.4 cm (transverse); a persistent
  // descending mesocolon is taken as the sigmoid's.
  const double length_m = region == Region::kTransverse ? 0.074 : 0.063;
  // No gathered reserve by default: with the sigmoid's at 0.3 and the
  // transverse's at 0.2 loops form under a push, but the scripted expert
  // does not yet reach every shipped cecum (docs/model.md, "The gathered
  // reserve"); a case sets it per region.
  return {.mesentery_length_m = length_m,
          .mesentery_stiffness_N_per_m2 = 1000.0,
          .pleat_limit = 0.3,
          .suspension_relaxation_s = 10.0,
          .gathered_reserve = 0.0};
}

void ValidateTissue(const TissueParams& t) {
  Require(InRange(t.suspension_stiffness_N_per_m2, 0.0, 1.0e7), "suspension_stiffness_N_per_m2",
          t.suspension_stiffness_N_per_m2, "must be in [0, 1e7]");
  Require(InRange(t.suspension_damping_N_s_per_m2, 1.0e-3, 1.0e6),
          "suspension_damping_N_s_per_m2", t.suspension_damping_N_s_per_m2,
          "must be in [1e-3, 1e6]");
  Require(InRange(t.wall_stiffness_N_per_m, 1.0, 1.0e6), "wall_stiffness_N_per_m",
          t.wall_stiffness_N_per_m, "must be in [1, 1e6]");
  Require(InRange(t.wall_damping_N_s_per_m, 0.0, 1.0e4), "wall_damping_N_s_per_m",
          t.wall_damping_N_s_per_m, "must be in [0, 1e4]");
  Require(InRange(t.deformation_threshold_m, 0.0, 0.1), "deformation_threshold_m",
          t.deformation_threshold_m, "must be in [0, 0.1]");
  Require(InRange(t.static_friction, 0.0, 2.0), "static_friction", t.static_friction,
          "must be in [0, 2]");
  Require(InRange(t.dynamic_friction, 0.0, t.static_friction), "dynamic_friction",
          t.dynamic_friction, "must be in [0, static_friction]");
  Require(InRange(t.neighbor_tension_N, 0.0, 1.0e4), "neighbor_tension_N", t.neighbor_tension_N,
          "must be in [0, 1e4]");
  Require(InRange(t.mesentery_length_m, 0.0, 0.5), "mesentery_length_m", t.mesentery_length_m,
          "must be in [0, 0.5] m");
  Require(InRange(t.mesentery_stiffness_N_per_m2, 0.0, 1.0e7), "mesentery_stiffness_N_per_m2",
          t.mesentery_stiffness_N_per_m2, "must be in [0, 1e7]");
  Require(InRange(t.pleat_limit, 0.05, 1.0), "pleat_limit", t.pleat_limit,
          "must be in [0.05, 1]");
  Require(InRange(t.suspension_relaxation_s, 0.0, 1.0e6), "suspension_relaxation_s",
          t.suspension_relaxation_s, "must be in [0, 1e6] s (0: never)");
  Require(InRange(t.gathered_reserve, 0.0, kMaxGatheredReserve), "gathered_reserve",
          t.gathered_reserve, "must be in [0, 0.6]");
}

void ValidateColon(const ColonSpec& colon) {
  const int n = static_cast<int>(colon.points.size());
  Require(InRange(colon.mesentery_shear_ratio, 1.0, 100.0), "mesentery_shear_ratio",
          colon.mesentery_shear_ratio, "must be in [1, 100]");
  Require(InRange(colon.mesentery_crossing_m, 0.0, 1.0), "mesentery_crossing_m",
          colon.mesentery_crossing_m, "must be in [0, 1] m");
  Require(InRange(colon.root_wall_stiffness_N_per_m2, 0.0, 1.0e7), "root_wall_stiffness_N_per_m2",
          colon.root_wall_stiffness_N_per_m2, "must be in [0, 1e7]");
  Require(n >= 3 && n <= 20000, "points.size", n, "must be in [3, 20000]");
  for (int i = 0; i < n; ++i) {
    const ColonPoint& p = colon.points[i];
    const std::string at = "points[" + std::to_string(i) + "].";
    Require(p.rest_position_m.allFinite(), at + "rest_position_m.norm", p.rest_position_m.norm(),
            "must be finite");
    Require(std::abs(p.rest_tangent.norm() - 1.0) < 1e-6, at + "rest_tangent.norm",
            p.rest_tangent.norm(), "must be 1");
    Require(InRange(p.radius_m, 1.0e-3, 0.2), at + "radius_m", p.radius_m,
            "must be in [0.001, 0.2] m");
    Require(InRange(p.length_m, 1.0e-5, 1.0), at + "length_m", p.length_m,
            "must be in [1e-5, 1] m");
    if (i > 0) {
      const double gap = (p.rest_position_m - colon.points[i - 1].rest_position_m).norm();
      Require(gap > 1.0e-6, at + "spacing_m", gap, "consecutive points must differ");
    }
    ValidateTissue(p.tissue);
    Require(p.tether_anchor_m.allFinite(), at + "tether_anchor_m.norm", p.tether_anchor_m.norm(),
            "must be finite");
    Require(InRange(p.tether_length_m, 0.0, 10.0), at + "tether_length_m", p.tether_length_m,
            "must be in [0, 10] m");
  }
}

ColonSpec MakeColonFromPoints(const std::vector<Eigen::Vector3d>& positions_m, double radius_m,
                              const TissueParams& tissue, Region region) {
  const int n = static_cast<int>(positions_m.size());
  Require(n >= 3, "positions.size", n, "must be >= 3");
  ColonSpec colon;
  colon.points.resize(n);
  double arc_m = 0.0;
  for (int i = 0; i < n; ++i) {
    ColonPoint& p = colon.points[i];
    p.rest_position_m = positions_m[i];
    if (i > 0) arc_m += (positions_m[i] - positions_m[i - 1]).norm();
    p.arc_m = arc_m;
    const int a = std::max(i - 1, 0);
    const int b = std::min(i + 1, n - 1);
    const Eigen::Vector3d chord = positions_m[b] - positions_m[a];
    Require(chord.norm() > 1e-9, "positions[" + std::to_string(i) + "].spacing_m", chord.norm(),
            "consecutive points must differ");
    p.rest_tangent = chord.normalized();
    p.length_m = 0.5 * ((positions_m[b] - positions_m[i]).norm() +
                        (positions_m[i] - positions_m[a]).norm());
    p.material_gap_m = i + 1 < n ? (positions_m[i + 1] - positions_m[i]).norm() : 0.0;
    p.radius_m = radius_m;
    p.region = region;
    p.tissue = tissue;
  }
  CalcPlaneBases(&colon);
  CalcMesenteryAnchors(&colon);
  ValidateColon(colon);
  return colon;
}

void CalcMesenteryAnchors(ColonSpec* colon) {
  const double shear_ratio = colon->mesentery_shear_ratio;
  auto& pts = colon->points;
  const int n = static_cast<int>(pts.size());
  int i = 0;
  while (i < n) {
    if (!pts[i].tissue.mobile) {
      pts[i].tether_anchor_m = pts[i].rest_position_m;
      pts[i].tether_length_m = pts[i].tissue.mesentery_length_m;
      pts[i].tether_root_direction.setZero();
      pts[i].tether_side.setZero();
      ++i;
      continue;
    }
    int end = i;  // the run of mobile points is [i, end)
    while (end < n && pts[end].tissue.mobile) ++end;
    const Eigen::Vector3d root_a = pts[std::max(i - 1, 0)].rest_position_m;
    const Eigen::Vector3d root_b = pts[std::min(end, n - 1)].rest_position_m;
    const Eigen::Vector3d chord = root_b - root_a;
    const double chord2 = chord.squaredNorm();
    for (int k = i; k < end; ++k) {
      ColonPoint& p = pts[k];
      const double arc_a = pts[std::max(i - 1, 0)].arc_m;
      const double arc_b = pts[std::min(end, n - 1)].arc_m;
      const double s =
          colon->mesentery_anchor_by_arc && arc_b > arc_a
              ? std::clamp((p.arc_m - arc_a) / (arc_b - arc_a), 0.0, 1.0)
          : chord2 > 1e-12 ? std::clamp((p.rest_position_m - root_a).dot(chord) / chord2, 0.0, 1.0)
                           : 0.0;
      p.tether_anchor_m = root_a + s * chord;
      p.tether_root_direction =
          chord2 > 1e-12 ? Eigen::Vector3d(chord / std::sqrt(chord2)) : Eigen::Vector3d::Zero();
      const Eigen::Vector3d hang = p.rest_position_m - p.tether_anchor_m;
      p.tether_side = hang.norm() > kMinHang_m ? Eigen::Vector3d(hang.normalized())
                                               : Eigen::Vector3d::Zero();
      p.tether_length_m = std::max(
          p.tissue.mesentery_length_m,
          CalcTetherDistance(p.rest_position_m - p.tether_anchor_m, p.tether_root_direction,
                             shear_ratio));
    }
    i = end;
  }
  if (n > 0) {
    Eigen::Vector3d lo = pts[0].rest_position_m;
    Eigen::Vector3d hi = lo;
    for (const ColonPoint& p : pts) {
      lo = lo.cwiseMin(p.rest_position_m);
      hi = hi.cwiseMax(p.rest_position_m);
    }
    colon->abdomen_min_m = lo - Eigen::Vector3d::Constant(colon->abdomen_margin_m);
    colon->abdomen_max_m = hi + Eigen::Vector3d::Constant(colon->abdomen_margin_m);
  }
}

void GatherMobileColon(ColonSpec* colon) {
  auto& pts = colon->points;
  const int n = static_cast<int>(pts.size());
  bool moved = false;
  int i = 0;
  while (i < n) {
    if (!pts[i].tissue.mobile) {
      ++i;
      continue;
    }
    int end = i;  // the run of mobile points is [i, end)
    double reserve_sum = 0.0;
    while (end < n && pts[end].tissue.mobile) reserve_sum += pts[end++].tissue.gathered_reserve;
    // Its path runs from the fixed point before it to the one after it (or
    // its own ends at the colon's ends), which stay.
    const int a = std::max(i - 1, 0);
    const int b = std::min(end, n - 1);
    const double reserve = reserve_sum / (end - i);
    const double material_m = GatheredPathLength(*colon, a, b, 1.0);
    const double root_m = GatheredPathLength(*colon, a, b, 0.0);
    const double target_m = std::max((1.0 - reserve) * material_m, kMinGatheredPathOverRoot * root_m);
    i = end;
    if (reserve <= 0.0 || b - a < 2 || target_m >= material_m) continue;
    // The path grows with the scale: bisect for the target.
    double lo = 0.0, hi = 1.0;
    for (int iteration = 0; iteration < 60; ++iteration) {
      const double mid = 0.5 * (lo + hi);
      (GatheredPathLength(*colon, a, b, mid) < target_m ? lo : hi) = mid;
    }
    const double scale = 0.5 * (lo + hi);
    for (int k = a + 1; k < b; ++k) {
      ColonPoint& p = pts[k];
      p.rest_position_m = p.tether_anchor_m + scale * (p.rest_position_m - p.tether_anchor_m);
    }
    moved = true;
  }
  if (!moved) return;
  for (int k = 0; k < n; ++k) {
    const int a = std::max(k - 1, 0);
    const int b = std::min(k + 1, n - 1);
    pts[k].rest_tangent = (pts[b].rest_position_m - pts[a].rest_position_m).normalized();
  }
  CalcPlaneBases(colon);
  CalcMesenteryAnchors(colon);
  ValidateColon(*colon);
}

void MakeSuspensionStiff(ColonSpec* colon) {
  double stiffest = kStiffSuspension_N_per_m2;
  for (const ColonPoint& p : colon->points) {
    stiffest = std::max(stiffest, p.tissue.suspension_stiffness_N_per_m2);
  }
  for (ColonPoint& p : colon->points) {
    p.tissue.suspension_stiffness_N_per_m2 = stiffest;
    p.tissue.mobile = false;
    p.tissue.mesentery_length_m = 0.0;
    p.tissue.mesentery_stiffness_N_per_m2 = stiffest;
    p.tissue.pleat_limit = 1.0;
    p.tissue.suspension_relaxation_s = 0.0;
    p.tissue.gathered_reserve = 0.0;  // the shape stays as gathered, now taut
  }
  auto& pts = colon->points;
  for (size_t i = 0; i + 1 < pts.size(); ++i) {
    pts[i].material_gap_m = (pts[i + 1].rest_position_m - pts[i].rest_position_m).norm();
  }
  CalcMesenteryAnchors(colon);
}

}  // namespace ves::model
