#pragma once

#include <vector>

#include "ves/v1/case.pb.h"

// Arc-length geometry of a case's centerline as the case format defines it:
// the arc length s is measured along the polyline through the control points
// (docs/case-format.md). A model fitting a smooth curve maps s proportionally.
namespace ves::patient_db {

// Cumulative polyline arc length at each control point; [0] = 0. Empty for an
// empty centerline.
std::vector<double> CalcControlPointArcs_m(const ves::v1::ColonCase& colon_case);

// Total polyline length of the centerline (0 with fewer than two points).
double CalcCenterlineLength_m(const ves::v1::ColonCase& colon_case);

// Lumen radius R = phi(s) (paper eq. 5): radius_profile interpolated linearly in
// arc length, held constant beyond its ends; 0 when the profile is empty.
double CalcRadiusAt_m(const ves::v1::ColonCase& colon_case, double arc_m);

// Region containing arc length s (the first span with start <= s < end, the last
// span for s at or beyond the end); REGION_UNSPECIFIED when there are no spans.
ves::v1::Region CalcRegionAt(const ves::v1::ColonCase& colon_case, double arc_m);

}  // namespace ves::patient_db
