#pragma once

// A scripted hand for the simulated device: each axis is driven either in
// position (the hand, a spring-damper, pulls the scope toward a moving target)
// or in force (the hand pushes with a scripted force), the two ways the
// paper's Fig. 5 and 6 experiments were run by an operator.
#include <limits>

namespace ves::haptics {

enum class HandDrive { kPosition, kForce };

// value(t) = offset + amplitude·sin(2π·f·τ) + rate·τ, τ = t − start_s (0 before start).
// Units: m or rad (position drive), N or N·m (force drive); rate per second.
struct HandAxisProfile {
  HandDrive drive{HandDrive::kPosition};
  double offset{0.0};
  double amplitude{0.0};
  double frequency_Hz{0.0};
  double rate_per_s{0.0};
  double start_s{0.0};
  bool operator==(const HandAxisProfile&) const = default;
};

double CalcProfileValue(const HandAxisProfile& profile, double t_s);
double CalcProfileRate(const HandAxisProfile& profile, double t_s);

struct HandProfile {
  HandAxisProfile thrust{};
  HandAxisProfile roll{};
  // Grip impedance of a position-driven hand (hand-arm stiffness when gripping).
  double thrust_stiffness_N_per_m{2000.0};
  double thrust_damping_N_s_per_m{20.0};
  double roll_stiffness_Nm_per_rad{2.0};
  double roll_damping_Nm_s_per_rad{0.02};
  // The most a position-driven hand pushes or pulls along the scope, N (the
  // keyboard's hand is bounded to what a hand gives: station/app/keyboard_push.h).
  double thrust_force_limit_N{std::numeric_limits<double>::infinity()};
  bool operator==(const HandProfile&) const = default;
};

// The roll profile that moves the scope's surface like the thrust profile moves
// it axially: an arc of `amplitude_m` on a scope of `scope_radius_m`.
HandAxisProfile RollLikeThrust(const HandAxisProfile& thrust, double scope_radius_m);
inline constexpr double kScopeRadius_m = 0.0065;  // a 13 mm colonoscope

}  // namespace ves::haptics
