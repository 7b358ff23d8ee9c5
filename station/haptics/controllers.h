#pragma once

// The control modes of paper §2.2 as pure functions of (device state,
// parameters, controller state) -> motor command.
//  free:    "the reaction force on the endoscope was always 0": an admittance
//           target m_v·ẍ_t = F_hand − b_v·ẋ_t with small virtual inertia and
//           damping, tracked through the encoder with feed-forward of the
//           plant's inertia and friction and of the measured hand force.
//  spring:  "the force read from the force sensor was used to compute the
//           theoretical position using a linear spring model; the motor
//           output was determined from the difference between that
//           theoretical position and the present position sensed by an
//           encoder": x_t = x_0 + F_hand/k, u = −F_hand + K_p(x_t − x) − K_d·ẋ,
//           with K_p = spring_gain_ratio·k (the force loop's gain K_p/k stays
//           the same for every spring) and K_d = K_p·spring_damping_time_s.
//  coupled: free with the model's base response added to the admittance:
//           m_v·ẍ_t = F_hand + F_base − b_v·ẋ_t, with b_v raised to the
//           coupled_* damping: a stiff model response (a wall) rendered one
//           period late through a 30 g virtual mass rings and climbs without it.
// The same laws run on roll with torques and angles.
#include "station/haptics/base_response.h"
#include "station/haptics/device.h"

namespace ves::haptics {

enum class ControlMode { kFree, kSpring, kCoupled };

// One axis; units are N, m (thrust) or N·m, rad (roll).
struct AxisControlParams {
  double position_gain{0.0};       // K_p, N/m or N·m/rad
  double velocity_gain{0.0};       // K_d, N·s/m or N·m·s/rad
  double plant_inertia{0.0};       // feed-forward estimate, kg or kg·m²
  double plant_damping{0.0};       // feed-forward estimate, N·s/m or N·m·s/rad
  double virtual_inertia{0.0};     // m_v of the admittance
  double virtual_damping{0.0};     // b_v of the admittance
  double max_tracking_error{0.0};  // anti-windup: |x_t − x| never exceeds this
  bool operator==(const AxisControlParams&) const = default;
};

struct ControlParams {
  ControlMode mode{ControlMode::kFree};
  AxisControlParams thrust{4000.0, 40.0, 0.3, 1.0, 0.03, 0.3, 0.005};
  AxisControlParams roll{2.0, 0.01, 9e-5, 0.003, 2e-5, 2e-4, 0.05};
  double spring_stiffness_N_per_m{100.0};
  double spring_stiffness_Nm_per_rad{0.05};
  double spring_rest_insertion_m{0.0};
  double spring_rest_roll_rad{0.0};
  double coupled_virtual_damping_N_s_per_m{3.0};
  double coupled_virtual_damping_Nm_s_per_rad{2e-3};
  double spring_gain_ratio{10.0};
  double spring_damping_time_s{0.01};
  bool operator==(const ControlParams&) const = default;
};

// Admittance target per axis (the controller's only state).
struct AxisTarget {
  double position{0.0};
  double velocity{0.0};
  bool operator==(const AxisTarget&) const = default;
};
struct ControllerState {
  AxisTarget thrust{};
  AxisTarget roll{};
  bool operator==(const ControllerState&) const = default;
};

// Puts the targets on the measured state (on arming and on mode changes).
ControllerState CalcInitialControllerState(const DeviceState& device);

MotorCommand CalcFreeCommand(const DeviceState& device, const ControlParams& params, double dt_s,
                             ControllerState* state);
MotorCommand CalcSpringCommand(const DeviceState& device, const ControlParams& params);
MotorCommand CalcCoupledCommand(const DeviceState& device, const BaseResponse& base,
                                const ControlParams& params, double dt_s, ControllerState* state);

// One admittance-tracking step for one axis; exposed for tests.
double CalcAdmittanceAxis(double position, double velocity, double hand_load, double external_load,
                          const AxisControlParams& params, double dt_s, AxisTarget* target);

}  // namespace ves::haptics
