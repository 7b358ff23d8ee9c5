#include "station/haptics/keyboard_push.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ves::haptics {

KeyboardPush::KeyboardPush(KeyboardPushCurve curve, double period_s)
    : curve_(curve), period_s_(period_s), limit_N_(curve.hold_N) {
  if (!(period_s > 0.0)) throw std::invalid_argument("keyboard push: period must be > 0 s");
  if (!(curve.hold_N > 0.0 && curve.hold_N <= curve.steady_N && curve.ramp_N_per_s > 0.0 &&
        curve.speed_m_per_s > 0.0)) {
    throw std::invalid_argument(
        "keyboard push: the curve needs 0 < hold_N <= steady_N and positive ramp and speed");
  }
}

HandProfile KeyboardPush::Next(double target_m, double roll_rad, double scope_m) {
  HandProfile hand;
  if (!started_) {
    commanded_m_ = scope_m;  // the hand takes the scope where it is
    started_ = true;
  }
  const double stiffness = hand.thrust_stiffness_N_per_m;
  const double max_move_m = curve_.speed_m_per_s * period_s_;
  commanded_m_ += std::clamp(target_m - commanded_m_, -max_move_m, max_move_m);
  // Straining: the spring would pull harder than the bound allows.
  const bool straining = std::abs(commanded_m_ - scope_m) * stiffness >= limit_N_;
  const double ramp_N = curve_.ramp_N_per_s * period_s_;
  limit_N_ = straining ? std::min(curve_.steady_N, limit_N_ + ramp_N)
                       : std::max(curve_.hold_N, limit_N_ - ramp_N);
  // No wind-up: the hand's own position stays within its bound of the scope,
  // so a released key stops the push at once.
  const double lead_m = limit_N_ / stiffness;
  commanded_m_ = std::clamp(commanded_m_, scope_m - lead_m, scope_m + lead_m);
  hand.thrust.drive = HandDrive::kPosition;
  hand.thrust.offset = commanded_m_;
  hand.thrust_force_limit_N = limit_N_;
  hand.roll.drive = HandDrive::kPosition;
  hand.roll.offset = roll_rad;
  return hand;
}

}  // namespace ves::haptics
