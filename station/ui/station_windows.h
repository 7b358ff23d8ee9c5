#pragma once

#include <opencv2/core.hpp>

#include "station/ui/control_panel.h"
#include "station/ui/controls.h"

namespace ves::ui {

// The station's three OpenCV highgui windows (paper Fig. 14): endoscope view,
// fluoroscopy view (drag to rotate, wheel to zoom) and the control panel.
// All highgui calls happen on the thread that owns this object.
class StationWindows {
 public:
  static constexpr const char* kEndoscopeWindow = "VES endoscope";
  static constexpr const char* kFluoroscopyWindow = "VES fluoroscopy";
  static constexpr const char* kPanelWindow = "VES control";

  // Opens the windows. Throws std::runtime_error with a clear message when
  // there is no display to open them on.
  explicit StationWindows(KeyboardHand hand = {});
  ~StationWindows();
  StationWindows(const StationWindows&) = delete;
  StationWindows& operator=(const StationWindows&) = delete;

  // A lesson without fluoroscopy: the X-ray window says so instead of
  // offering the key that turns it on.
  void SetFluoroscopyAllowed(bool allowed) { fluoroscopy_allowed_ = allowed; }

  // Shows the latest frames; an empty fluoroscopy image shows "X-ray off"
  // (or "not allowed in this lesson").
  void Show(const cv::Mat& endoscope_bgr, const cv::Mat& fluoroscopy_bgr, const cv::Mat& panel_bgr);

  // Handles keys and mouse events for up to `wait_ms`, updating `state`.
  // Returns the number of inputs applied.
  int Poll(int wait_ms, const PanelModel& model, ControlState* state);

 private:
  static void OnFluoroscopyMouse(int event, int x, int y, int flags, void* self);
  static void OnPanelMouse(int event, int x, int y, int flags, void* self);

  KeyboardHand hand_;
  DragTracker drag_;
  ControlState* polling_state_{nullptr};
  const PanelModel* polling_model_{nullptr};
  int applied_{0};
  bool fluoroscopy_allowed_{true};
};

}  // namespace ves::ui
