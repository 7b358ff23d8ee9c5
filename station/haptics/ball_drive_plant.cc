#include "station/haptics/ball_drive_plant.h"

#include <algorithm>
#include <cmath>

namespace ves::haptics {
namespace {

constexpr double kCoulombVelocityScale_m_per_s = 1e-3;

double DeadZone(double value, double half_width) {
  if (value > half_width) return value - half_width;
  if (value < -half_width) return value + half_width;
  return 0.0;
}

double AxisHandLoad(const HandAxisProfile& profile, double stiffness, double damping,
                    double position, double velocity, double t_s) {
  if (profile.drive == HandDrive::kForce) return CalcProfileValue(profile, t_s);
  return stiffness * (CalcProfileValue(profile, t_s) - position) +
         damping * (CalcProfileRate(profile, t_s) - velocity);
}

}  // namespace

void CalcHandLoad(const HandProfile& hand, const PlantState& state, double t_s, double* force_N,
                  double* torque_Nm) {
  *force_N = AxisHandLoad(hand.thrust, hand.thrust_stiffness_N_per_m, hand.thrust_damping_N_s_per_m,
                          state.insertion_m, state.insertion_velocity_m_per_s, t_s);
  if (hand.thrust.drive == HandDrive::kPosition) {
    *force_N = std::clamp(*force_N, -hand.thrust_force_limit_N, hand.thrust_force_limit_N);
  }
  *torque_Nm =
      AxisHandLoad(hand.roll, hand.roll_stiffness_Nm_per_rad, hand.roll_damping_Nm_s_per_rad,
                   state.roll_scope_rad, state.roll_scope_velocity_rad_per_s, t_s);
}

void StepBallDrive(const BallDriveParams& params, const HandProfile& hand,
                   const MotorVoltages& voltages, double dt_s, int substeps, PlantState* state) {
  PlantState& s = *state;
  const double h = dt_s / substeps;
  const double half_play = 0.5 * params.roll_backlash_rad;
  for (int i = 0; i < substeps; ++i) {
    CalcHandLoad(hand, s, s.t_s, &s.hand_force_N, &s.hand_torque_Nm);
    // Thrust.
    const double motor_force_N =
        CalcThrustMotorForce(params, voltages.thrust_V, s.insertion_velocity_m_per_s);
    const double friction_N = params.thrust_damping_N_s_per_m * s.insertion_velocity_m_per_s +
                              params.thrust_coulomb_N * std::tanh(s.insertion_velocity_m_per_s /
                                                                  kCoulombVelocityScale_m_per_s);
    const double accel = (s.hand_force_N + motor_force_N - friction_N) / params.thrust_mass_kg;
    s.insertion_velocity_m_per_s += h * accel;
    s.insertion_m += h * s.insertion_velocity_m_per_s;
    // Roll, across the backlash gap.
    const double twist_rad = DeadZone(s.roll_motor_rad - s.roll_scope_rad, half_play);
    const double gear_torque_Nm =
        twist_rad == 0.0
            ? 0.0
            : params.roll_gear_stiffness_Nm_per_rad * twist_rad +
                  params.roll_gear_damping_Nm_s_per_rad *
                      (s.roll_motor_velocity_rad_per_s - s.roll_scope_velocity_rad_per_s);
    const double motor_torque_Nm =
        CalcRollMotorTorque(params, voltages.roll_V, s.roll_motor_velocity_rad_per_s);
    const double motor_accel =
        (motor_torque_Nm - gear_torque_Nm -
         params.roll_motor_damping_Nm_s_per_rad * s.roll_motor_velocity_rad_per_s) /
        params.roll_motor_inertia_kg_m2;
    const double scope_accel =
        (s.hand_torque_Nm + gear_torque_Nm -
         params.roll_scope_damping_Nm_s_per_rad * s.roll_scope_velocity_rad_per_s) /
        params.roll_scope_inertia_kg_m2;
    s.roll_motor_velocity_rad_per_s += h * motor_accel;
    s.roll_scope_velocity_rad_per_s += h * scope_accel;
    s.roll_motor_rad += h * s.roll_motor_velocity_rad_per_s;
    s.roll_scope_rad += h * s.roll_scope_velocity_rad_per_s;
    s.t_s += h;
  }
  CalcHandLoad(hand, s, s.t_s, &s.hand_force_N, &s.hand_torque_Nm);
}

}  // namespace ves::haptics
