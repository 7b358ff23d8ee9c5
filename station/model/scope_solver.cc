// Linearly implicit step of the quasi-static endoscope law, paper eq. (6):
//   D q' = sum_i J_i^T F_i - K (q - q0) - G(q) + tau_input.
// Backward Euler with the contact forces linearised (F(q + dq) ~ F - K_c J dq)
// gives (D + dt K + dt J^T K_c J) dq = dt (J^T F - K (q - q0)). That matrix is
// the joint-space "inertia" of a chain whose bodies carry the spatial contact
// stiffness dt*K_c instead of inertia and whose joints carry D + dt*K as
// armature, so the articulated-body recursion (Featherstone) solves it in O(n)
// without ever forming J: tip to base it accumulates stiffness and the wrench
// sum J^T F, base to tip it recovers dq. Spatial vectors are in W at its
// origin: twists [dtheta; dx_O], wrenches [moment about O; force].
#include <algorithm>

#include "station/model/internal.h"

namespace ves::model::internal {
namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;

constexpr double kMaxJointTurnPerStep_rad = 0.02;
// The pivot at the anus is as stiff as a joint this far from the clamp when
// the root's inside part is shorter (it never becomes infinitely stiff).
constexpr double kPivotMinHalfLength_m = 0.001;
using Mat6 = Eigen::Matrix<double, 6, 6>;

Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// Spatial stiffness and wrench of a body's contact springs and point forces,
// summed sample by sample and turned into the 6x6 form once per body.
// A point spring K = b I + c n n^T at p (b = k_t, c = k_n - k_t) adds
// B^T K B with B = [-p^, I]. With P = p^ and m = P n: P K = b P + c m n^T,
// K P = b P - c n m^T and P K P = b (p p^T - |p|^2 I) - c m m^T. All of it is
// linear in b p, b p p^T, c m m^T, c m n^T and c n n^T, so only those sums
// are kept per sample (no 6x6 work per sample).
struct BodyStiffnessSum {
  double b{0.0};
  double b_p2{0.0};  // sum b |p|^2
  Eigen::Vector3d b_p{Eigen::Vector3d::Zero()};
  Eigen::Matrix3d b_ppT{Eigen::Matrix3d::Zero()};
  Eigen::Matrix3d c_mmT{Eigen::Matrix3d::Zero()};
  Eigen::Matrix3d c_mnT{Eigen::Matrix3d::Zero()};
  Eigen::Matrix3d c_nnT{Eigen::Matrix3d::Zero()};
  Eigen::Vector3d moment{Eigen::Vector3d::Zero()};  // sum p x F about W's origin
  Eigen::Vector3d force{Eigen::Vector3d::Zero()};
  bool stiff{false};

  // flatten: otherwise GCC leaves the four outer products out of line, a
  // call each per contact (about 3 % of the 64 x 1000 step).
  [[gnu::flatten]] void AddSpring(double k_n, double k_t, const Eigen::Vector3d& n,
                                  const Eigen::Vector3d& p) {
    const double c = k_n - k_t;
    const Eigen::Vector3d m = p.cross(n);
    if (k_t != 0.0) {  // a ring's spring has no friction: these sums would gain zeros
      b += k_t;
      b_p2 += k_t * p.squaredNorm();
      b_p += k_t * p;
      b_ppT.noalias() += (k_t * p) * p.transpose();
    }
    c_mmT.noalias() += (c * m) * m.transpose();
    c_mnT.noalias() += (c * m) * n.transpose();
    c_nnT.noalias() += (c * n) * n.transpose();
    stiff = true;
  }
  void AddForce(const Eigen::Vector3d& F, const Eigen::Vector3d& p) {
    moment += p.cross(F);
    force += F;
  }
  // Adds scale times the sums to a body's articulated stiffness and bias.
  void FlushInto(double scale, Mat6* I, Vec6* w) {
    w->head<3>() += scale * moment;
    w->tail<3>() += scale * force;
    if (stiff) {
      const Eigen::Matrix3d P = Hat(b_p);
      Eigen::Matrix3d PKP = b_ppT - c_mmT;
      PKP.diagonal().array() -= b_p2;
      I->topLeftCorner<3, 3>() -= scale * PKP;
      I->topRightCorner<3, 3>() += scale * (P + c_mnT);
      I->bottomLeftCorner<3, 3>() += scale * (c_mnT.transpose() - P);
      I->bottomRightCorner<3, 3>() += scale * c_nnT;
      I->bottomRightCorner<3, 3>().diagonal().array() += scale * b;
    }
    *this = BodyStiffnessSum{};
  }
};

// The bodies' own terms: each body's contact stiffness and the forces on its
// samples (contact, gravity G(q), the external tip load, the rings' pushes)
// into its articulated stiffness and bias (the J^T F sum starts here).
// Returns the sums of those forces and of their moments about the anus.
struct AppliedLoad {
  Eigen::Vector3d force_N{Eigen::Vector3d::Zero()};
  Eigen::Vector3d moment_N_m{Eigen::Vector3d::Zero()};  // about the anus
};
AppliedLoad AddBodyTerms(const ModelParams& params, const StepInput& input, int root,
                         const ModelState& s, Scratch* sc) {
  const int n = static_cast<int>(s.link_length_m.size());
  const double dt = params.dt_s;
  auto& IA = sc->articulated_stiffness;
  auto& bA = sc->articulated_bias;
  for (int k = root; k < n; ++k) {
    IA[k].setZero();
    bA[k].setZero();
  }
  const int samples = static_cast<int>(s.samples.size());
  const Eigen::Vector3d anus = params.colon.points.front().rest_position_m;
  AppliedLoad load;
  // Samples are ordered base to tip, so a body's samples are consecutive.
  BodyStiffnessSum body;
  int body_link = -1;
  int ring = 0;  // ring contacts are ordered by their proximal sample
  for (int i = s.first_inside_sample; i < samples; ++i) {
    const int k = std::max(s.samples[i].link, root);
    if (k != body_link) {
      if (body_link >= 0) body.FlushInto(dt, &IA[body_link], &bA[body_link]);
      body_link = k;
    }
    const Eigen::Vector3d& p = s.p_WSample[i];
    Eigen::Vector3d F = sc->sample_force_W_N[i] + s.samples[i].mass_kg * params.gravity_W_m_per_s2;
    if (i == samples - 1) F += input.tip_force_W_N;
    load.force_N += F;
    load.moment_N_m += (p - anus).cross(F);
    body.AddForce(F, p);
    if (s.contact[i].touching) {
      body.AddSpring(sc->sample_normal_stiffness_N_per_m[i], params.friction_stiffness_N_per_m,
                     sc->sample_normal_W[i], p);
    }
    // The rings held on the scope piece after this sample push it back
    // toward their centres (no friction).
    for (; ring < sc->ring_contact_count && sc->ring_contacts[ring].sample == i; ++ring) {
      const RingContact& rc = sc->ring_contacts[ring];
      const Eigen::Vector3d F_ring = -rc.force_N * rc.normal_W;
      load.force_N += F_ring;
      load.moment_N_m += (rc.p_W - anus).cross(F_ring);
      body.AddForce(F_ring, rc.p_W);
      body.AddSpring(rc.stiffness_N_per_m, 0.0, rc.normal_W, rc.p_W);
    }
  }
  if (body_link >= 0) body.FlushInto(dt, &IA[body_link], &bA[body_link]);
  return load;
}

// Tip to base: articulated stiffness and bias of every 2-DOF bending joint
// past the root. The link straddling the anus turns about a pivot at the
// anus (its part outside stays on the entry axis): the pivot and the first
// joint inside share the bend of the scope leaving the guide, each over
// half of the root's inside length (a cantilever clamped at the anus).
void ArticulateJoints(const ModelParams& params, int root, double root_inside_m,
                      const ModelState& s, Scratch* sc) {
  const int n = static_cast<int>(s.link_length_m.size());
  const double dt = params.dt_s;
  auto& IA = sc->articulated_stiffness;
  auto& bA = sc->articulated_bias;
  auto& S = sc->motion_subspace;
  const double D = params.scope.joint_damping_N_m_s_per_rad;
  for (int k = n - 1; k > root; --k) {
    const Eigen::Matrix3d& R_parent = s.X_WLink[k - 1].linear();
    const Eigen::Vector3d o = s.X_WLink[k].translation();
    const double a = s.bend_rad[k].x();
    const Eigen::Vector3d axis1 = R_parent.col(0);
    const Eigen::Vector3d axis2 = std::cos(a) * R_parent.col(1) + std::sin(a) * R_parent.col(2);
    S[k].col(0) << axis1, o.cross(axis1);
    S[k].col(1) << axis2, o.cross(axis2);
    double K = s.joint_stiffness_N_m_per_rad[k];
    if (k == root + 1) {
      K = s.joint_stiffness_N_m_per_rad[k] * 0.5 * (s.link_length_m[k - 1] + s.link_length_m[k]) /
          (0.5 * (root_inside_m + s.link_length_m[k]));
    }
    sc->u_matrix[k].noalias() = IA[k] * S[k];
    Eigen::Matrix2d Dk = S[k].transpose() * sc->u_matrix[k];
    Dk.diagonal().array() += D + dt * K;
    sc->d_inverse[k] = Dk.inverse();
    // paper eq. (2): T = -K (q - q0) - D q', the joint's own viscoelasticity.
    sc->u_vector[k] = -dt * K * (s.bend_rad[k] - s.bend_rest_rad[k]) + S[k].transpose() * bA[k];
    const Eigen::Matrix<double, 6, 2> UDinv = sc->u_matrix[k] * sc->d_inverse[k];
    IA[k - 1].noalias() += IA[k] - UDinv * sc->u_matrix[k].transpose();
    bA[k - 1].noalias() += bA[k] - UDinv * sc->u_vector[k];
  }
}

// The base, base to tip: the pivot at the anus (2 DOF, from the world),
// then the thrust along the pivoted root (the scope slides through the
// guide), prescribed (kPosition) or driven by the hand's force against the
// thrust damping (kForce); then each joint's increment and each body's
// displacement. The roll turned the shaft in place before the contacts
// (SpinScope): it moves no body here.
class BaseToTip {
 public:
  BaseToTip(const ModelParams& params, const StepInput& input, double target_insertion_m,
            int root, double root_inside_m, const ModelState& s, Scratch* sc)
      : params_(params), input_(input), target_insertion_m_(target_insertion_m), root_(root),
        s_(s), sc_(sc) {
    const Eigen::Matrix3d& R_base = s.X_WLink[std::max(root - 1, 0)].linear();
    const Eigen::Matrix3d& R_root = s.X_WLink[root].linear();
    z_root_ = R_root.col(2);
    S_thrust_ << Eigen::Vector3d::Zero(), z_root_;
    const Eigen::Vector3d anus = params.colon.points.front().rest_position_m;
    const double a = s.bend_rad[root].x();
    const Eigen::Vector3d axis1 = R_base.col(0);
    const Eigen::Vector3d axis2 = std::cos(a) * R_base.col(1) + std::sin(a) * R_base.col(2);
    S_pivot_.col(0) << axis1, anus.cross(axis1);
    S_pivot_.col(1) << axis2, anus.cross(axis2);
    const double EI_root = root >= s.first_bending_link
                               ? params.scope.bending_section_rigidity_N_m2
                               : params.scope.flexural_rigidity_N_m2;
    K_pivot_ = EI_root / (0.5 * root_inside_m + kPivotMinHalfLength_m);
    U_thrust_ = sc->articulated_stiffness[root] * S_thrust_;
    D_thrust_ = params.thrust_damping_N_s_per_m + S_thrust_.dot(U_thrust_);
  }

  // The scope's direction leaving the guide.
  const Eigen::Vector3d& z_root() const { return z_root_; }

  // The linearised step with its force terms (u, bA and the hand's push)
  // scaled by `scale`; the prescribed thrust (kPosition) is never scaled.
  // Returns the largest joint turn.
  double Solve(double scale);

  // Driven by force, the scope can meet its ends: all of it in (the control
  // body against the anus) or all out. There the thrust is held, not free:
  // the step is solved again with the insertion prescribed at that end (the
  // free solve's insertion, clamped), so the hand's push does not act on the
  // rest of the scope through the slide. True once the thrust is so held.
  bool HoldThrustAtEnd() {
    const double max_insert = params_.scope.working_length_m;
    if (input_.thrust_mode == ThrustMode::kForce &&
        (free_insertion_m_ > max_insert || free_insertion_m_ < 0.0)) {
      thrust_at_end_ = true;
    }
    return thrust_at_end_;
  }

  // Writes the solved increments into the state.
  void Apply(ModelState* s) const;

 private:
  const ModelParams& params_;
  const StepInput& input_;
  const double target_insertion_m_;
  const int root_;
  const ModelState& s_;
  Scratch* const sc_;
  Eigen::Vector3d z_root_;
  Vec6 S_thrust_;
  Eigen::Matrix<double, 6, 2> S_pivot_;
  double K_pivot_{0.0};
  Vec6 U_thrust_;
  double D_thrust_{0.0};
  bool thrust_at_end_{false};
  double free_insertion_m_{0.0};  // the force-driven solve's insertion, unclamped
  double d_insert_{0.0};
  Eigen::Vector2d dq_pivot_{Eigen::Vector2d::Zero()};
};

double BaseToTip::Solve(double scale) {
  const int n = static_cast<int>(s_.link_length_m.size());
  const double dt = params_.dt_s;
  const double D = params_.scope.joint_damping_N_m_s_per_rad;
  const double max_insert = params_.scope.working_length_m;
  const auto& IA = sc_->articulated_stiffness;
  const auto& bA = sc_->articulated_bias;
  const auto& S = sc_->motion_subspace;
  auto& delta = sc_->body_displacement;
  auto& dq = sc_->joint_increment;
  // Condense the thrust into the pivot's child.
  Mat6 IA_slide = IA[root_];
  Vec6 b_slide = scale * bA[root_];
  double u_thrust = 0.0;
  if (input_.thrust_mode == ThrustMode::kPosition || thrust_at_end_) {
    const double target_m = thrust_at_end_ ? free_insertion_m_ : target_insertion_m_;
    d_insert_ = std::clamp(target_m, 0.0, max_insert) - s_.inserted_m;
    b_slide.noalias() -= U_thrust_ * d_insert_;
  } else {
    u_thrust = scale * (dt * input_.push_force_N + S_thrust_.dot(bA[root_]));
    IA_slide.noalias() -= U_thrust_ * U_thrust_.transpose() / D_thrust_;
    b_slide.noalias() -= U_thrust_ * (u_thrust / D_thrust_);
  }
  // The pivot, from the world.
  const Eigen::Matrix<double, 6, 2> U_pivot = IA_slide * S_pivot_;
  Eigen::Matrix2d D_pivot = S_pivot_.transpose() * U_pivot;
  D_pivot.diagonal().array() += D + dt * K_pivot_;
  const Eigen::Vector2d u_pivot =
      scale * (-dt * K_pivot_ * (s_.bend_rad[root_] - s_.bend_rest_rad[root_])) +
      S_pivot_.transpose() * b_slide;
  dq_pivot_ = D_pivot.inverse() * u_pivot;
  const Vec6 delta_slide = S_pivot_ * dq_pivot_;
  if (input_.thrust_mode == ThrustMode::kForce && !thrust_at_end_) {
    d_insert_ = (u_thrust - U_thrust_.dot(delta_slide)) / D_thrust_;
    free_insertion_m_ = s_.inserted_m + d_insert_;
    d_insert_ = std::clamp(free_insertion_m_, 0.0, max_insert) - s_.inserted_m;
  }
  delta[root_] = delta_slide + S_thrust_ * d_insert_;
  double largest_turn = dq_pivot_.norm();
  for (int k = root_ + 1; k < n; ++k) {
    dq[k].noalias() =
        sc_->d_inverse[k] * (scale * sc_->u_vector[k] - sc_->u_matrix[k].transpose() * delta[k - 1]);
    largest_turn = std::max(largest_turn, dq[k].norm());
    delta[k] = delta[k - 1] + S[k] * dq[k];
  }
  return largest_turn;
}

void BaseToTip::Apply(ModelState* s) const {
  const int n = static_cast<int>(s->link_length_m.size());
  const double dt = params_.dt_s;
  const auto apply = [&](int k, Eigen::Vector2d turn_rad) {
    // The prescribed base motion alone can still ask for more; cut that joint.
    const double turn = turn_rad.norm();
    if (turn > kMaxJointTurnPerStep_rad) turn_rad *= kMaxJointTurnPerStep_rad / turn;
    s->bend_rad[k] += turn_rad;
    s->bend_rate_rad_per_s[k] = turn_rad / dt;
  };
  apply(root_, dq_pivot_);
  for (int k = root_ + 1; k < n; ++k) apply(k, sc_->joint_increment[k]);
  s->inserted_m += d_insert_;
  s->insertion_rate_m_per_s = d_insert_ / dt;
}

}  // namespace

void SolveScope(const ModelParams& params, const StepInput& input, double target_insertion_m,
                ModelState* s, Scratch* sc, StepOutput* out) {
  const int root = RootLink(*s);
  const AppliedLoad load = AddBodyTerms(params, input, root, *s, sc);
  const double root_inside_m = CalcRootInsideLength(*s);
  ArticulateJoints(params, root, root_inside_m, *s, sc);
  BaseToTip base(params, input, target_insertion_m, root, root_inside_m, *s, sc);
  // Reaction at the base, quasi-static: every inserted point moves with the
  // thrust, so the hand holds z . sum F (z the scope's direction leaving the
  // guide); the scope as a whole is in moment balance about the entry axis,
  // so the hand holds that moment too (forces at the start of the step; Step
  // adds the friction around the shaft).
  const Eigen::Vector3d e = CalcEntryRotation(params).col(2);
  out->base_force_N = -base.z_root().dot(load.force_N);
  out->roll_torque_Nm = -e.dot(load.moment_N_m);
  // The linearisation holds for small turns only. A step that would turn a
  // joint further (a loop snapping, a jammed chain buckling) is shortened as a
  // whole (a line search along the linearised solution), so the chain keeps
  // that solution's shape rather than one with a few joints cut short.
  double largest_turn = base.Solve(1.0);
  if (base.HoldThrustAtEnd()) largest_turn = base.Solve(1.0);
  if (largest_turn > kMaxJointTurnPerStep_rad) {
    base.Solve(kMaxJointTurnPerStep_rad / largest_turn);
  }
  base.Apply(s);
}

}  // namespace ves::model::internal
