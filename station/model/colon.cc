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

}  // namespace

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
}

void ValidateColon(const ColonSpec& colon) {
  const int n = static_cast<int>(colon.points.size());
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
    p.radius_m = radius_m;
    p.region = region;
    p.tissue = tissue;
  }
  // Rotation-minimising plane bases, so (u, v) turn smoothly along the colon.
  Eigen::Vector3d u = colon.points[0].rest_tangent.unitOrthogonal();
  for (ColonPoint& p : colon.points) {
    u -= u.dot(p.rest_tangent) * p.rest_tangent;
    if (u.norm() < 1e-6) u = p.rest_tangent.unitOrthogonal();
    u.normalize();
    p.plane_u = u;
    p.plane_v = p.rest_tangent.cross(u);
  }
  ValidateColon(colon);
  return colon;
}

void MakeSuspensionStiff(ColonSpec* colon) {
  double stiffest = kStiffSuspension_N_per_m2;
  for (const ColonPoint& p : colon->points) {
    stiffest = std::max(stiffest, p.tissue.suspension_stiffness_N_per_m2);
  }
  for (ColonPoint& p : colon->points) p.tissue.suspension_stiffness_N_per_m2 = stiffest;
}

}  // namespace ves::model
