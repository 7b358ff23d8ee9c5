#pragma once

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

// Mechanical parameters of a region (paper eqs. 9, 10, 16, 17). Suspension and
// coupling are per metre of colon, so behaviour does not depend on N: a point
// standing for a length h of colon gets K_c*h (N/m) and D_c*h (N s/m).
struct TissueParams {
  double suspension_stiffness_N_per_m2{400.0};   // K_c (mobile sigmoid-like default)
  double suspension_damping_N_s_per_m2{40.0};    // D_c
  double wall_stiffness_N_per_m{300.0};          // K_d, one contact
  double wall_damping_N_s_per_m{0.5};            // D_d
  double deformation_threshold_m{0.004};         // L: beyond it the point moves (eq. 10)
  double static_friction{0.3};                   // mu_s (F_s hat, eq. 16)
  double dynamic_friction{0.2};                  // mu_d (F_d hat, eq. 17)
  double neighbor_tension_N{0.5};                // couples neighbouring points
  bool operator==(const TissueParams&) const = default;
};

// One segment point r_i at rest. The point moves only in its plane P_i, whose
// normal is the rest tangent; (plane_u, plane_v) is an orthonormal basis of P_i.
struct ColonPoint {
  Eigen::Vector3d rest_position_m{Eigen::Vector3d::Zero()};
  Eigen::Vector3d rest_tangent{Eigen::Vector3d::UnitZ()};  // unit, toward the cecum
  Eigen::Vector3d plane_u{Eigen::Vector3d::UnitX()};
  Eigen::Vector3d plane_v{Eigen::Vector3d::UnitY()};
  double arc_m{0.0};        // rest arc length from the anus
  double length_m{0.0};     // length of colon this point stands for (h_i)
  double radius_m{0.025};   // R_i
  Region region{Region::kUnspecified};
  TissueParams tissue;
  bool operator==(const ColonPoint&) const = default;
};

// The resampled colon, from the anus (points[0], a fixed guide; its rest
// tangent is the entry axis) to the deepest point (cecum). At least 3 points.
struct ColonSpec {
  std::vector<ColonPoint> points;
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

// Sets every point's suspension to the stiffest one found in the colon (at
// least kStiffSuspension_N_per_m2): the older, radial-only model the paper
// compares against in §3.6 ("--stiff-colon").
inline constexpr double kStiffSuspension_N_per_m2 = 2.0e4;
void MakeSuspensionStiff(ColonSpec* colon);

}  // namespace ves::model
