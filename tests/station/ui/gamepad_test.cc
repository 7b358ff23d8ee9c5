// A USB game controller through evdev (ui/gamepad.h), tested with recorded
// events: an Xbox-style pad's reports as the kernel delivers them. With
// /dev/uinput (a kernel with CONFIG_INPUT_UINPUT, writable) a virtual pad is
// also created and read through EvdevGamepad; without it that test is skipped
// and says so.
#include "station/ui/gamepad.h"

#include <fcntl.h>
#include <linux/uinput.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "station/haptics/ball_drive_plant.h"
#include "station/haptics/keyboard_push.h"

namespace ves::ui {
namespace {

input_event Event(int type, int code, int value) {
  input_event e{};
  e.type = static_cast<__u16>(type);
  e.code = static_cast<__u16>(code);
  e.value = value;
  return e;
}
input_event Report() { return Event(EV_SYN, SYN_REPORT, 0); }

// An Xbox 360 pad (xpad): sticks -32768..32767 with a flat of 128, triggers 0..255.
GamepadDecoder XboxPad() {
  GamepadDecoder decoder;
  for (int code : {ABS_X, ABS_Y, ABS_RX, ABS_RY}) decoder.SetRange(code, {-32768, 32767, 128});
  for (int code : {ABS_Z, ABS_RZ}) decoder.SetRange(code, {0, 255, 0});
  return decoder;
}

TEST(Gamepad, RecordedReportsBecomeAxes) {
  GamepadDecoder pad = XboxPad();
  EXPECT_EQ(pad.axes(), GamepadAxes{});  // at rest
  // The right trigger half in, the left stick hard right, the right stick up:
  // nothing counts until the report is complete.
  EXPECT_FALSE(pad.Feed(Event(EV_ABS, ABS_RZ, 128)));
  EXPECT_FALSE(pad.Feed(Event(EV_ABS, ABS_X, 32767)));
  EXPECT_FALSE(pad.Feed(Event(EV_ABS, ABS_RY, -32768)));
  EXPECT_EQ(pad.axes().push, 0.0);
  EXPECT_TRUE(pad.Feed(Report()));
  EXPECT_NEAR(pad.axes().push, 128.0 / 255.0, 1e-12);
  EXPECT_EQ(pad.axes().pull, 0.0);
  EXPECT_NEAR(pad.axes().roll, 1.0, 1e-12);
  EXPECT_NEAR(pad.axes().knob_up, 1.0, 1e-4);  // up is negative in evdev
  EXPECT_EQ(pad.axes().knob_right, 0.0);
  // A stick resting a little off centre, inside its flat zone, is at rest.
  pad.Feed(Event(EV_ABS, ABS_X, 100));
  pad.Feed(Event(EV_ABS, ABS_RY, -90));
  pad.Feed(Report());
  EXPECT_EQ(pad.axes().roll, 0.0);
  EXPECT_EQ(pad.axes().knob_up, 0.0);
  // The left trigger pulls; a repeated identical report changes nothing.
  pad.Feed(Event(EV_ABS, ABS_Z, 255));
  EXPECT_TRUE(pad.Feed(Report()));
  EXPECT_EQ(pad.axes().pull, 1.0);
  EXPECT_FALSE(pad.Feed(Report()));
}

// The kernel's buffer overflowed (SYN_DROPPED): the events up to the next
// report are not trusted; the report after that is.
TEST(Gamepad, EventsAfterAnOverflowWaitForTheNextReport) {
  GamepadDecoder pad = XboxPad();
  pad.Feed(Event(EV_SYN, SYN_DROPPED, 0));
  pad.Feed(Event(EV_ABS, ABS_RZ, 255));
  EXPECT_FALSE(pad.Feed(Report()));
  EXPECT_EQ(pad.axes().push, 0.0);
  pad.Feed(Event(EV_ABS, ABS_RZ, 255));
  EXPECT_TRUE(pad.Feed(Report()));
  EXPECT_EQ(pad.axes().push, 1.0);
}

TEST(Gamepad, ARangeThatIsNoRangeIsRefusedByName) {
  GamepadDecoder pad;
  try {
    pad.SetRange(ABS_RZ, {255, 0, 0});
    FAIL() << "accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("ABS_RZ"), std::string::npos) << error.what();
  }
}

// The trigger held fully in for 20 s at the screen's 60 frames a second,
// against a scope the colon blocks: the target runs ahead, but the hand is
// the keyboard's (haptics::KeyboardPush) and never commands more than its
// steady 10 N; the knobs stop at their limit.
TEST(Gamepad, HoldingTheTriggerFor20sNeverCommandsMoreThanTheHandsLimit) {
  const GamepadAxes held{.push = 1.0, .knob_up = 1.0};
  ControlState controls;
  const KeyboardHand limits;
  haptics::KeyboardPush hand(haptics::KeyboardPushCurve{}, 0.001);
  const double scope_m = 0.4;
  controls.hand_insertion_m = scope_m;
  double peak_N = 0.0;
  for (int frame = 0; frame < 20 * 60; ++frame) {
    ApplyGamepad(held, 1.0 / 60.0, GamepadRates{}, limits, &controls);
    for (int step = 0; step < 16; ++step) {
      const haptics::HandProfile profile = hand.Next(controls.hand_insertion_m, 0.0, scope_m);
      haptics::PlantState plant;
      plant.insertion_m = scope_m;
      double force_N = 0.0;
      double torque_Nm = 0.0;
      haptics::CalcHandLoad(profile, plant, 0.0, &force_N, &torque_Nm);
      ASSERT_LE(force_N, hand.curve().steady_N + 1e-9) << "frame " << frame;
      peak_N = std::max(peak_N, force_N);
    }
  }
  EXPECT_NEAR(peak_N, hand.curve().steady_N, 1e-6);
  EXPECT_EQ(controls.hand_insertion_m, limits.max_insertion_m);
  EXPECT_EQ(controls.knob_up_rad, limits.max_knob_rad);
  // A stalled screen (2 s between frames) moves the target by 0.1 s's worth.
  ControlState stalled;
  ApplyGamepad(GamepadAxes{.push = 1.0}, 2.0, GamepadRates{}, limits, &stalled);
  EXPECT_NEAR(stalled.hand_insertion_m, 0.015, 1e-12);
}

TEST(Gamepad, APathThatIsNoControllerIsRefusedWithTheReason) {
  try {
    EvdevGamepad missing("/nonexistent/event7");
    FAIL() << "opened";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/event7"), std::string::npos);
  }
  const std::filesystem::path file = std::filesystem::temp_directory_path() / "ves-gamepad-not";
  std::ofstream(file) << "not a device";
  try {
    EvdevGamepad not_a_pad(file.string());
    FAIL() << "opened";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("not a game controller"), std::string::npos)
        << error.what();
  }
  std::filesystem::remove(file);
}

// A virtual pad through the kernel (uinput): EvdevGamepad reads its ranges
// and its reports as it would a USB one.
TEST(Gamepad, AVirtualPadThroughTheKernelIsRead) {
  const int fd = ::open("/dev/uinput", O_WRONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    GTEST_SKIP() << "/dev/uinput cannot be opened (" << std::strerror(errno)
                 << "): this kernel or container has no uinput; the recorded-event tests above "
                    "cover the decoding";
  }
  ASSERT_EQ(::ioctl(fd, UI_SET_EVBIT, EV_ABS), 0);
  ASSERT_EQ(::ioctl(fd, UI_SET_EVBIT, EV_SYN), 0);
  for (int code : {ABS_X, ABS_Y, ABS_RX, ABS_RY, ABS_Z, ABS_RZ}) {
    ASSERT_EQ(::ioctl(fd, UI_SET_ABSBIT, code), 0);
    uinput_abs_setup abs{};
    abs.code = static_cast<__u16>(code);
    const bool trigger = code == ABS_Z || code == ABS_RZ;
    abs.absinfo.minimum = trigger ? 0 : -32768;
    abs.absinfo.maximum = trigger ? 255 : 32767;
    abs.absinfo.flat = trigger ? 0 : 128;
    ASSERT_EQ(::ioctl(fd, UI_ABS_SETUP, &abs), 0);
  }
  uinput_setup setup{};
  setup.id.bustype = BUS_VIRTUAL;
  std::strncpy(setup.name, "ves virtual pad", UINPUT_MAX_NAME_SIZE - 1);
  ASSERT_EQ(::ioctl(fd, UI_DEV_SETUP, &setup), 0);
  ASSERT_EQ(::ioctl(fd, UI_DEV_CREATE), 0);
  char sysname[64] = {};
  ASSERT_GE(::ioctl(fd, UI_GET_SYSNAME(sizeof(sysname)), sysname), 0);
  std::string event_path;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string("/sys/devices/virtual/input/") + sysname)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("event", 0) == 0) event_path = "/dev/input/" + name;
  }
  ASSERT_FALSE(event_path.empty());
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // udev makes the node
  {
    EvdevGamepad pad(event_path);
    const input_event report[] = {Event(EV_ABS, ABS_RZ, 255), Event(EV_ABS, ABS_X, -32768),
                                  Report()};
    ASSERT_EQ(::write(fd, report, sizeof(report)), static_cast<ssize_t>(sizeof(report)));
    bool changed = false;
    for (int i = 0; i < 50 && !changed; ++i) {
      changed = pad.Poll();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    EXPECT_TRUE(changed);
    EXPECT_EQ(pad.axes().push, 1.0);
    EXPECT_NEAR(pad.axes().roll, -1.0, 1e-12);
  }
  ::ioctl(fd, UI_DEV_DESTROY);
  ::close(fd);
}

}  // namespace
}  // namespace ves::ui
