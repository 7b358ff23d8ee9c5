// ResampleColon: a smooth curve through a case's control points, cut into N
// segment points equally spaced in arc length (paper eqs. 3-5).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "station/model/colon.h"

namespace ves::model {
namespace {

constexpr int kDenseSamplesPerSpan = 32;

// Centripetal Catmull-Rom between p1 and p2 (Barry-Goldman pyramid), t in [0, 1].
Eigen::Vector3d CatmullRom(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                           const Eigen::Vector3d& p2, const Eigen::Vector3d& p3, double s) {
  auto knot = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::max(std::sqrt((b - a).norm()), 1e-9);
  };
  const double t0 = 0.0;
  const double t1 = t0 + knot(p0, p1);
  const double t2 = t1 + knot(p1, p2);
  const double t3 = t2 + knot(p2, p3);
  const double t = t1 + s * (t2 - t1);
  const Eigen::Vector3d a1 = (t1 - t) / (t1 - t0) * p0 + (t - t0) / (t1 - t0) * p1;
  const Eigen::Vector3d a2 = (t2 - t) / (t2 - t1) * p1 + (t - t1) / (t2 - t1) * p2;
  const Eigen::Vector3d a3 = (t3 - t) / (t3 - t2) * p2 + (t - t2) / (t3 - t2) * p3;
  const Eigen::Vector3d b1 = (t2 - t) / (t2 - t0) * a1 + (t - t0) / (t2 - t0) * a2;
  const Eigen::Vector3d b2 = (t3 - t) / (t3 - t1) * a2 + (t - t1) / (t3 - t1) * a3;
  return (t2 - t) / (t2 - t1) * b1 + (t - t1) / (t2 - t1) * b2;
}

double RadiusAt(const std::vector<RadiusSample>& profile, double arc_m) {
  if (arc_m <= profile.front().arc_m) return profile.front().radius_m;
  for (size_t i = 1; i < profile.size(); ++i) {
    if (arc_m <= profile[i].arc_m) {
      const RadiusSample& a = profile[i - 1];
      const RadiusSample& b = profile[i];
      const double t = (arc_m - a.arc_m) / (b.arc_m - a.arc_m);
      return a.radius_m + t * (b.radius_m - a.radius_m);
    }
  }
  return profile.back().radius_m;
}

const RegionSpan& RegionAt(const std::vector<RegionSpan>& regions, double arc_m) {
  for (const RegionSpan& span : regions) {
    if (arc_m >= span.start_arc_m && arc_m < span.end_arc_m) return span;
  }
  return arc_m < regions.front().start_arc_m ? regions.front() : regions.back();
}

void Fail(const std::string& what) { throw std::invalid_argument("colon curve: " + what); }

}  // namespace

ColonSpec ResampleColon(const ColonCurve& curve, int segment_count) {
  const auto& cp = curve.control_points_m;
  const int m = static_cast<int>(cp.size());
  if (m < 2) Fail("control_points has " + std::to_string(m) + " points (need >= 2)");
  if (segment_count < 3 || segment_count > 20000) {
    Fail("segment_count = " + std::to_string(segment_count) + " (must be in [3, 20000])");
  }
  if (curve.radius_profile.empty()) Fail("radius_profile is empty");
  if (curve.regions.empty()) Fail("regions is empty");
  for (size_t i = 0; i < curve.radius_profile.size(); ++i) {
    const RadiusSample& r = curve.radius_profile[i];
    if (!std::isfinite(r.arc_m) || !(r.radius_m > 0.0) || !std::isfinite(r.radius_m)) {
      Fail("radius_profile[" + std::to_string(i) + "] = (" + std::to_string(r.arc_m) + ", " +
           std::to_string(r.radius_m) + ")");
    }
    if (i > 0 && !(r.arc_m > curve.radius_profile[i - 1].arc_m)) {
      Fail("radius_profile[" + std::to_string(i) + "].arc_m = " + std::to_string(r.arc_m) +
           " (must increase)");
    }
  }
  double polyline_m = 0.0;
  for (int i = 0; i < m; ++i) {
    if (!cp[i].allFinite()) Fail("control_points[" + std::to_string(i) + "] is not finite");
    if (i > 0) {
      const double gap = (cp[i] - cp[i - 1]).norm();
      if (!(gap > 1e-9)) Fail("control_points[" + std::to_string(i) + "] repeats its predecessor");
      polyline_m += gap;
    }
  }
  for (const RegionSpan& span : curve.regions) ValidateTissue(span.tissue);

  // Dense samples of the spline, with end points mirrored for the end spans.
  std::vector<Eigen::Vector3d> dense;
  dense.reserve((m - 1) * kDenseSamplesPerSpan + 1);
  for (int i = 0; i + 1 < m; ++i) {
    const Eigen::Vector3d p0 = i > 0 ? cp[i - 1] : Eigen::Vector3d(2.0 * cp[0] - cp[1]);
    const Eigen::Vector3d p3 = i + 2 < m ? cp[i + 2] : Eigen::Vector3d(2.0 * cp[m - 1] - cp[m - 2]);
    for (int j = 0; j < kDenseSamplesPerSpan; ++j) {
      dense.push_back(CatmullRom(p0, cp[i], cp[i + 1], p3,
                                 static_cast<double>(j) / kDenseSamplesPerSpan));
    }
  }
  dense.push_back(cp[m - 1]);
  std::vector<double> dense_arc(dense.size(), 0.0);
  for (size_t i = 1; i < dense.size(); ++i) {
    dense_arc[i] = dense_arc[i - 1] + (dense[i] - dense[i - 1]).norm();
  }
  const double total_m = dense_arc.back();

  // Equal arc-length points along the dense polyline.
  std::vector<Eigen::Vector3d> points(segment_count);
  size_t j = 0;
  for (int i = 0; i < segment_count; ++i) {
    const double s = total_m * i / (segment_count - 1);
    while (j + 2 < dense.size() && dense_arc[j + 1] < s) ++j;
    const double span = dense_arc[j + 1] - dense_arc[j];
    const double t = span > 0.0 ? std::clamp((s - dense_arc[j]) / span, 0.0, 1.0) : 0.0;
    points[i] = dense[j] + t * (dense[j + 1] - dense[j]);
  }
  ColonSpec colon = MakeColonFromPoints(points, curve.radius_profile.front().radius_m,
                                        curve.regions.front().tissue, curve.regions.front().region);
  // Case arcs are polyline arcs through the control points: map proportionally.
  const double to_case = polyline_m / colon.points.back().arc_m;
  for (ColonPoint& p : colon.points) {
    const double case_arc_m = p.arc_m * to_case;
    p.radius_m = RadiusAt(curve.radius_profile, case_arc_m);
    const RegionSpan& span = RegionAt(curve.regions, case_arc_m);
    p.region = span.region;
    p.tissue = span.tissue;
  }
  CalcMesenteryAnchors(&colon);  // the regions' mobility is known only now
  GatherMobileColon(&colon);
  ValidateColon(colon);
  return colon;
}

}  // namespace ves::model
