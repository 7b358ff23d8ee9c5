#pragma once

#include <optional>
#include <string>

#include "station/training/observation.h"

namespace ves::ui {

// The endoscope view mode is the one the session records
// (training::ViewMode: wire-frame, flat polygons, texture): no other.
using training::ViewMode;
using training::AbdominalPress;
using training::PatientPosition;

// What the trainee asked for through keys, mouse and the control panel
// (paper §4.4). Without hardware (`--device sim`) the keyboard also moves the
// simulated hand: targets the simulated hand follows.
struct ControlState {
  ViewMode view_mode{ViewMode::kTextured};
  bool fluoroscopy_visible{false};
  bool damage_display{false};
  bool repeat_requested{false};   // consumed by the app when it restarts the session
  bool quit_requested{false};
  int case_choice{0};             // index into the panel's case list
  int scope_choice{0};            // index into the panel's scope list
  // Fluoroscopy camera (paper §4.3: any angle, continuously, and zoom).
  double fluoro_yaw_rad{0.0};
  double fluoro_pitch_rad{0.0};
  double fluoro_zoom{1.0};
  // Simulated hand and the angulation knobs.
  double hand_insertion_m{0.0};
  double hand_roll_rad{0.0};
  double knob_up_rad{0.0};
  double knob_right_rad{0.0};
  // The loop-control toolkit: where the assistant presses the abdomen and
  // how the patient lies; the model and the input log take them as asked.
  AbdominalPress abdominal_press{AbdominalPress::kNone};
  PatientPosition patient_position{PatientPosition::kSupine};
  bool operator==(const ControlState&) const = default;
};

// A repeated session starts clean (docs/station-ui.md): the X-ray off and the
// C-arm home (AP, no tilt, zoom 1), so no X-ray time is counted before the
// trainee asks for it. The hand, the knobs, the view mode, the damage display
// and the case and scope choices stay as they are.
void StartClean(ControlState* state);

// Step sizes and limits of the keyboard hand.
struct KeyboardHand {
  double insertion_step_m{0.005};
  double roll_step_rad{0.0872664626};   // 5 degrees
  double knob_step_rad{0.0872664626};
  double max_insertion_m{1.8};
  double max_knob_rad{3.14159265358979};  // 180 degrees; the scope's own limits clamp further
};

// Applies one key (as cv::waitKeyEx returns it) to the state; returns false
// when the key means nothing. The mapping is documented in docs/station-ui.md.
bool ApplyKey(int key, const KeyboardHand& hand, ControlState* state);

// One line per key, for the help overlay and the docs.
std::string KeyHelpText();

// For the panel: "none", "left lower quadrant", "mid-abdomen"; "supine",
// "left lateral", "right lateral".
const char* PressName(AbdominalPress press);
const char* PositionName(PatientPosition position);

// Mouse drag on the fluoroscopy view rotates it; the wheel zooms.
struct DragTracker {
  std::optional<std::pair<int, int>> last;
};
constexpr double kFluoroRadiansPerPixel = 0.01;
constexpr double kFluoroZoomPerWheelStep = 1.1;
constexpr double kFluoroMinZoom = 0.25;
constexpr double kFluoroMaxZoom = 8.0;

void ApplyFluoroDrag(int x, int y, bool button_down, DragTracker* drag, ControlState* state);
void ApplyFluoroWheel(int steps, ControlState* state);  // +: zoom in

}  // namespace ves::ui
