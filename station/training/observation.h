#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>

namespace ves::training {

// Endoscope view rendering mode (paper §4.2): wireframe for beginners, flat
// polygons for intermediates, texture-mapped mucosa for advanced trainees.
enum class ViewMode : std::uint8_t { kWireframe = 0, kFlat = 1, kTextured = 2 };

// Where the assistant's hand presses the abdomen to keep a straightened loop
// from bowing out again (docs/scoring.md, "Input log"): over the sigmoid apex
// in the left lower quadrant, or under the transverse colon mid-abdomen.
enum class AbdominalPress : std::uint8_t { kNone = 0, kLeftLowerQuadrant = 1, kMidAbdomen = 2 };

// The patient's position on the couch, as model::PatientPosition: gravity
// moves the mobile colon when the patient turns.
enum class PatientPosition : std::uint8_t { kSupine = 0, kLeftLateral = 1, kRightLateral = 2 };

// What the metrics need to know about one model step (DESIGN.md §5). Built
// from the model's step outputs plus the views' per-frame measures; plain
// data so the metrics can be tested on constructed sequences without a model.
// One observation stands for the interval (t_s - dt_s, t_s].
struct StepObservation {
  double t_s{0.0};  // time at the end of the step, from the session start
  double dt_s{0.001};
  double inserted_m{0.0};    // scope length past the anus
  double tip_arc_m{0.0};     // tip position as arc length along the colon from the anus
  double base_force_N{0.0};  // thrust force at the base: what the hand feels
  Eigen::Vector3d p_WTip{Eigen::Vector3d::Zero()};  // tip position, world frame (m)
  double max_wall_force_N{0.0};  // largest wall force over all segments this step
  double max_wall_force_arc_m{0.0};
  double peak_stretch_m{0.0};  // largest suspension stretch (mesentery pull), paper §3.3.1
  double peak_stretch_arc_m{0.0};
  // Per-segment wall force (N), optional: when given, damage is also mapped per segment.
  std::span<const double> segment_wall_force_N{};
  std::span<const double> segment_arc_m{};  // arc of each segment point, same length
  ViewMode view_mode{ViewMode::kTextured};
  bool fluoroscopy_on{false};
  AbdominalPress abdominal_press{AbdominalPress::kNone};
  PatientPosition patient_position{PatientPosition::kSupine};
  double redout_fraction{0.0};       // 0..1 of the endoscope image washed red (tip on the wall)
  double mucosa_seen_fraction{0.0};  // 0..1, cumulative coverage reported by the view
};

}  // namespace ves::training
