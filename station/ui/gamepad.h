#pragma once

// A USB game controller as a cheap input where the haptic device is absent
// (`ves-station run --device sim --gamepad /dev/input/eventN`;
// docs/station-ui.md, "Game controller"), read through Linux evdev: the
// right trigger pushes the scope in, the left trigger pulls it back (both
// analogue: the further pressed, the faster the hand's target moves, at most
// the keyboard hand's 0.15 m/s, and the simulated hand is the keyboard's,
// bounded to what a hand gives), the left stick's x rolls, the right stick
// turns the angulation knobs.
#include <linux/input.h>

#include <array>
#include <optional>
#include <string>

#include "station/ui/controls.h"

namespace ves::ui {

// The controller's state, each axis scaled: triggers 0..1, sticks -1..1
// (right and down positive, as evdev reports them), 0 inside the flat zone.
struct GamepadAxes {
  double push{0.0};        // right trigger (ABS_RZ, or ABS_GAS)
  double pull{0.0};        // left trigger (ABS_Z, or ABS_BRAKE)
  double roll{0.0};        // left stick x (ABS_X)
  double knob_right{0.0};  // right stick x (ABS_RX)
  double knob_up{0.0};     // right stick y (ABS_RY), up is negative in evdev
  bool operator==(const GamepadAxes&) const = default;
};

// One axis's range as the driver reports it (EVIOCGABS).
struct AxisRange {
  int minimum{0};
  int maximum{255};
  int flat{0};
};

// Turns evdev events into GamepadAxes. Values are taken as they come and
// the state is published at each SYN_REPORT; after SYN_DROPPED the events up
// to the next SYN_REPORT are ignored (the kernel's buffer overflowed: the
// state is resynchronised from the next complete report).
class GamepadDecoder {
 public:
  GamepadDecoder();
  // Ranges of the axes by evdev code (ABS_X ...); an axis without one keeps
  // the default 0..255 (sticks centred at 128). A range with
  // maximum <= minimum is refused (std::invalid_argument naming the axis).
  void SetRange(int code, AxisRange range);
  // One event; true when it completed a report (axes() changed to it).
  bool Feed(const input_event& event);
  const GamepadAxes& axes() const { return axes_; }

 private:
  double Scaled(int code, bool trigger) const;

  std::array<AxisRange, ABS_CNT> ranges_;
  std::array<int, ABS_CNT> values_{};
  bool dropped_{false};
  GamepadAxes axes_;
};

// The controller's reach, per second of a fully deflected axis.
struct GamepadRates {
  double insertion_m_per_s{0.15};  // the keyboard hand's speed (haptics::KeyboardPush)
  double roll_rad_per_s{1.5707963267948966};   // 90°/s
  double knob_rad_per_s{1.5707963267948966};   // 90°/s
};

// The axes held for `dt_s`: the hand's insertion target moves by (push -
// pull) · rate · dt within [0, hand.max_insertion_m], the roll and the knobs
// (within ±hand.max_knob_rad) likewise. dt_s is bounded to 0.1 s, so a
// stalled screen does not turn a held trigger into a jump.
void ApplyGamepad(const GamepadAxes& axes, double dt_s, const GamepadRates& rates,
                  const KeyboardHand& hand, ControlState* state);

// The controller's event device, opened non-blocking with its axes' ranges.
class EvdevGamepad {
 public:
  // Throws std::runtime_error naming the path and why (missing, no
  // permission: add the user to the `input` group, not a controller: it has
  // no ABS_X axis).
  explicit EvdevGamepad(const std::string& path);
  ~EvdevGamepad();
  EvdevGamepad(const EvdevGamepad&) = delete;
  EvdevGamepad& operator=(const EvdevGamepad&) = delete;

  // Reads what is pending (never blocks); true when the axes changed. A
  // controller unplugged stops changing them (said once on stderr) and its
  // axes go to rest.
  bool Poll();
  const GamepadAxes& axes() const { return decoder_.axes(); }
  const std::string& name() const { return name_; }

 private:
  int fd_{-1};
  std::string path_;
  std::string name_;
  GamepadDecoder decoder_;
};

}  // namespace ves::ui
