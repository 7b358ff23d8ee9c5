#include "station/ui/training_window.h"

#include <X11/Xlib.h>

#include <opencv2/highgui.hpp>

#include <cstdlib>
#include <stdexcept>
#include <string>

namespace ves::ui {

cv::Size ScreenSize() {
  Display* display = XOpenDisplay(nullptr);
  if (display == nullptr) {
    const char* name = std::getenv("DISPLAY");
    throw std::runtime_error(std::string("cannot open the X display '") + (name ? name : "") +
                             "': start the station in its graphical session (docs/operations.md), "
                             "under xvfb-run, or with --headless");
  }
  const int screen = DefaultScreen(display);
  const cv::Size size(DisplayWidth(display, screen), DisplayHeight(display, screen));
  XCloseDisplay(display);
  return size;
}

TrainingWindow::TrainingWindow(KeyboardHand hand) : hand_(hand) {
  const char* display = std::getenv("DISPLAY");
  if (display == nullptr || *display == '\0') {
    throw std::runtime_error(
        "no display (DISPLAY is not set): start the station in its graphical session "
        "(docs/operations.md), under xvfb-run, or with --headless");
  }
  layout_ = MakeScreenLayout(ScreenSize());
  try {
    // GUI_NORMAL: no Qt toolbar or status bar; NORMAL: the window may take
    // the screen's size whatever the image's.
    cv::namedWindow(kWindowName, cv::WINDOW_NORMAL | cv::WINDOW_GUI_NORMAL);
  } catch (const cv::Exception& error) {
    throw std::runtime_error(std::string("cannot open the training window: ") + error.what());
  }
  // Without a window manager (a bare X server) full screen is not honoured:
  // place and size the window on the screen ourselves as well.
  cv::moveWindow(kWindowName, 0, 0);
  cv::resizeWindow(kWindowName, layout_.canvas.width, layout_.canvas.height);
  cv::setWindowProperty(kWindowName, cv::WND_PROP_FULLSCREEN, cv::WINDOW_FULLSCREEN);
  cv::setMouseCallback(kWindowName, &TrainingWindow::OnMouse, this);
}

TrainingWindow::~TrainingWindow() { cv::destroyAllWindows(); }

void TrainingWindow::Show(const cv::Mat& canvas_bgr) { cv::imshow(kWindowName, canvas_bgr); }

int TrainingWindow::Poll(int wait_ms, const ScreenModel& model, ControlState* state) {
  polling_state_ = state;
  polling_model_ = &model;
  applied_ = 0;
  const int key = cv::waitKeyEx(std::max(wait_ms, 1));
  // n / m step the panel's case / scope choice (they need the panel's lists).
  if (key == 'n' || key == 'm') {
    ApplyPanelAction(key == 'n' ? PanelAction::kNextCase : PanelAction::kNextScope, model, state);
    ++applied_;
  } else if (key >= 0 && ApplyKey(key, hand_, state)) {
    ++applied_;
  }
  polling_state_ = nullptr;
  polling_model_ = nullptr;
  return applied_;
}

void TrainingWindow::OnMouse(int event, int x, int y, int flags, void* self) {
  auto* window = static_cast<TrainingWindow*>(self);
  if (window->polling_state_ == nullptr) return;
  ControlState* state = window->polling_state_;
  const bool in_fluoroscopy = window->layout_.fluoroscopy.contains({x, y});
  if (event == cv::EVENT_MOUSEWHEEL) {
    if (in_fluoroscopy) {
      ApplyFluoroWheel(cv::getMouseWheelDelta(flags) > 0 ? 1 : -1, state);
      ++window->applied_;
    }
    return;
  }
  if (event == cv::EVENT_LBUTTONDOWN) {
    if (const auto action = HitTestScreen(window->layout_, x, y)) {
      ApplyPanelAction(*action, *window->polling_model_, state);
      ++window->applied_;
      return;
    }
  }
  // A drag that starts on the fluoroscopy rotates the C-arm until released.
  const bool down = (flags & cv::EVENT_FLAG_LBUTTON) != 0 && event != cv::EVENT_LBUTTONUP;
  const bool dragging = window->drag_.last.has_value();
  if (!dragging && !(down && in_fluoroscopy)) return;
  ApplyFluoroDrag(x, y, down, &window->drag_, state);
  if (down && dragging) ++window->applied_;
}

}  // namespace ves::ui
