#pragma once

// The VES-IV mechanics as a plant (paper §2.1), integrated with semi-implicit
// Euler substeps:
//   thrust:  m·ẍ = F_hand + F_motor(V, ẋ) − b·ẋ − F_c·tanh(ẋ/v_c)
//            (motor → gear → ball → scope without slip, no backlash)
//   roll:    J_m·θ̈_m = τ_motor(V, θ̇_m) − τ_gear − b_m·θ̇_m
//            J_s·θ̈_s = τ_hand + τ_gear − b_s·θ̇_s
//            τ_gear = k_g·dz(θ_m − θ_s) + c_g·(θ̇_m − θ̇_s) while engaged,
//            dz = dead zone of half the backlash (paper §2.2 on Fig. 5(b)).
// The encoders sit on the motors (θ_m for roll); the force sensor sits
// between hand and scope and reads F_hand and τ_hand.
#include "station/haptics/ball_drive_params.h"
#include "station/haptics/hand_profile.h"
#include "station/haptics/protocol.h"

namespace ves::haptics {

struct PlantState {
  double t_s{0.0};
  double insertion_m{0.0};
  double insertion_velocity_m_per_s{0.0};
  double roll_motor_rad{0.0};
  double roll_motor_velocity_rad_per_s{0.0};
  double roll_scope_rad{0.0};
  double roll_scope_velocity_rad_per_s{0.0};
  double hand_force_N{0.0};  // what the hand applies to the scope (sensor's truth)
  double hand_torque_Nm{0.0};
  bool operator==(const PlantState&) const = default;
};

// Hand force and torque on the scope for the plant state at time t.
void CalcHandLoad(const HandProfile& hand, const PlantState& state, double t_s, double* force_N,
                  double* torque_Nm);

// Advances `state` by dt_s with the pair voltages held, in `substeps` steps.
void StepBallDrive(const BallDriveParams& params, const HandProfile& hand,
                   const MotorVoltages& voltages, double dt_s, int substeps, PlantState* state);

}  // namespace ves::haptics
