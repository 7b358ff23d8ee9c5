// Forward kinematics of the endoscope chain (paper §3.2, Fig. 7).
#include <algorithm>
#include <cmath>

#include "station/model/internal.h"

namespace ves::model::internal {

Eigen::Matrix3d CalcEntryRotation(const ModelParams& params) {
  const Eigen::Vector3d z = params.colon.points.front().rest_tangent.normalized();
  Eigen::Vector3d y = Eigen::Vector3d::UnitY() - z.y() * z;
  if (y.norm() < 1e-6) y = Eigen::Vector3d::UnitZ() - z.z() * z;  // entry straight up
  y.normalize();
  Eigen::Matrix3d R;
  R.col(0) = y.cross(z);
  R.col(1) = y;
  R.col(2) = z;
  return R;
}

int RootLink(const ModelState& state) {
  const int n = static_cast<int>(state.link_length_m.size());
  if (state.first_inside_link >= n) return n - 1;
  return state.first_inside_link > 0 ? state.first_inside_link - 1 : 0;
}

namespace {

// Universal joint: pitch a about the parent's x, then yaw b about the new y.
Eigen::Matrix3d JointRotation(const Eigen::Vector2d& q) {
  const double ca = std::cos(q.x()), sa = std::sin(q.x());
  const double cb = std::cos(q.y()), sb = std::sin(q.y());
  Eigen::Matrix3d rx, ry;
  rx << 1, 0, 0, 0, ca, -sa, 0, sa, ca;
  ry << cb, 0, sb, 0, 1, 0, -sb, 0, cb;
  return rx * ry;
}

// The joint angles (a, b) whose rotation Rx(a) Ry(b) turns +z into `axis`
// (a unit vector): Rx(a) Ry(b) e_z = (sin b, -sin a cos b, cos a cos b). The
// twist about the axis that a product of two joints carries is dropped.
Eigen::Vector2d JointAnglesOfAxis(const Eigen::Vector3d& axis) {
  const double b = std::asin(std::clamp(axis.x(), -1.0, 1.0));
  const double a = std::atan2(-axis.y(), axis.z());
  return Eigen::Vector2d(a, b);
}

}  // namespace

void SpinScope(const ModelParams& params, double roll_rad, ModelState* s) {
  if (roll_rad == s->roll_rad) return;
  // The torsionally stiff shaft turns about its own centreline: every link
  // keeps its direction (so the whole shape stays) while its frame turns with
  // the roll. Each joint is re-expressed in its parent's turned frame; the
  // small twist a universal joint cannot hold is dropped, as on withdrawal.
  const int n = static_cast<int>(s->link_length_m.size());
  const int root = RootLink(*s);
  const Eigen::Matrix3d R_entry = CalcEntryRotation(params);
  s->roll_rad = roll_rad;
  Eigen::Matrix3d R = Eigen::AngleAxisd(roll_rad, R_entry.col(2)).toRotationMatrix() * R_entry;
  for (int k = root; k < n; ++k) {  // the pivot at the anus, then every joint inside
    const Eigen::Vector3d axis_W = s->X_WLink[k].linear().col(2);
    s->bend_rad[k] = JointAnglesOfAxis(R.transpose() * axis_W);
    R = R * JointRotation(s->bend_rad[k]);
  }
  UpdateScopeKinematics(params, s);
}

double CalcRootInsideLength(const ModelState& s) {
  const int n = static_cast<int>(s.link_length_m.size());
  double distal_m = 0.0;
  for (int k = RootLink(s) + 1; k < n; ++k) distal_m += s.link_length_m[k];
  return std::max(0.0, s.inserted_m - distal_m);
}

void UpdateScopeKinematics(const ModelParams& params, ModelState* s) {
  const int n = static_cast<int>(s->link_length_m.size());
  const Eigen::Vector3d anus = params.colon.points.front().rest_position_m;
  const Eigen::Matrix3d R_entry = CalcEntryRotation(params);
  const Eigen::Vector3d e = R_entry.col(2);
  const Eigen::Matrix3d R_base = Eigen::AngleAxisd(s->roll_rad, e).toRotationMatrix() * R_entry;

  // Arc from the tip to link k's proximal joint, and the first joint inside.
  double arc_to_tip_m = 0.0;
  int first_inside = n;
  for (int k = n - 1; k >= 0; --k) {
    arc_to_tip_m += s->link_length_m[k];
    if (arc_to_tip_m <= s->inserted_m + 1e-12) first_inside = k;
  }
  const int previous_root = RootLink(*s);
  s->first_inside_link = first_inside;
  const int root = RootLink(*s);
  if (root > previous_root) {
    // Withdrawn past a joint: the guide straightens it. The root link turns
    // about the pivot at the anus, so the new root's pivot takes the old
    // pivot's and the exited joints' turn and the inserted part keeps its
    // shape (the exited joint sat at the anus, where the pivot is).
    Eigen::Matrix3d R_carried = Eigen::Matrix3d::Identity();
    for (int k = previous_root; k <= root; ++k) R_carried *= JointRotation(s->bend_rad[k]);
    s->bend_rad[root] = JointAnglesOfAxis(R_carried.col(2));
  }
  // (Inserted past a joint: the old pivot's bend stays as that joint's bend,
  // which is at the anus now; the new root's pivot is straight.)
  for (int k = 0; k < root; ++k) {
    s->bend_rad[k].setZero();
    s->bend_rate_rad_per_s[k].setZero();
  }

  // The root link: its outside part on the entry axis, its inside part from
  // the pivot at the anus. Its frame's origin is where its proximal joint
  // would be along the pivoted direction, so inside samples sit right.
  const double inside_m = CalcRootInsideLength(*s);
  const double outside_m = s->link_length_m[root] - inside_m;
  const Eigen::Matrix3d R_root = R_base * JointRotation(s->bend_rad[root]);
  s->X_WLink[root].linear() = R_root;
  s->X_WLink[root].translation() = anus - outside_m * R_root.col(2);
  // Links behind the root lie straight on the entry axis (the hand holds them).
  Eigen::Vector3d p = anus - outside_m * e;
  for (int k = root - 1; k >= 0; --k) {
    p -= s->link_length_m[k] * e;
    s->X_WLink[k].linear() = R_base;
    s->X_WLink[k].translation() = p;
  }
  p = anus + inside_m * R_root.col(2);
  Eigen::Matrix3d R = R_root;
  for (int k = root + 1; k < n; ++k) {
    R = R * JointRotation(s->bend_rad[k]);
    s->X_WLink[k].linear() = R;
    s->X_WLink[k].translation() = p;
    p += s->link_length_m[k] * R.col(2);
  }
  s->X_WTip.linear() = R;
  s->X_WTip.translation() = root + 1 < n ? p : Eigen::Vector3d(anus + inside_m * R_root.col(2));

  for (size_t i = 0; i < s->samples.size(); ++i) {
    const ScopeSample& sample = s->samples[i];
    if (sample.arc_from_tip_m >= s->inserted_m) {  // outside: on the entry axis
      s->p_WSample[i] = anus - (sample.arc_from_tip_m - s->inserted_m) * e;
      continue;
    }
    const Eigen::Isometry3d& X = s->X_WLink[sample.link];
    s->p_WSample[i] = X.translation() + sample.offset_m * X.linear().col(2);
  }
}

}  // namespace ves::model::internal
