#include "station/haptics/hand_profile.h"

#include <cmath>
#include <numbers>

namespace ves::haptics {

double CalcProfileValue(const HandAxisProfile& profile, double t_s) {
  const double tau = std::max(0.0, t_s - profile.start_s);
  const double omega = 2.0 * std::numbers::pi * profile.frequency_Hz;
  return profile.offset + profile.amplitude * std::sin(omega * tau) + profile.rate_per_s * tau;
}

double CalcProfileRate(const HandAxisProfile& profile, double t_s) {
  if (t_s < profile.start_s) return 0.0;
  const double tau = t_s - profile.start_s;
  const double omega = 2.0 * std::numbers::pi * profile.frequency_Hz;
  return profile.amplitude * omega * std::cos(omega * tau) + profile.rate_per_s;
}

HandAxisProfile RollLikeThrust(const HandAxisProfile& thrust, double scope_radius_m) {
  HandAxisProfile roll = thrust;
  roll.offset /= scope_radius_m;
  roll.amplitude /= scope_radius_m;
  roll.rate_per_s /= scope_radius_m;
  return roll;
}

}  // namespace ves::haptics
