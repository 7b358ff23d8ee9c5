#include "patient_db/case_geometry.h"

#include <cmath>

namespace ves::patient_db {
namespace {

double Distance_m(const ves::v1::Vec3& a, const ves::v1::Vec3& b) {
  return std::hypot(a.x_m() - b.x_m(), a.y_m() - b.y_m(), a.z_m() - b.z_m());
}

}  // namespace

std::vector<double> CalcControlPointArcs_m(const ves::v1::ColonCase& colon_case) {
  const auto& points = colon_case.centerline();
  std::vector<double> arcs_m;
  arcs_m.reserve(points.size());
  double arc_m = 0.0;
  for (int i = 0; i < points.size(); ++i) {
    if (i > 0) arc_m += Distance_m(points[i - 1], points[i]);
    arcs_m.push_back(arc_m);
  }
  return arcs_m;
}

double CalcCenterlineLength_m(const ves::v1::ColonCase& colon_case) {
  const auto arcs_m = CalcControlPointArcs_m(colon_case);
  return arcs_m.empty() ? 0.0 : arcs_m.back();
}

double CalcRadiusAt_m(const ves::v1::ColonCase& colon_case, double arc_m) {
  const auto& profile = colon_case.radius_profile();
  if (profile.empty()) return 0.0;
  if (arc_m <= profile[0].arc_m()) return profile[0].radius_m();
  for (int i = 1; i < profile.size(); ++i) {
    if (arc_m <= profile[i].arc_m()) {
      const auto& a = profile[i - 1];
      const auto& b = profile[i];
      const double span_m = b.arc_m() - a.arc_m();
      if (!(span_m > 0.0)) return b.radius_m();
      const double t = (arc_m - a.arc_m()) / span_m;
      return a.radius_m() + t * (b.radius_m() - a.radius_m());
    }
  }
  return profile[profile.size() - 1].radius_m();
}

ves::v1::Region CalcRegionAt(const ves::v1::ColonCase& colon_case, double arc_m) {
  const auto& regions = colon_case.regions();
  if (regions.empty()) return ves::v1::REGION_UNSPECIFIED;
  for (const auto& span : regions) {
    if (arc_m >= span.start_arc_m() && arc_m < span.end_arc_m()) return span.region();
  }
  return arc_m < regions[0].start_arc_m() ? regions[0].region()
                                          : regions[regions.size() - 1].region();
}

}  // namespace ves::patient_db
