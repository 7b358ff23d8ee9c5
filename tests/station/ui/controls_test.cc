#include "station/ui/controls.h"

#include <gtest/gtest.h>

namespace ves::ui {
namespace {

constexpr double kTolerance = 1e-12;

TEST(ApplyKey, InsertAndWithdrawMoveTheHandByOneStepWithinLimits) {
  ControlState state;
  const KeyboardHand hand;
  EXPECT_TRUE(ApplyKey('w', hand, &state));
  EXPECT_NEAR(state.hand_insertion_m, hand.insertion_step_m, kTolerance);
  EXPECT_TRUE(ApplyKey('s', hand, &state));
  EXPECT_TRUE(ApplyKey('s', hand, &state));
  EXPECT_NEAR(state.hand_insertion_m, 0.0, kTolerance);  // never pulled out past the anus
  state.hand_insertion_m = hand.max_insertion_m;
  ApplyKey('w', hand, &state);
  EXPECT_NEAR(state.hand_insertion_m, hand.max_insertion_m, kTolerance);
}

TEST(ApplyKey, ArrowKeysOfQtAndGtkMatchLetters) {
  const KeyboardHand hand;
  for (const int up : {0x1000013, 0xff52}) {
    ControlState state;
    ApplyKey(up, hand, &state);
    EXPECT_NEAR(state.hand_insertion_m, hand.insertion_step_m, kTolerance);
  }
  for (const int right : {0x1000014, 0xff53}) {
    ControlState state;
    ApplyKey(right, hand, &state);
    EXPECT_NEAR(state.hand_roll_rad, hand.roll_step_rad, kTolerance);
  }
}

TEST(ApplyKey, KnobsMoveAndClampAndCenter) {
  ControlState state;
  KeyboardHand hand;
  hand.max_knob_rad = 0.1;
  ApplyKey('i', hand, &state);
  ApplyKey('i', hand, &state);
  EXPECT_NEAR(state.knob_up_rad, 0.1, kTolerance);
  ApplyKey('j', hand, &state);
  EXPECT_NEAR(state.knob_right_rad, -hand.knob_step_rad, kTolerance);
  ApplyKey('c', hand, &state);
  EXPECT_EQ(state.knob_up_rad, 0.0);
  EXPECT_EQ(state.knob_right_rad, 0.0);
}

TEST(ApplyKey, ViewModeFluoroscopyDamageRepeatAndQuit) {
  ControlState state;
  const KeyboardHand hand;
  ApplyKey('1', hand, &state);
  EXPECT_EQ(state.view_mode, ViewMode::kWireframe);
  ApplyKey('v', hand, &state);
  EXPECT_EQ(state.view_mode, ViewMode::kFlat);
  ApplyKey('v', hand, &state);
  ApplyKey('v', hand, &state);
  EXPECT_EQ(state.view_mode, ViewMode::kWireframe);  // cycles
  ApplyKey('f', hand, &state);
  EXPECT_TRUE(state.fluoroscopy_visible);
  ApplyKey('f', hand, &state);
  EXPECT_FALSE(state.fluoroscopy_visible);
  ApplyKey('g', hand, &state);
  EXPECT_TRUE(state.damage_display);
  ApplyKey('r', hand, &state);
  EXPECT_TRUE(state.repeat_requested);
  ApplyKey(27, hand, &state);
  EXPECT_TRUE(state.quit_requested);
}

TEST(ApplyKey, PCyclesTheAssistantsPressAndTTurnsThePatient) {
  ControlState state;
  const KeyboardHand hand;
  EXPECT_EQ(state.abdominal_press, AbdominalPress::kNone);
  EXPECT_EQ(state.patient_position, PatientPosition::kSupine);
  EXPECT_TRUE(ApplyKey('p', hand, &state));
  EXPECT_EQ(state.abdominal_press, AbdominalPress::kLeftLowerQuadrant);
  ApplyKey('p', hand, &state);
  EXPECT_EQ(state.abdominal_press, AbdominalPress::kMidAbdomen);
  ApplyKey('p', hand, &state);
  EXPECT_EQ(state.abdominal_press, AbdominalPress::kNone);  // the hand comes off
  EXPECT_EQ(state.patient_position, PatientPosition::kSupine);
  EXPECT_TRUE(ApplyKey('t', hand, &state));
  EXPECT_EQ(state.patient_position, PatientPosition::kLeftLateral);
  ApplyKey('t', hand, &state);
  EXPECT_EQ(state.patient_position, PatientPosition::kRightLateral);
  ApplyKey('t', hand, &state);
  EXPECT_EQ(state.patient_position, PatientPosition::kSupine);
  EXPECT_EQ(state.abdominal_press, AbdominalPress::kNone);
  // Nothing else moves: the hand, the knobs and the views stay.
  ControlState expected;
  ApplyKey('p', hand, &state);
  ApplyKey('t', hand, &state);
  expected.abdominal_press = AbdominalPress::kLeftLowerQuadrant;
  expected.patient_position = PatientPosition::kLeftLateral;
  EXPECT_EQ(state, expected);
  EXPECT_STREQ(PressName(state.abdominal_press), "left lower quadrant");
  EXPECT_STREQ(PositionName(state.patient_position), "left lateral");
}

TEST(ApplyKey, UnknownKeyChangesNothing) {
  ControlState state;
  EXPECT_FALSE(ApplyKey('z', KeyboardHand{}, &state));
  EXPECT_EQ(state, ControlState{});
}

TEST(FluoroDrag, DragRotatesByPixelsAndReleaseEndsTheDrag) {
  ControlState state;
  DragTracker drag;
  ApplyFluoroDrag(100, 100, true, &drag, &state);  // press: no motion yet
  EXPECT_EQ(state.fluoro_yaw_rad, 0.0);
  ApplyFluoroDrag(150, 80, true, &drag, &state);
  EXPECT_NEAR(state.fluoro_yaw_rad, 50 * kFluoroRadiansPerPixel, kTolerance);
  EXPECT_NEAR(state.fluoro_pitch_rad, -20 * kFluoroRadiansPerPixel, kTolerance);
  ApplyFluoroDrag(150, 80, false, &drag, &state);
  ApplyFluoroDrag(400, 80, true, &drag, &state);  // a new press does not jump
  EXPECT_NEAR(state.fluoro_yaw_rad, 50 * kFluoroRadiansPerPixel, kTolerance);
}

TEST(FluoroWheel, ZoomsGeometricallyWithinLimits) {
  ControlState state;
  ApplyFluoroWheel(2, &state);
  EXPECT_NEAR(state.fluoro_zoom, kFluoroZoomPerWheelStep * kFluoroZoomPerWheelStep, 1e-9);
  ApplyFluoroWheel(-1000, &state);
  EXPECT_EQ(state.fluoro_zoom, kFluoroMinZoom);
}

TEST(KeyHelpText, NamesEveryBoundKey) {
  const std::string help = KeyHelpText();
  for (const char* word : {"insert", "withdraw", "roll", "knob", "view mode", "fluoroscopy",
                           "damage", "repeat", "next case", "scope", "abdominal press",
                           "left lower quadrant", "mid-abdomen", "patient position"}) {
    EXPECT_NE(help.find(word), std::string::npos) << word;
  }
}

// Issue #48: the X-ray and the C-arm carried over to a repeated session,
// which counted X-ray time before a key was touched.
TEST(StartClean, TheXrayGoesOffAndTheCarmHomeTheRestStays) {
  ControlState state;
  state.view_mode = ViewMode::kWireframe;
  state.fluoroscopy_visible = true;
  state.damage_display = true;
  state.fluoro_yaw_rad = 0.7;
  state.fluoro_pitch_rad = -0.2;
  state.fluoro_zoom = 3.0;
  state.hand_insertion_m = 0.9;
  state.hand_roll_rad = 0.4;
  state.knob_up_rad = 0.5;
  state.case_choice = 2;
  ControlState expected = state;
  expected.fluoroscopy_visible = false;
  expected.fluoro_yaw_rad = 0.0;
  expected.fluoro_pitch_rad = 0.0;
  expected.fluoro_zoom = 1.0;
  StartClean(&state);
  EXPECT_EQ(state, expected);
}

}  // namespace
}  // namespace ves::ui
