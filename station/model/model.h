#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "station/model/colon.h"
#include "station/model/endoscope.h"

// The endoscope-colon model of paper §3 (docs/model.md). A step is a pure
// function of (params, input, state): no I/O, threads, clocks or globals, and
// no heap allocation inside Step (state, scratch and output are preallocated).
//
// Frames: W is the patient frame of the case (origin at the anus, +z cranial,
// +y anterior, +x the patient's right; metres). Every link frame L_k has its
// origin at the link's proximal joint and +z along the link toward the tip.
// The tip frame Tip sits at the distal end: the camera looks along +z, +y is
// "up" in the endoscope image (the up/down knob bends toward +y), +x is image
// right (the right knob bends toward +x).
namespace ves::model {

enum class ThrustMode : std::uint8_t {
  kPosition,  // insertion_m prescribed (haptic device encoder)
  kForce,     // push_force_N applied at the base (the paper's constant-force run)
};

struct ModelParams {
  ColonSpec colon;
  EndoscopeParams scope;
  double dt_s{0.001};
  Eigen::Vector3d gravity_W_m_per_s2{0.0, -9.81, 0.0};  // supine patient: posterior is -y
  double thrust_damping_N_s_per_m{40.0};    // base thrust DOF in kForce mode
  double sample_spacing_m{0.012};           // contact sample points along the scope
  double wall_hardening_ratio{4.0};         // wall stiffness beyond L, times K_d (eq. 10)
  double friction_stiffness_N_per_m{500.0};  // tangential stick spring of one contact
  double outer_cone_ratio{1.5};             // r0 = ratio * F_s * |f_n|, eq. (16)
  int contact_search_window{4};             // segments searched each way per step
  // How far ahead of its proximal neighbour's a sample's tracked colon arc may
  // run, per metre of scope between them (+2 segments; at most 2 behind):
  // the colon has no contact with itself, so at a loop's pinched neck two
  // lumens overlap and the local search alone would walk across. 0: no limit.
  double tracking_arc_ratio{1.5};
  // Axial give of the colon (experimental, off by default: docs/model.md,
  // "Known limits", says why): each point may also
  // slide along its rest tangent, anchored by its own suspension (K_c, D_c),
  // and neighbours resist a change of their gap: stretching with the wall's
  // longitudinal stiffness EA, shortening (the wall folding, "pleating" onto
  // the scope) with pleat_stiffness_ratio * EA until the gap has shortened by
  // pleat_limit, beyond which the folds are packed (pleat_hardening_ratio * EA).
  double colon_longitudinal_stiffness_N{0.0};  // EA (N per unit strain); 0: no axial give
  double colon_pleat_stiffness_ratio{0.05};
  double colon_pleat_limit{0.6};                 // largest shortening strain before packing
  double colon_pleat_hardening_ratio{50.0};
  bool operator==(const ModelParams&) const = default;
};

// Throws std::invalid_argument naming the bad field and value.
void ValidateParams(const ModelParams& params);

struct StepInput {
  ThrustMode thrust_mode{ThrustMode::kPosition};
  double insertion_m{0.0};     // kPosition: inserted length past the anus
  double push_force_N{0.0};    // kForce: hand force along the entry axis (+ inserts)
  double roll_rad{0.0};        // base roll about the entry axis (right hand rule)
  double knob_up_rad{0.0};     // + up, - down (clamped to the scope's angulation)
  double knob_right_rad{0.0};  // + right, - left
  Eigen::Vector3d tip_force_W_N{Eigen::Vector3d::Zero()};  // external load at the tip
};

// A point along the scope where contact and gravity act (fixed at creation).
struct ScopeSample {
  int link{0};                  // link index, 0 = base, n-1 = tip link
  double offset_m{0.0};         // from the link's proximal joint along +z
  double arc_from_tip_m{0.0};   // scope arc length from the distal tip
  double mass_kg{0.0};          // share of the scope's mass
};

// Per-sample contact memory: the tracked colon segment (never found by a global
// search, so a looped colon cannot tunnel) and the friction stick spring.
struct SampleContact {
  int segment{0};               // colon segment [segment, segment+1] it lies in
  double segment_t{0.0};        // position between them, 0..1
  Eigen::Vector3d slip_m{Eigen::Vector3d::Zero()};  // tangential stick displacement
  double penetration_m{0.0};    // radial wall deformation l (last step)
  bool inside{false};           // past the anus
  bool touching{false};
  bool sliding{false};          // outside the static cone (alpha > 0, eq. 16)
};

struct ModelState {
  double time_s{0.0};
  std::int64_t step_count{0};

  // Scope generalized coordinates q.
  double inserted_m{0.0};                    // thrust
  double roll_rad{0.0};
  std::vector<Eigen::Vector2d> bend_rad;     // [k]: (pitch about x, yaw about y) at the
                                             // proximal joint of link k; [0] is the base
  std::vector<Eigen::Vector2d> bend_rest_rad;  // q0 (knobs set the bending section's)
  std::vector<Eigen::Vector2d> bend_rate_rad_per_s;
  double insertion_rate_m_per_s{0.0};

  // Scope shape at the end of the last step.
  std::vector<Eigen::Isometry3d> X_WLink;    // [k] at link k's proximal joint
  Eigen::Isometry3d X_WTip{Eigen::Isometry3d::Identity()};
  std::vector<Eigen::Vector3d> p_WSample;
  int first_inside_link{0};                  // most proximal link whose proximal joint is in

  // Fixed layout derived from params at creation.
  std::vector<double> link_length_m;
  std::vector<double> joint_stiffness_N_m_per_rad;  // [k] at link k's proximal joint
  int first_bending_link{0};
  std::vector<ScopeSample> samples;          // ordered base -> tip; the last is the tip

  std::vector<SampleContact> contact;        // one per sample
  // Samples past the anus are a suffix (arc_from_tip_m < inserted_m): those
  // from this index on, as of the last contact evaluation.
  int first_inside_sample{0};

  // Colon: each point moves only in its plane P_i.
  std::vector<Eigen::Vector2d> colon_offset_m;  // d_ri in (plane_u, plane_v)
  std::vector<Eigen::Vector2d> colon_rate_m_per_s;
  // Axial give: offset of point i along its rest tangent (its plane P_i moves
  // with it, the plane's normal stays the rest tangent).
  std::vector<double> colon_axial_m;
  std::vector<double> colon_axial_rate_m_per_s;
  std::vector<Eigen::Vector3d> p_WColon;     // current r_i
  std::vector<double> wall_deformation_m;    // largest radial l at each point

  double tip_arc_m{0.0};                     // tip position along the rest centerline
};

struct Contact {
  int sample{0};
  int segment{0};
  double colon_arc_m{0.0};
  double scope_arc_from_tip_m{0.0};
  Eigen::Vector3d p_W{Eigen::Vector3d::Zero()};
  Eigen::Vector3d normal_W{Eigen::Vector3d::Zero()};  // from the lumen axis toward the wall
  double penetration_m{0.0};
  double normal_force_N{0.0};
  Eigen::Vector3d force_on_scope_W_N{Eigen::Vector3d::Zero()};  // F_i of eq. (17)
  double alpha{0.0};                         // eq. (16): 0 stick, 1 slide
  bool beyond_threshold{false};              // ||l|| > L (eq. 10)
};

struct StepOutput {
  double base_force_N{0.0};      // thrust reaction along the entry axis: + resists insertion
  double roll_torque_Nm{0.0};   // reaction about the entry axis
  Eigen::Isometry3d X_WTip{Eigen::Isometry3d::Identity()};
  double tip_arc_m{0.0};
  double inserted_m{0.0};
  std::vector<double> wall_force_N;  // per colon point: normal contact force on the wall
  std::vector<double> stretch_m;     // per colon point: suspension stretch |d_ri|
  double peak_stretch_m{0.0};
  double peak_stretch_arc_m{0.0};
  double peak_wall_force_N{0.0};
  std::vector<Contact> contacts;     // first contact_count entries are valid
  int contact_count{0};
  double velocity_norm_m_per_s{0.0};  // sqrt(sum |v_sample|^2 + sum |v_colon|^2)
  bool finite{true};                  // false if any NaN/Inf appeared (state not trusted)
};

// Work arrays for Step, sized once.
struct Scratch {
  std::vector<Eigen::Matrix<double, 6, 6>> articulated_stiffness;
  std::vector<Eigen::Matrix<double, 6, 1>> articulated_bias;
  std::vector<Eigen::Matrix<double, 6, 2>> motion_subspace;
  std::vector<Eigen::Matrix<double, 6, 2>> u_matrix;
  std::vector<Eigen::Matrix2d> d_inverse;
  std::vector<Eigen::Vector2d> u_vector;
  std::vector<Eigen::Matrix<double, 6, 1>> body_displacement;
  std::vector<Eigen::Vector2d> joint_increment;
  std::vector<Eigen::Vector3d> sample_force_W_N;
  // Linearised contact stiffness k_n n n^T + k_t (I - n n^T) of each touching
  // sample, kept as k_n (k_t = friction_stiffness_N_per_m, n = sample_normal_W).
  std::vector<double> sample_normal_stiffness_N_per_m;
  std::vector<Eigen::Vector3d> sample_normal_W;
  std::vector<Eigen::Vector3d> sample_friction_W_N;
  std::vector<double> sample_normal_force_N;
  std::vector<double> sample_normal_slope_N_per_m;
  std::vector<Eigen::Vector3d> sample_delta_m;
  std::vector<Eigen::Matrix2d> colon_diag;
  std::vector<Eigen::Matrix2d> colon_upper;  // block (i, i+1)
  std::vector<Eigen::Vector2d> colon_rhs;
  std::vector<Eigen::Matrix2d> colon_work;
  // Constant parts of the colon system, computed once by MakeScratch from the
  // rest geometry and dt (a Scratch belongs to the params it was made from).
  std::vector<double> colon_pair_k_N_per_m;        // [i]: coupling T/gap of points i, i+1
  std::vector<Eigen::Matrix2d> colon_pair_transfer;  // [i]: B_i^T B_(i+1), plane i+1 -> i
  std::vector<double> colon_suspension_N_per_m;    // [i]: K_c h_i
  std::vector<double> colon_base_diag;             // [i]: D_c h + dt (K_c h + couplings)
  std::vector<double> colon_stiffness_diag;        // [i]: dt (K_c h + couplings)
  std::vector<Eigen::Matrix2d> colon_pair_upper;   // [i]: -dt (T/gap) B_i^T B_(i+1)
  // Axial give: tridiagonal system of the tangential offsets (scalar per point).
  std::vector<double> axial_diag;
  std::vector<double> axial_upper;                 // (i, i+1)
  std::vector<double> axial_rhs;                   // after the solve: the increments
  std::vector<double> axial_work;
  std::vector<double> axial_pair_gap_m;            // [i]: rest distance of points i, i+1
};

ModelState MakeInitialState(const ModelParams& params);  // validates params; may throw
Scratch MakeScratch(const ModelParams& params);
StepOutput MakeStepOutput(const ModelParams& params);

// One time step of dt_s (docs/model.md): contacts (eqs. 9-17), a linearly
// implicit scope update solving eq. (6) by an O(n) articulated recursion, then
// a linearly implicit colon update. Never throws, never allocates.
void Step(const ModelParams& params, const StepInput& input, ModelState* state, Scratch* scratch,
          StepOutput* output);

}  // namespace ves::model
