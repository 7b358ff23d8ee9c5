#pragma once

// Parameters of the VES-IV decoupled ball drive (paper §2.1): two motors for
// thrust and two for roll, each pair fed the same voltage, motor output
// reaching the scope only through a rubber ball that does not slip. The thrust
// pair uses backlash-free gear motors; the roll pair's gear has backlash
// (the paper's explanation of Fig. 5(b)). The driver uses these to turn a
// force/torque command into a voltage; the simulated device uses them as its plant.
namespace ves::haptics {

struct MotorPairParams {
  double torque_constant_Nm_per_A{0.01};
  double back_emf_V_s_per_rad{0.01};
  double resistance_ohm{8.0};
  double gear_ratio{10.0};  // motor turns per gear-output turn
  double max_voltage_V{24.0};
  bool operator==(const MotorPairParams&) const = default;
};

struct BallDriveParams {
  // Thrust: gear output -> ball -> scope, v_scope = ω_out · r (no slip).
  MotorPairParams thrust{};
  double thrust_drive_radius_m{0.01};
  double thrust_mass_kg{0.3};  // scope section, ball, rollers and reflected rotors
  double thrust_damping_N_s_per_m{1.0};
  double thrust_coulomb_N{0.03};
  // Roll: gear output turns the scope 1:1 through the ball, across a backlash gap.
  MotorPairParams roll{0.01, 0.01, 8.0, 20.0, 24.0};
  double roll_motor_inertia_kg_m2{8e-5};  // both rotors reflected through the gear
  double roll_motor_damping_Nm_s_per_rad{1e-3};
  double roll_scope_inertia_kg_m2{1e-5};
  double roll_scope_damping_Nm_s_per_rad{2e-3};
  double roll_backlash_rad{0.0175};  // total play, ~1°
  double roll_gear_stiffness_Nm_per_rad{50.0};
  double roll_gear_damping_Nm_s_per_rad{0.02};
  bool operator==(const BallDriveParams&) const = default;
};

// Voltage for a pair so the drive delivers `force_N` at the scope while it
// moves at `velocity_m_per_s` (resistive drop plus back-EMF), unclamped.
double CalcThrustVoltage(const BallDriveParams& params, double force_N, double velocity_m_per_s);
double CalcRollVoltage(const BallDriveParams& params, double torque_Nm, double velocity_rad_per_s);
// Force / torque at the gear output for an applied pair voltage (the plant side).
double CalcThrustMotorForce(const BallDriveParams& params, double voltage_V,
                            double velocity_m_per_s);
double CalcRollMotorTorque(const BallDriveParams& params, double voltage_V,
                           double velocity_rad_per_s);

}  // namespace ves::haptics
