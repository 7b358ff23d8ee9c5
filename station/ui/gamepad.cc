#include "station/ui/gamepad.h"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <iostream>
#include <stdexcept>

namespace ves::ui {
namespace {

std::string AxisName(int code) {
  switch (code) {
    case ABS_X: return "ABS_X";
    case ABS_Y: return "ABS_Y";
    case ABS_Z: return "ABS_Z";
    case ABS_RX: return "ABS_RX";
    case ABS_RY: return "ABS_RY";
    case ABS_RZ: return "ABS_RZ";
    case ABS_GAS: return "ABS_GAS";
    case ABS_BRAKE: return "ABS_BRAKE";
    default: return "axis " + std::to_string(code);
  }
}

constexpr double kMaxStep_s = 0.1;

}  // namespace

GamepadDecoder::GamepadDecoder() {
  ranges_.fill(AxisRange{});
  // Sticks at rest: the middle of the default range.
  for (int code : {ABS_X, ABS_Y, ABS_RX, ABS_RY}) values_[code] = 128;
}

void GamepadDecoder::SetRange(int code, AxisRange range) {
  if (code < 0 || code >= ABS_CNT) {
    throw std::invalid_argument("game controller: no such axis code " + std::to_string(code));
  }
  if (range.maximum <= range.minimum) {
    throw std::invalid_argument("game controller: " + AxisName(code) + " has the range " +
                                std::to_string(range.minimum) + ".." +
                                std::to_string(range.maximum) + " (maximum not above minimum)");
  }
  range.flat = std::clamp(range.flat, 0, range.maximum - range.minimum);
  ranges_[code] = range;
  values_[code] = code == ABS_X || code == ABS_Y || code == ABS_RX || code == ABS_RY
                      ? range.minimum + (range.maximum - range.minimum) / 2
                      : range.minimum;
}

double GamepadDecoder::Scaled(int code, bool trigger) const {
  const AxisRange& r = ranges_[code];
  const double span = r.maximum - r.minimum;
  const int value = std::clamp(values_[code], r.minimum, r.maximum);
  if (trigger) {
    const double pressed = value - r.minimum;
    return pressed <= r.flat ? 0.0 : (pressed - r.flat) / (span - r.flat);
  }
  const double centre = r.minimum + 0.5 * span;
  const double off = value - centre;
  const double half = 0.5 * span;
  const double flat = std::min<double>(r.flat, half * 0.9);
  if (std::abs(off) <= flat) return 0.0;
  return std::clamp((off - std::copysign(flat, off)) / (half - flat), -1.0, 1.0);
}

bool GamepadDecoder::Feed(const input_event& event) {
  if (event.type == EV_SYN) {
    if (event.code == SYN_DROPPED) {
      dropped_ = true;
      return false;
    }
    if (event.code != SYN_REPORT) return false;
    if (dropped_) {  // the report after an overflow completes nothing trustworthy
      dropped_ = false;
      return false;
    }
    GamepadAxes axes;
    axes.push = std::max(Scaled(ABS_RZ, true), Scaled(ABS_GAS, true));
    axes.pull = std::max(Scaled(ABS_Z, true), Scaled(ABS_BRAKE, true));
    axes.roll = Scaled(ABS_X, false);
    axes.knob_right = Scaled(ABS_RX, false);
    axes.knob_up = -Scaled(ABS_RY, false);
    const bool changed = !(axes == axes_);
    axes_ = axes;
    return changed;
  }
  if (event.type == EV_ABS && !dropped_ && event.code < ABS_CNT) values_[event.code] = event.value;
  return false;
}

void ApplyGamepad(const GamepadAxes& axes, double dt_s, const GamepadRates& rates,
                  const KeyboardHand& hand, ControlState* state) {
  const double dt = std::clamp(dt_s, 0.0, kMaxStep_s);
  state->hand_insertion_m =
      std::clamp(state->hand_insertion_m + (axes.push - axes.pull) * rates.insertion_m_per_s * dt,
                 0.0, hand.max_insertion_m);
  state->hand_roll_rad += axes.roll * rates.roll_rad_per_s * dt;
  state->knob_up_rad = std::clamp(state->knob_up_rad + axes.knob_up * rates.knob_rad_per_s * dt,
                                  -hand.max_knob_rad, hand.max_knob_rad);
  state->knob_right_rad =
      std::clamp(state->knob_right_rad + axes.knob_right * rates.knob_rad_per_s * dt,
                 -hand.max_knob_rad, hand.max_knob_rad);
}

EvdevGamepad::EvdevGamepad(const std::string& path) : path_(path) {
  fd_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    const int error = errno;
    throw std::runtime_error(
        "cannot open the game controller " + path + ": " + std::strerror(error) +
        (error == EACCES ? " (add the station's user to the 'input' group)" : ""));
  }
  char name[128] = {};
  if (::ioctl(fd_, EVIOCGNAME(sizeof(name) - 1), name) >= 0) name_ = name;
  bool has_stick = false;
  for (int code : {ABS_X, ABS_Y, ABS_Z, ABS_RX, ABS_RY, ABS_RZ, ABS_GAS, ABS_BRAKE}) {
    input_absinfo info{};
    if (::ioctl(fd_, EVIOCGABS(code), &info) < 0 || info.maximum <= info.minimum) continue;
    decoder_.SetRange(code, AxisRange{info.minimum, info.maximum, info.flat});
    if (code == ABS_X) has_stick = true;
  }
  if (!has_stick) {
    ::close(fd_);
    throw std::runtime_error(path + " ('" + name_ +
                             "') is not a game controller: it has no analogue stick (ABS_X)");
  }
}

EvdevGamepad::~EvdevGamepad() {
  if (fd_ >= 0) ::close(fd_);
}

bool EvdevGamepad::Poll() {
  if (fd_ < 0) return false;
  bool changed = false;
  input_event events[64];
  for (;;) {
    const ssize_t got = ::read(fd_, events, sizeof(events));
    if (got < 0 && (errno == EAGAIN || errno == EINTR)) break;
    if (got <= 0) {  // ENODEV: unplugged
      std::cerr << "ves-station: the game controller " << path_ << " is gone; its axes are at rest\n";
      ::close(fd_);
      fd_ = -1;
      decoder_ = GamepadDecoder();
      return true;
    }
    const auto count = static_cast<std::size_t>(got) / sizeof(input_event);
    for (std::size_t i = 0; i < count; ++i) changed |= decoder_.Feed(events[i]);
  }
  return changed;
}

}  // namespace ves::ui
