#pragma once

// The keyboard's hand on the simulated device (`--device sim`): the scope is
// pulled toward the keys' insertion target by a hand whose force ramps while
// it strains and is bounded to what a colonoscopist's hand gives
// (docs/station-ui.md, "The keyboard hand").
//
// The curve: the hand holds the scope with at most `hold_N`; while the
// scope lags the target and the hand is at its bound, the bound rises at
// `ramp_N_per_s` to `steady_N`; once the scope has caught up it falls back
// at the same rate. Source: Appleyard et al., Gastrointest Endosc 2000
// (colonoscopists' hand force measured at the insertion tube: over 10 N
// only 5 % of the procedure time, peak about 43 N): the steady push is that
// 95th percentile, 10 N, reached in half a second. A held push key never
// commands more.
#include "station/haptics/hand_profile.h"

namespace ves::haptics {

struct KeyboardPushCurve {
  double hold_N{2.0};          // a relaxed grip on the scope
  double steady_N{10.0};       // the longest push: Appleyard 2000's 95th percentile
  double ramp_N_per_s{16.0};   // hold to steady in 0.5 s
  double speed_m_per_s{0.15};  // how fast the hand follows the keys (a push, not a jump)
};

class KeyboardPush {
 public:
  // Throws std::invalid_argument for a non-positive period or a curve that
  // is not 0 < hold <= steady with positive ramp and speed.
  KeyboardPush(KeyboardPushCurve curve, double period_s);

  // One period: the hand toward `target_m` (device insertion) and
  // `roll_rad`, for the scope now at `scope_m`. The profile's thrust force
  // never exceeds force_limit_N() either way.
  HandProfile Next(double target_m, double roll_rad, double scope_m);

  // The bound of the period last returned, N.
  double force_limit_N() const { return limit_N_; }
  const KeyboardPushCurve& curve() const { return curve_; }

 private:
  KeyboardPushCurve curve_;
  double period_s_;
  double commanded_m_{0.0};
  bool started_{false};
  double limit_N_;
};

}  // namespace ves::haptics
