#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

// The colon of paper §3.3 as the model sees it: the centerline S(r)=0 (eq. 3)
// cut into N segment points r_i (eq. 4), each with a lumen radius R_i = phi(s)
// (eq. 5), a region and the tissue parameters of that region. Frame W: origin
// at the anus, +z cranial, +y anterior ("up" for a supine patient), +x the
// patient's right; metres.
namespace ves::model {

// Anatomical region of a segment point (same order as ves.v1.Region).
enum class Region : std::uint8_t {
  kUnspecified = 0,
  kRectum = 1,
  kSigmoid = 2,
  kDescending = 3,
  kSplenicFlexure = 4,
  kTransverse = 5,
  kHepaticFlexure = 6,
  kAscending = 7,
  kCecum = 8,
};

// The most of a region's material that may lie gathered at rest.
inline constexpr double kMaxGatheredReserve = 0.6;

// Mechanical parameters of a region (paper eqs. 9, 10, 16, 17, and the
// shortening colon of docs/model.md). Suspension, coupling and mesentery are
// per metre of colon, so behaviour does not depend on N: a point standing for
// a length h of colon gets K_c*h (N/m) and D_c*h (N s/m). The defaults are a
// mobile, sigmoid-like segment; docs/model.md gives each value's source.
struct TissueParams {
  double suspension_stiffness_N_per_m2{300.0};   // K_c, in the rest plane P_i
  double suspension_damping_N_s_per_m2{10.0};    // D_c (every direction)
  double wall_stiffness_N_per_m{400.0};          // K_d, one contact
  double wall_damping_N_s_per_m{4.0};            // D_d
  double deformation_threshold_m{0.004};         // L: beyond it the point moves (eq. 10)
  double static_friction{0.15};                  // mu_s (F_s hat, eq. 16)
  double dynamic_friction{0.10};                 // mu_d (F_d hat, eq. 17): Watanabe et al. 2024
  // Tension of the tube across a kink: pulls each pair of neighbours toward
  // the local direction of the tube (its smoothness), never along it.
  double neighbor_tension_N{2.0};
  // Mesentery: a mobile region hangs on it (its tether reaches from the
  // mesentery root); a fixed (retroperitoneal) one is held near its rest
  // position. The tether is slack within mesentery_length_m of its anchor and
  // pulls back with mesentery_stiffness beyond (the stretch that hurts).
  bool mobile{true};
  double mesentery_length_m{0.063};              // mesocolon height, sigmoid 6.3 cm
  double mesentery_stiffness_N_per_m2{1000.0};
  // Pleating: the gap between neighbours may shorten to pleat_limit of its
  // rest length (the wall folds onto the scope) before the folds pack.
  double pleat_limit{0.3};
  // The paper's suspension holds the colon near where it has been, not where
  // it started: its reference relaxes toward the point's position with this
  // time constant (0: never, the paper's fixed rest). Soft tissue relaxes
  // under a held deformation; a reduced loop stays reduced.
  double suspension_relaxation_s{0.0};
  // The share of the colon's material length that lies gathered at rest
  // (a deflated mobile colon telescoped on itself, docs/model.md "The
  // gathered reserve"): the rest path is that much shorter than the
  // material, and straightens at low tension before the wall itself strains.
  double gathered_reserve{0.0};
  bool operator==(const TissueParams&) const = default;
};

// What a region's name says of its mobility when a case does not: the
// sigmoid and transverse colon hang on a mesentery, the rectum, descending
// colon, flexures, ascending colon and cecum are retroperitoneal (fixed).
bool IsMobileByDefault(Region region);

// Mesentery and pleating of a region that a case leaves at 0 (docs/model.md,
// "Defaults and their sources").
struct MobilityDefaults {
  double mesentery_length_m;
  double mesentery_stiffness_N_per_m2;
  double pleat_limit;
  double suspension_relaxation_s;
  double gathered_reserve;
};
MobilityDefaults DefaultMobility(Region region, bool mobile);

// One segment point r_i at rest. The paper's suspension acts in its plane
// P_i, whose normal is the rest tangent; (plane_u, plane_v) is an orthonormal
// basis of P_i. The point itself moves in 3-D (docs/model.md).
struct ColonPoint {
  Eigen::Vector3d rest_position_m{Eigen::Vector3d::Zero()};
  Eigen::Vector3d rest_tangent{Eigen::Vector3d::UnitZ()};  // unit, toward the cecum
  Eigen::Vector3d plane_u{Eigen::Vector3d::UnitX()};
  Eigen::Vector3d plane_v{Eigen::Vector3d::UnitY()};
  double arc_m{0.0};        // rest arc length from the anus
  double length_m{0.0};     // length of colon this point stands for (h_i)
  // Material length of the colon from this point to the next (0 at the
  // last): the rest gap, or more where the colon lies gathered at rest
  // (GatherMobileColon).
  double material_gap_m{0.0};
  double radius_m{0.025};   // R_i
  Region region{Region::kUnspecified};
  TissueParams tissue;
  // Mesentery tether (CalcMesenteryAnchors): slack within tether_length_m of
  // the anchor. Mobile points are anchored on their run's mesentery root.
  Eigen::Vector3d tether_anchor_m{Eigen::Vector3d::Zero()};
  double tether_length_m{0.0};
  // Mobile points: the unit direction of their mesentery root. Moving along
  // it shears the mesentery sheet, so it counts mesentery_shear_ratio times
  // (ModelParams) toward the reach; zero for fixed points (isotropic).
  Eigen::Vector3d tether_root_direction{Eigen::Vector3d::Zero()};
  // Mobile points: the unit direction from the anchor to the rest position,
  // the side of the root the colon hangs on; it cannot swing through the
  // root to the other side (zero: no side, at or near the root).
  Eigen::Vector3d tether_side{Eigen::Vector3d::Zero()};
  bool operator==(const ColonPoint&) const = default;
};

// The resampled colon, from the anus (points[0], a fixed guide; its rest
// tangent is the entry axis) to the deepest point (cecum). At least 3 points.
struct ColonSpec {
  std::vector<ColonPoint> points;
  // How many times a move along a mobile point's mesentery root counts
  // toward its reach (the sheet shearing rather than swinging). 1: the
  // tether is isotropic; 4 held the pleats where they formed but needed
  // 18-20 N to reduce a loop with the tip pinned, against 0.5 N at 1
  // (docs/model-shortening-notes.md).
  double mesentery_shear_ratio{1.0};
  // Where on its root a mobile point is anchored: false, its rest
  // position's projection; true, its arc fraction of the run along the
  // chord (where a uniformly gathered run would put it; experiment).
  bool mesentery_anchor_by_arc{false};
  // How far a mobile point may cross its root to the other side before the
  // body wall behind the root holds it, with this stiffness per metre.
  double mesentery_crossing_m{0.01};
  double root_wall_stiffness_N_per_m2{1.0e5};
  // The abdominal cavity: the colon stays within the box of its rest
  // centerline grown by abdomen_margin_m (the abdominal wall, diaphragm,
  // liver and pelvis hold it; a loop stretches the wall only a little).
  // Set by CalcMesenteryAnchors; held with root_wall_stiffness_N_per_m2.
  double abdomen_margin_m{10.0};  // off: 0.03 m measured worse (docs/model-shortening-notes.md)
  Eigen::Vector3d abdomen_min_m{Eigen::Vector3d::Constant(-1e9)};
  Eigen::Vector3d abdomen_max_m{Eigen::Vector3d::Constant(1e9)};
  bool operator==(const ColonSpec&) const = default;
};

// --- Building a ColonSpec -------------------------------------------------

struct RadiusSample {
  double arc_m{0.0};
  double radius_m{0.025};
};

struct RegionSpan {
  Region region{Region::kUnspecified};
  double start_arc_m{0.0};
  double end_arc_m{0.0};
  TissueParams tissue;
};

// A case's centerline as control points, with R = phi(s) and regions given
// against the POLYLINE arc length through the control points (the case
// format's convention); they are mapped proportionally onto the smooth curve.
struct ColonCurve {
  std::vector<Eigen::Vector3d> control_points_m;
  std::vector<RadiusSample> radius_profile;  // strictly increasing arc; linear; held at ends
  std::vector<RegionSpan> regions;           // in order; the last one extends to the end
};

// Fits a centripetal Catmull-Rom curve through the control points and
// resamples it into segment_count points equally spaced in arc length.
// Throws std::invalid_argument naming the bad value (fewer than 2 control
// points, segment_count outside [3, 20000], non-positive radius, no regions,
// non-finite numbers, invalid tissue).
ColonSpec ResampleColon(const ColonCurve& curve, int segment_count);

// Builds a spec from explicit point positions (tests and synthetic tubes):
// tangents by central differences, plane bases, arc lengths and h_i computed.
// radius and tissue apply to every point. Throws std::invalid_argument.
ColonSpec MakeColonFromPoints(const std::vector<Eigen::Vector3d>& positions_m, double radius_m,
                              const TissueParams& tissue, Region region = Region::kUnspecified);

// Throws std::invalid_argument naming the first bad field.
void ValidateTissue(const TissueParams& tissue);
void ValidateColon(const ColonSpec& colon);

// Anchors every point's mesentery tether. A fixed point is anchored at its
// rest position. A maximal run of mobile points hangs from its mesentery
// root, taken as the chord between the fixed points on either side of the
// run (or its own ends at the ends of the colon): each point is anchored at
// its projection on that chord. Its reach is the larger of its region's
// mesentery length and its rest distance from the anchor (measured with the
// distance along the root counted mesentery_shear_ratio times, see
// CalcTetherDistance), so the colon at rest is slack, can be gathered onto a
// straight scope, and hurts when a loop is pushed beyond its mesentery.
// Called by the builders above; call it again after changing tissue.
void CalcMesenteryAnchors(ColonSpec* colon);

// The gathered reserve (TissueParams::gathered_reserve; docs/model.md):
// every run of mobile points with a reserve is drawn toward its mesentery
// root (each point toward its tether anchor, by one factor for the run)
// until its path is (1 - reserve) of its material length, the arc it keeps
// (arc_m, length_m). A run that lies almost on its root cannot gather: its
// path stays at least 5 % longer than its root. Rest tangents, plane bases
// and tethers are then taken from the gathered shape. ResampleColon calls it
// after the regions are known; call it again only on a fresh resampling.
void GatherMobileColon(ColonSpec* colon);

// Distance of r (from a point's anchor) in its tether's metric: the part
// along the root direction counts shear_ratio times. Inline: the colon solve
// takes it for every point every step.
inline double CalcTetherDistance(const Eigen::Vector3d& r, const Eigen::Vector3d& root_direction,
                                 double shear_ratio) {
  const double along = r.dot(root_direction);
  return std::sqrt(
      std::max(0.0, r.squaredNorm() + (shear_ratio * shear_ratio - 1.0) * along * along));
}

// The older, radial-only model the paper compares against in §3.6
// ("--stiff-colon"): every point fixed, with the stiffest suspension found in
// the colon (at least kStiffSuspension_N_per_m2) as its suspension and
// tether, no mesentery slack and no pleating.
inline constexpr double kStiffSuspension_N_per_m2 = 2.0e4;
void MakeSuspensionStiff(ColonSpec* colon);

}  // namespace ves::model
