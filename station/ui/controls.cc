#include "station/ui/controls.h"

#include <algorithm>
#include <cmath>

namespace ves::ui {
namespace {

// cv::waitKeyEx codes of the arrow keys under the Qt and GTK backends.
constexpr int kQtUp = 0x1000013, kQtDown = 0x1000015, kQtLeft = 0x1000012, kQtRight = 0x1000014;
constexpr int kGtkUp = 0xff52, kGtkDown = 0xff54, kGtkLeft = 0xff51, kGtkRight = 0xff53;
constexpr int kEscape = 27;
constexpr double kHalfPi = 1.5707963267948966;

double Clamp(double value, double limit) { return std::clamp(value, -limit, limit); }

}  // namespace

bool ApplyKey(int key, const KeyboardHand& hand, ControlState* state) {
  switch (key) {
    case 'w': case kQtUp: case kGtkUp:
      state->hand_insertion_m =
          std::min(state->hand_insertion_m + hand.insertion_step_m, hand.max_insertion_m);
      return true;
    case 's': case kQtDown: case kGtkDown:
      state->hand_insertion_m = std::max(state->hand_insertion_m - hand.insertion_step_m, 0.0);
      return true;
    case 'a': case kQtLeft: case kGtkLeft:
      state->hand_roll_rad -= hand.roll_step_rad;
      return true;
    case 'd': case kQtRight: case kGtkRight:
      state->hand_roll_rad += hand.roll_step_rad;
      return true;
    case 'i':
      state->knob_up_rad = Clamp(state->knob_up_rad + hand.knob_step_rad, hand.max_knob_rad);
      return true;
    case 'k':
      state->knob_up_rad = Clamp(state->knob_up_rad - hand.knob_step_rad, hand.max_knob_rad);
      return true;
    case 'j':
      state->knob_right_rad =
          Clamp(state->knob_right_rad - hand.knob_step_rad, hand.max_knob_rad);
      return true;
    case 'l':
      state->knob_right_rad =
          Clamp(state->knob_right_rad + hand.knob_step_rad, hand.max_knob_rad);
      return true;
    case 'c':
      state->knob_up_rad = 0.0;
      state->knob_right_rad = 0.0;
      return true;
    case '1': state->view_mode = ViewMode::kWireframe; return true;
    case '2': state->view_mode = ViewMode::kFlat; return true;
    case '3': state->view_mode = ViewMode::kTextured; return true;
    case 'v':
      state->view_mode = static_cast<ViewMode>((static_cast<int>(state->view_mode) + 1) % 3);
      return true;
    case 'f': state->fluoroscopy_visible = !state->fluoroscopy_visible; return true;
    case 'p':  // the assistant's hand: off, left lower quadrant, mid-abdomen, off
      state->abdominal_press =
          static_cast<AbdominalPress>((static_cast<int>(state->abdominal_press) + 1) % 3);
      return true;
    case 't':  // turn the patient: supine, left lateral, right lateral, supine
      state->patient_position =
          static_cast<PatientPosition>((static_cast<int>(state->patient_position) + 1) % 3);
      return true;
    case 'g': state->damage_display = !state->damage_display; return true;
    case 'r': state->repeat_requested = true; return true;
    case '+': case '=': ApplyFluoroWheel(1, state); return true;
    case '-': ApplyFluoroWheel(-1, state); return true;
    case 'q': case kEscape: state->quit_requested = true; return true;
    default:
      return false;
  }
}

std::string KeyHelpText() {
  return "w / Up      insert 5 mm          s / Down    withdraw 5 mm\n"
         "a / Left    roll -5 deg          d / Right   roll +5 deg\n"
         "i / k       knob up / down       j / l       knob left / right\n"
         "c           knobs to neutral     v, 1 2 3    view mode: wire, polygon, texture\n"
         "f           fluoroscopy on/off   g           damage display on/off\n"
         "+ / -       fluoroscopy zoom     drag        rotate fluoroscopy (wheel: zoom)\n"
         "p           abdominal press      t           patient position\n"
         "            (off, left lower quadrant, mid-abdomen; supine, left, right lateral)\n"
         "n / m       next case / scope    r           repeat (with the chosen case, scope)\n"
         "q / Esc     finish (abort) the session\n";
}

const char* PressName(AbdominalPress press) {
  switch (press) {
    case AbdominalPress::kLeftLowerQuadrant: return "left lower quadrant";
    case AbdominalPress::kMidAbdomen: return "mid-abdomen";
    case AbdominalPress::kNone: break;
  }
  return "none";
}

const char* PositionName(PatientPosition position) {
  switch (position) {
    case PatientPosition::kLeftLateral: return "left lateral";
    case PatientPosition::kRightLateral: return "right lateral";
    case PatientPosition::kSupine: break;
  }
  return "supine";
}

void ApplyFluoroDrag(int x, int y, bool button_down, DragTracker* drag, ControlState* state) {
  if (!button_down) {
    drag->last.reset();
    return;
  }
  if (drag->last) {
    state->fluoro_yaw_rad += (x - drag->last->first) * kFluoroRadiansPerPixel;
    state->fluoro_pitch_rad = std::clamp(
        state->fluoro_pitch_rad + (y - drag->last->second) * kFluoroRadiansPerPixel, -kHalfPi,
        kHalfPi);
  }
  drag->last = {x, y};
}

void ApplyFluoroWheel(int steps, ControlState* state) {
  state->fluoro_zoom = std::clamp(state->fluoro_zoom * std::pow(kFluoroZoomPerWheelStep, steps),
                                  kFluoroMinZoom, kFluoroMaxZoom);
}

void StartClean(ControlState* state) {
  const ControlState home;
  state->fluoroscopy_visible = home.fluoroscopy_visible;
  state->fluoro_yaw_rad = home.fluoro_yaw_rad;
  state->fluoro_pitch_rad = home.fluoro_pitch_rad;
  state->fluoro_zoom = home.fluoro_zoom;
}

}  // namespace ves::ui
