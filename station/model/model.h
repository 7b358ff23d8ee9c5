#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "station/model/colon.h"
#include "station/model/compiled_model.h"
#include "station/model/endoscope.h"
#include "station/model/experiments.h"

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

// The patient's position on the couch (docs/model.md, "Position and
// pressure"): gravity turns with it in the patient frame W, and the mobile
// colon's weight moves it. Supine: back down (-y); left lateral: left side
// down; right lateral: right side down.
enum class PatientPosition : std::uint8_t {
  kSupine = 0,
  kLeftLateral = 1,
  kRightLateral = 2,
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
  // lumens overlap and the local search alone would walk across. A pleated
  // colon packs up to 1/pleat_limit of its arc on a metre of scope, so the
  // ratio used is at least 1.2/(smallest pleat_limit). 0: no limit.
  double tracking_arc_ratio{1.5};
  // The colon wall along the tube (docs/model.md, "Axial links"), per unit
  // strain of a gap (so independent of N). In tension it may be J-shaped
  // like other soft tissue (a compliant toe up to colon_toe_strain, then the
  // wall's linear modulus EA); by default the toe is as stiff as the wall, so
  // there is none: a soft toe lets the scope stretch the sigmoid and
  // transverse colon and the expert reaches less deep
  // (docs/model-shortening-notes.md). Shortened, the wall folds onto the
  // scope (pleats) softly down to each region's pleat_limit, then the folds
  // are packed.
  double colon_toe_stiffness_N{500.0};
  double colon_toe_strain{0.2};
  // Regions whose wall has the toe (bit 1 << Region; all by default): a gap
  // has it when both its points are in one of them
  // (docs/model-shortening-notes.md, "A sigmoid that stretches").
  std::uint32_t colon_toe_regions{~0u};
  double colon_tension_stiffness_N{500.0};
  // A gap with a gathered reserve (TissueParams::gathered_reserve) lengthens
  // from its rest length to its material length at this stiffness per unit
  // strain (the telescoped folds straighten), then the wall strains at
  // colon_tension_stiffness_N (docs/model.md, "The gathered reserve").
  double colon_straighten_stiffness_N{2.0};
  double colon_pleat_stiffness_N{1.0};
  double colon_packed_stiffness_N{500.0};
  // Folds set: a gap held shortened takes its length as its rest length with
  // this time constant (the gathered colon stays on the scope), and returns
  // to its natural rest length with the release time constant once no longer
  // shortened. 0: never (the gap's rest length stays the natural one).
  // Set fast and released over about a procedure's length, a reduced colon
  // stays gathered while the scope re-advances (docs/model.md).
  double colon_pleat_set_s{0.5};
  double colon_pleat_release_s{600.0};
  // The mobile colon's weight per metre (wall and contents, estimate): on
  // turning the patient (StepInput::patient_position) the change of gravity
  // from supine acts on it, so the mobile colon sags toward the lower side.
  double colon_linear_mass_kg_per_m{0.3};
  // The assistant's hand on the abdomen (StepInput::abdominal_pressure): at
  // full pressure a pressed region's points are held within the slack of
  // their mesentery root with this stiffness per metre of colon; the hand
  // presses in and lets go over abdominal_pressure_ramp_s (pressed in at
  // once, it snaps the sigmoid inward with a spike of about 100 N at the
  // base; docs/model.md, "Position and pressure").
  double abdominal_pressure_stiffness_N_per_m2{10000.0};
  double abdominal_pressure_slack_m{0.01};
  double abdominal_pressure_ramp_s{5.0};
  // A sample's wall contact pushes across the scope's axis: the side of a
  // cylinder takes only radial loads (the tip keeps its end face). Where the
  // colon folds askew onto the scope the lumen plane's offset points along
  // the shaft and would hold a withdrawing scope like a barb (docs/model.md,
  // "Contact"). false: along the offset (contact_geometry_test compares).
  bool contacts_across_scope{true};
  // A ring contact (a colon point held round the scope piece between two
  // samples) takes its load over this time once it appears, linearly. The
  // tracking hands a point from a sample's segment to a ring in one step,
  // and where the colon folds sharply the point is then millimetres inside:
  // taken at once, its load is a one-step jump of 5-11 N that the hand feels
  // as a roll torque spike of up to 2.2 N m. 10 ms: the resolution of the
  // hand force (docs/model.md, "Ring contacts"). 0: at once.
  double ring_onset_s{0.01};
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
  // The assistant's hand pressing over a region (index: Region), 0..1: it
  // flattens that region's mobile colon onto its mesentery root, so a
  // straightened loop cannot bow out again (docs/model.md).
  std::array<double, 9> abdominal_pressure{};
  PatientPosition patient_position{PatientPosition::kSupine};
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

  // Colon: each point r_i moves in 3-D, d_i = r_i - rest position.
  std::vector<Eigen::Vector3d> colon_displacement_m;
  // Where the paper's suspension pulls each point (its rest position, or
  // where it has settled: TissueParams::suspension_relaxation_s).
  std::vector<Eigen::Vector3d> colon_reference_m;
  // Rest length of the gap between points i and i+1: the natural one, or
  // shorter where folds have set (ModelParams::colon_pleat_set_s).
  std::vector<double> colon_pair_rest_gap_m;
  std::vector<Eigen::Vector3d> colon_velocity_m_per_s;
  std::vector<Eigen::Vector3d> p_WColon;     // current r_i
  // Current unit tangent of the tube at each point (central difference of the
  // neighbours, as of the end of the last step): the normal of the lumen's
  // plane at r_i for the contacts and the views.
  std::vector<Eigen::Vector3d> colon_tangent;
  // Derived from p_WColon as of the end of the last step, kept so that each
  // is taken once per step (SolveColon and the outputs read them): the
  // length of the gap between points i and i+1, and each point's distance
  // from its tether anchor in the tether's metric (CalcTetherDistance).
  std::vector<double> colon_gap_m;
  std::vector<double> colon_tether_distance_m;
  // The lumen's radius at each point (the case's, or less where the folds
  // have set: ModelExperiments::lumen_gather_pleat).
  std::vector<double> colon_lumen_radius_m;
  std::vector<double> wall_deformation_m;    // largest radial l at each point
  // How far each colon point's ring contact has come on (0..1;
  // ModelParams::ring_onset_s); 0 where the point is not held as a ring.
  std::vector<double> ring_onset;
  // The assistant's hand over each region as pressed in now (0..1): follows
  // StepInput::abdominal_pressure at ModelParams::abdominal_pressure_ramp_s.
  std::array<double, 9> abdominal_pressure_level{};

  // Tip position along the colon's material (rest arc of the tracked point
  // of the wall): where in the colon the tip is, however the colon pleats.
  double tip_arc_m{0.0};
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
  // Per colon point: mesentery stretch, how far the tether is pulled beyond
  // its reach (the pain signal, paper §3.3.1).
  std::vector<double> stretch_m;
  // Per colon point: current length of the tube it stands for over its rest
  // length (< 1 pleated onto the scope, > 1 stretched).
  std::vector<double> pleat_ratio;
  double peak_stretch_m{0.0};
  double peak_stretch_arc_m{0.0};
  double peak_wall_force_N{0.0};
  double peak_fixed_displacement_m{0.0};  // largest |d_i| of a fixed (retroperitoneal) point
  // The wall's own strain, largest over the gaps: a gap's length over its
  // material length (its rest arc), less 1; the gathered reserve is spent
  // before it rises above 0.
  double peak_wall_strain{0.0};
  std::vector<Contact> contacts;     // first contact_count entries are valid
  int contact_count{0};
  double velocity_norm_m_per_s{0.0};  // sqrt(sum |v_sample|^2 + sum |v_colon|^2)
  bool finite{true};                  // false if any NaN/Inf appeared (state not trusted)
};

// A colon point the scope runs through between two of its samples (the colon
// pleated onto the scope, or a loop's neck): its ring must contain the scope
// piece between them. Frictionless; the samples' contacts carry the friction.
struct RingContact {
  int point{0};          // colon point
  int sample{0};         // proximal sample of the scope piece
  double piece_t{0.0};   // where along the piece, 0 at the sample, 1 at the next one
  Eigen::Vector3d p_W{Eigen::Vector3d::Zero()};       // closest point of the scope piece
  Eigen::Vector3d normal_W{Eigen::Vector3d::UnitX()};  // from the ring's centre toward it
  double penetration_m{0.0};
  double force_N{0.0};
  double slope_N_per_m{0.0};
  double stiffness_N_per_m{0.0};  // slope + D_d / dt
  double onset{1.0};              // share of the load taken (ModelParams::ring_onset_s)
};

// The colon's block-tridiagonal system (3x3 blocks, points 0..N-1), one
// array per entry so that the solver's loops take four points at a time
// (docs/model.md, "Speed").
struct ColonSystem {
  std::array<std::vector<double>, 6> diag;   // D_i's upper triangle: 00, 01, 02, 11, 12, 22
  std::array<std::vector<double>, 9> upper;  // U_i, the block (i, i+1): entry (r, c) at 3 r + c
  CoordinateArrays rhs;                      // r_i, the impulses dt F of the step (per coordinate)
  // The elimination's gains G_i and its solution x_i (the increments of
  // r_i), four entries a row (the fourth unused) so that a row is one vector
  // in the elimination: G_i's (r, c) at 12 i + 4 r + c, x_i's c at 4 i + c.
  std::vector<double> gain;
  std::vector<double> solution;
  Eigen::Vector3d Rhs(int i) const { return {rhs[0][i], rhs[1][i], rhs[2][i]}; }
  Eigen::Vector3d Solution(int i) const {
    return {solution[4 * i], solution[4 * i + 1], solution[4 * i + 2]};
  }
  void Resize(int points);  // zeroes every entry
};

// SolveColon's per-step arrays, one per coordinate (padded by
// kColonLanePadding); the constants they are combined with are the
// CompiledModel's.
struct ColonSolverArrays {
  // Copies of the colon's state, taken at the start of each solve.
  CoordinateArrays position_m;       // p_WColon
  CoordinateArrays reference_m;      // colon_reference_m
  CoordinateArrays tangent;          // colon_tangent
  // colon_gap_m one entry later: [i + 1] is the gap ahead of point i and
  // [i] the one behind it ([0] = 0, before point 0).
  std::vector<double> gap_m;
  std::vector<double> rest_gap_m;    // colon_pair_rest_gap_m
  std::vector<double> tether_distance_m;
  // Each pair's dt C (its stiffness block's upper triangle, ordered as
  // ColonSystem::diag) and dt F (its force on point i) this step.
  std::array<std::vector<double>, 6> pair_block;
  CoordinateArrays pair_impulse;
  void Resize(int points);
};

// What Step works with besides the state: the compiled model (constant,
// built once by MakeScratch; Step only reads it) and the work arrays of a
// step (sized once; the state, not these, is what a step leaves for the next).
struct Scratch {
  CompiledModel compiled;
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
  std::vector<RingContact> ring_contacts;  // first ring_contact_count valid, by sample
  int ring_contact_count{0};
  std::vector<std::uint8_t> ring_held;    // [point]: held as a ring this step
  // [point]: the lumen plane's normal, once computed this step (contact.cc).
  std::vector<Eigen::Vector3d> lumen_normal_W;
  std::vector<std::uint8_t> lumen_normal_known;
  // The colon's system and the solver's per-coordinate arrays (SolveColon).
  ColonSystem colon_system;
  ColonSolverArrays colon_arrays;
};

ModelState MakeInitialState(const ModelParams& params);  // validates params; may throw
// Compiles the model (CompileModel) and sizes the work arrays; the
// experiments are the benches' (the product uses the defaults).
Scratch MakeScratch(const ModelParams& params, const ModelExperiments& experiments = {});
StepOutput MakeStepOutput(const ModelParams& params);

// One time step of dt_s (docs/model.md): contacts (eqs. 9-17), a linearly
// implicit scope update solving eq. (6) by an O(n) articulated recursion, then
// a linearly implicit colon update. Never throws, never allocates.
void Step(const ModelParams& params, const StepInput& input, ModelState* state, Scratch* scratch,
          StepOutput* output);

}  // namespace ves::model
