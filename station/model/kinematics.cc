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
  if (root > previous_root && root + 1 < n) {
    // Withdrawn past a joint: the joints now outside are straightened by the
    // guide. Their turn goes to the first joint still inside, so the inserted
    // part keeps its direction (the exiting joint sits at the anus, so its
    // position is kept too); zeroing it instead swung a looped scope's far
    // end by centimetres in one step and drove it into the wall.
    Eigen::Matrix3d R_carried = Eigen::Matrix3d::Identity();
    for (int k = previous_root + 1; k <= root + 1; ++k) R_carried *= JointRotation(s->bend_rad[k]);
    s->bend_rad[root + 1] = JointAnglesOfAxis(R_carried.col(2));
  }

  // Links up to the root lie straight on the entry axis (the anus guides them).
  double arc_m = 0.0;
  for (int k = n - 1; k > root; --k) arc_m += s->link_length_m[k];
  arc_m += s->link_length_m[root];  // arc from the tip to the root's proximal joint
  Eigen::Vector3d p = anus + (s->inserted_m - arc_m) * e;
  for (int k = 0; k <= root; ++k) {
    s->bend_rad[k].setZero();
    s->bend_rate_rad_per_s[k].setZero();
  }
  for (int k = root; k >= 0; --k) {
    s->X_WLink[k].linear() = R_base;
    s->X_WLink[k].translation() = anus + (s->inserted_m - arc_m) * e;
    if (k > 0) arc_m += s->link_length_m[k - 1];
  }
  p = s->X_WLink[root].translation();
  Eigen::Matrix3d R = R_base;
  for (int k = root + 1; k < n; ++k) {
    p += s->link_length_m[k - 1] * R.col(2);
    R = R * JointRotation(s->bend_rad[k]);
    s->X_WLink[k].linear() = R;
    s->X_WLink[k].translation() = p;
  }
  s->X_WTip.linear() = R;
  s->X_WTip.translation() = p + s->link_length_m[n - 1] * R.col(2);

  for (size_t i = 0; i < s->samples.size(); ++i) {
    const ScopeSample& sample = s->samples[i];
    const Eigen::Isometry3d& X = s->X_WLink[sample.link];
    s->p_WSample[i] = X.translation() + sample.offset_m * X.linear().col(2);
  }
}

}  // namespace ves::model::internal
