#pragma once

// The training screen (paper Fig. 14, as one full-screen window like the
// commercial trainers): the endoscope image large on the left, the
// fluoroscopy beside it, below that the control panel (view mode, X-ray on/off
// and C-arm angle, damage display, repeat, case and scope choice) and the live
// figures, and a status strip under the endoscope (session clock and state,
// device state, keys). Layout, hit testing and drawing are pure functions of
// the canvas size and the figures, so they are tested without a display.
#include <opencv2/core.hpp>

#include <optional>
#include <string>
#include <vector>

#include "station/training/debrief.h"
#include "station/ui/controls.h"
#include "station/ui/score_panel.h"

namespace ves::ui {

enum class PanelAction {
  kWireframe, kPolygon, kTexture, kToggleFluoroscopy, kToggleDamage,
  kCarmLeft, kCarmRight, kZoomOut, kZoomIn, kRepeat,
  kPreviousCase, kNextCase, kPreviousScope, kNextScope,
};

struct PanelButton {
  PanelAction action;
  cv::Rect rect;  // canvas pixels
  std::string label;
};

enum class SessionPhase { kReady, kRunning, kOver };
// ok: force feedback on; recovering: a transient fault or the fade-in after
// it (clears by itself); safe: a fault that needs a re-arm (r).
enum class DeviceStatus { kOk, kRecovering, kSafe };

// What the screen shows besides the views and the controls' own state.
struct ScreenModel {
  std::vector<std::string> case_names;
  std::vector<std::string> scope_names;
  SessionPhase phase{SessionPhase::kReady};
  std::string outcome;  // when over: "cecum reached", "time limit reached", ...
  double score{0.0};
  double score_max{100.0};
  double elapsed_s{0.0};
  double time_limit_s{0.0};
  double inserted_m{0.0};
  double tip_arc_m{0.0};
  std::string tip_region;  // "sigmoid", ...
  double roll_rad{0.0};
  double hand_force_N{0.0};  // measured at the device, + pushes in
  double force_gauge_max_N{20.0};
  // The gauge's labelled mark; the bar turns red above it: the steady push of
  // a colonoscopist's hand, 10 N (over it 5 % of the time: Appleyard et al.,
  // GIE 2000), which the keyboard's hand never exceeds (haptics::KeyboardPush).
  double hand_limit_N{10.0};
  // What the score weighs, live (score_panel.h), and its thresholds.
  ScoreFigures score_figures;
  double excessive_wall_force_N{4.0};  // the force part counts time over it
  double damage_wall_force_N{14.0};    // a damage episode: held over it
  double damage_penalty_points{10.0};  // per damage episode
  // When over: the session's score in its weighed parts (none: no record,
  // e.g. nothing went in) and the sitting's line (SittingLine).
  training::Debrief debrief;
  std::string sitting_line;
  DeviceStatus device_status{DeviceStatus::kOk};
  std::string device_text;  // "force feedback on", "SAFE STATE: bus-off (r re-arms)", ...
  bool fluoroscopy_allowed{true};
};

// Where everything is on a canvas of a given size: a 1920×1080 design scaled
// uniformly to fit (1366×768 is 0.71 of it) and centred.
struct ScreenLayout {
  cv::Size canvas;
  double scale{1.0};
  cv::Rect endoscope;
  cv::Rect fluoroscopy;
  cv::Rect status;   // under the endoscope: clock, state, device, keys
  cv::Rect panel;    // buttons, case/scope, figures, force gauge
  cv::Rect figures;  // the live figures inside the panel
  cv::Rect gauge;    // the force gauge bar
  cv::Rect banner;   // "session over" and the debrief, across the endoscope image
  cv::Rect warning;  // the damage warning, across the top of the endoscope image
  std::vector<PanelButton> buttons;
};

ScreenLayout MakeScreenLayout(cv::Size canvas);

std::optional<PanelAction> HitTestScreen(const ScreenLayout& layout, int x, int y);

// Applies a click; case/scope choice wraps around the model's lists.
void ApplyPanelAction(PanelAction action, const ScreenModel& model, ControlState* state);

// The whole screen. `endoscope_bgr` and `fluoroscopy_bgr` are scaled to
// their areas keeping their aspect; an empty fluoroscopy shows "X-ray off"
// (or "not allowed in this lesson"); an empty endoscope shows "starting".
cv::Mat ComposeScreen(const ScreenLayout& layout, const cv::Mat& endoscope_bgr,
                      const cv::Mat& fluoroscopy_bgr, const ScreenModel& model,
                      const ControlState& controls);

// Draws `text` left-aligned (or centred) in `box`, vertically centred, with
// the largest font scale <= `scale` whose width fits the box: text is made
// smaller, never cut. Returns the scale used.
double DrawTextFitted(cv::Mat& image, const std::string& text, const cv::Rect& box, double scale,
                      const cv::Scalar& color, bool centred = false, int thickness = 1);

}  // namespace ves::ui
