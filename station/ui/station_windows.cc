#include "station/ui/station_windows.h"

#include <opencv2/highgui.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdlib>
#include <stdexcept>

namespace ves::ui {

StationWindows::StationWindows(KeyboardHand hand) : hand_(hand) {
  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((!display || !*display) && (!wayland || !*wayland)) {
    throw std::runtime_error(
        "no display: DISPLAY is not set (run under X11, or use --headless, or xvfb-run)");
  }
  try {
    cv::namedWindow(kEndoscopeWindow, cv::WINDOW_AUTOSIZE);
    cv::namedWindow(kFluoroscopyWindow, cv::WINDOW_AUTOSIZE);
    cv::namedWindow(kPanelWindow, cv::WINDOW_AUTOSIZE);
  } catch (const cv::Exception& error) {
    throw std::runtime_error(std::string("cannot open the station windows: ") + error.what());
  }
  cv::setMouseCallback(kFluoroscopyWindow, &StationWindows::OnFluoroscopyMouse, this);
  cv::setMouseCallback(kPanelWindow, &StationWindows::OnPanelMouse, this);
}

StationWindows::~StationWindows() { cv::destroyAllWindows(); }

void StationWindows::Show(const cv::Mat& endoscope_bgr, const cv::Mat& fluoroscopy_bgr,
                          const cv::Mat& panel_bgr) {
  cv::imshow(kEndoscopeWindow, endoscope_bgr);
  if (fluoroscopy_bgr.empty()) {
    cv::Mat off(endoscope_bgr.size().empty() ? cv::Size(480, 480) : endoscope_bgr.size(), CV_8UC3,
                cv::Scalar(20, 20, 20));
    cv::putText(off, fluoroscopy_allowed_ ? "X-ray off (f)" : "X-ray not allowed in this lesson",
                {20, 40}, cv::FONT_HERSHEY_SIMPLEX, 0.8,
                cv::Scalar(200, 200, 200), 1, cv::LINE_AA);
    cv::imshow(kFluoroscopyWindow, off);
  } else {
    cv::imshow(kFluoroscopyWindow, fluoroscopy_bgr);
  }
  cv::imshow(kPanelWindow, panel_bgr);
}

int StationWindows::Poll(int wait_ms, const PanelModel& model, ControlState* state) {
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

void StationWindows::OnFluoroscopyMouse(int event, int x, int y, int flags, void* self) {
  auto* windows = static_cast<StationWindows*>(self);
  if (!windows->polling_state_) return;
  if (event == cv::EVENT_MOUSEWHEEL) {
    ApplyFluoroWheel(cv::getMouseWheelDelta(flags) > 0 ? 1 : -1, windows->polling_state_);
    ++windows->applied_;
    return;
  }
  const bool down = (flags & cv::EVENT_FLAG_LBUTTON) != 0 && event != cv::EVENT_LBUTTONUP;
  const bool was_dragging = windows->drag_.last.has_value();
  ApplyFluoroDrag(x, y, down, &windows->drag_, windows->polling_state_);
  if (down && was_dragging) ++windows->applied_;
}

void StationWindows::OnPanelMouse(int event, int x, int y, int, void* self) {
  auto* windows = static_cast<StationWindows*>(self);
  if (event != cv::EVENT_LBUTTONDOWN || !windows->polling_state_) return;
  if (const auto action = HitTestPanel(x, y)) {
    ApplyPanelAction(*action, *windows->polling_model_, windows->polling_state_);
    ++windows->applied_;
  }
}

}  // namespace ves::ui
