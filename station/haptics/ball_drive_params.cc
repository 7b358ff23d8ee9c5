#include "station/haptics/ball_drive_params.h"

namespace ves::haptics {
namespace {

// One DC motor pair behind a gear of ratio G with output lever r (r = 1 for
// roll): ω_motor = G·v/r, i = (V − k_e·ω_motor)/R, output = 2·k_t·i·G/r.
double PairOutput(const MotorPairParams& motor, double lever_m, double voltage_V, double velocity) {
  const double motor_speed_rad_per_s = motor.gear_ratio * velocity / lever_m;
  const double current_A =
      (voltage_V - motor.back_emf_V_s_per_rad * motor_speed_rad_per_s) / motor.resistance_ohm;
  return 2.0 * motor.torque_constant_Nm_per_A * current_A * motor.gear_ratio / lever_m;
}

double PairVoltage(const MotorPairParams& motor, double lever_m, double output, double velocity) {
  const double current_A =
      output * lever_m / (2.0 * motor.torque_constant_Nm_per_A * motor.gear_ratio);
  const double motor_speed_rad_per_s = motor.gear_ratio * velocity / lever_m;
  return motor.resistance_ohm * current_A + motor.back_emf_V_s_per_rad * motor_speed_rad_per_s;
}

}  // namespace

double CalcThrustVoltage(const BallDriveParams& params, double force_N, double velocity_m_per_s) {
  return PairVoltage(params.thrust, params.thrust_drive_radius_m, force_N, velocity_m_per_s);
}

double CalcRollVoltage(const BallDriveParams& params, double torque_Nm, double velocity_rad_per_s) {
  return PairVoltage(params.roll, 1.0, torque_Nm, velocity_rad_per_s);
}

double CalcThrustMotorForce(const BallDriveParams& params, double voltage_V,
                            double velocity_m_per_s) {
  return PairOutput(params.thrust, params.thrust_drive_radius_m, voltage_V, velocity_m_per_s);
}

double CalcRollMotorTorque(const BallDriveParams& params, double voltage_V,
                           double velocity_rad_per_s) {
  return PairOutput(params.roll, 1.0, voltage_V, velocity_rad_per_s);
}

}  // namespace ves::haptics
