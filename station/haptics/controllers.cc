#include "station/haptics/controllers.h"

#include <algorithm>

namespace ves::haptics {

ControllerState CalcInitialControllerState(const DeviceState& device) {
  return {{device.insertion_m, 0.0}, {device.roll_rad, 0.0}};
}

double CalcAdmittanceAxis(double position, double velocity, double hand_load, double external_load,
                          const AxisControlParams& params, double dt_s, AxisTarget* target) {
  // Admittance: m_v·a_t = F_hand + F_ext − b_v·v_t (semi-implicit Euler).
  const double accel = (hand_load + external_load - params.virtual_damping * target->velocity) /
                       params.virtual_inertia;
  target->velocity += dt_s * accel;
  target->position += dt_s * target->velocity;
  // Anti-windup: when the drive cannot follow (clamped output, a hand holding
  // the scope), the target waits for the scope instead of running away.
  const double error = target->position - position;
  if (error > params.max_tracking_error || error < -params.max_tracking_error) {
    target->position =
        position + std::clamp(error, -params.max_tracking_error, params.max_tracking_error);
    target->velocity = velocity;
  }
  // Make the plant follow the target: the plant gets F_hand from the hand, so
  // the drive supplies m̂·a_t + b̂·v_t − F_hand, and PD corrects the rest.
  return params.plant_inertia * accel + params.plant_damping * target->velocity - hand_load +
         params.position_gain * (target->position - position) +
         params.velocity_gain * (target->velocity - velocity);
}

namespace {

MotorCommand CalcAdmittanceCommand(const DeviceState& device, const BaseResponse& base,
                                   const AxisControlParams& thrust, const AxisControlParams& roll,
                                   double dt_s, ControllerState* state) {
  MotorCommand command;
  command.powered = true;
  command.thrust_force_N =
      CalcAdmittanceAxis(device.insertion_m, device.insertion_velocity_m_per_s, device.force_N,
                         base.thrust_force_N, thrust, dt_s, &state->thrust);
  command.roll_torque_Nm =
      CalcAdmittanceAxis(device.roll_rad, device.roll_velocity_rad_per_s, device.torque_Nm,
                         base.roll_torque_Nm, roll, dt_s, &state->roll);
  return command;
}

}  // namespace

MotorCommand CalcFreeCommand(const DeviceState& device, const ControlParams& params, double dt_s,
                             ControllerState* state) {
  // Paper §2.2: "control was applied so that the reaction force was always 0".
  return CalcAdmittanceCommand(device, BaseResponse{}, params.thrust, params.roll, dt_s, state);
}

MotorCommand CalcSpringCommand(const DeviceState& device, const ControlParams& params) {
  // Paper §2.2: theoretical position from force through a linear spring.
  const double target_insertion_m =
      params.spring_rest_insertion_m + device.force_N / params.spring_stiffness_N_per_m;
  const double target_roll_rad =
      params.spring_rest_roll_rad + device.torque_Nm / params.spring_stiffness_Nm_per_rad;
  const double thrust_gain_N_per_m = params.spring_gain_ratio * params.spring_stiffness_N_per_m;
  const double roll_gain_Nm_per_rad = params.spring_gain_ratio * params.spring_stiffness_Nm_per_rad;
  // The drive holds the measured hand force (−F_hand) and servoes the encoder
  // onto the theoretical position.
  MotorCommand command;
  command.powered = true;
  command.thrust_force_N =
      -device.force_N + thrust_gain_N_per_m * (target_insertion_m - device.insertion_m) -
      thrust_gain_N_per_m * params.spring_damping_time_s * device.insertion_velocity_m_per_s;
  command.roll_torque_Nm =
      -device.torque_Nm + roll_gain_Nm_per_rad * (target_roll_rad - device.roll_rad) -
      roll_gain_Nm_per_rad * params.spring_damping_time_s * device.roll_velocity_rad_per_s;
  return command;
}

MotorCommand CalcCoupledCommand(const DeviceState& device, const BaseResponse& base,
                                const ControlParams& params, double dt_s, ControllerState* state) {
  AxisControlParams thrust = params.thrust;
  AxisControlParams roll = params.roll;
  thrust.virtual_damping =
      std::max(thrust.virtual_damping, params.coupled_virtual_damping_N_s_per_m);
  roll.virtual_damping =
      std::max(roll.virtual_damping, params.coupled_virtual_damping_Nm_s_per_rad);
  return CalcAdmittanceCommand(device, base, thrust, roll, dt_s, state);
}

}  // namespace ves::haptics
