#pragma once

#include <opencv2/core.hpp>

#include "station/ui/controls.h"
#include "station/ui/training_screen.h"

namespace ves::ui {

// The one full-screen training window (OpenCV highgui without Qt's toolbar
// and status bar): covers the screen it opens on and shows ComposeScreen's
// canvas at exactly that size, so a mouse position is a canvas pixel. Keys,
// a drag or the wheel on the fluoroscopy, and clicks on the panel's buttons
// change the ControlState (docs/station-ui.md). All highgui calls happen on
// the thread that owns this object.
class TrainingWindow {
 public:
  static constexpr const char* kWindowName = "VES training";

  // Opens the window over the whole screen. Throws std::runtime_error with a
  // clear message when there is no display to open it on.
  explicit TrainingWindow(KeyboardHand hand = {});
  ~TrainingWindow();
  TrainingWindow(const TrainingWindow&) = delete;
  TrainingWindow& operator=(const TrainingWindow&) = delete;

  const ScreenLayout& layout() const { return layout_; }
  void Show(const cv::Mat& canvas_bgr);

  // Handles keys and mouse events for up to `wait_ms`, updating `state`.
  // Returns the number of inputs applied.
  int Poll(int wait_ms, const ScreenModel& model, ControlState* state);

 private:
  static void OnMouse(int event, int x, int y, int flags, void* self);

  KeyboardHand hand_;
  ScreenLayout layout_;
  DragTracker drag_;
  ControlState* polling_state_{nullptr};
  const ScreenModel* polling_model_{nullptr};
  int applied_{0};
};

// The size of the default screen of the X display (DISPLAY); throws
// std::runtime_error when it cannot be opened.
cv::Size ScreenSize();

}  // namespace ves::ui
