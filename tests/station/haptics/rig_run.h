#pragma once

// Helpers for running the simulated rig in simulated time in tests.
#include <vector>

#include "station/haptics/line_fit.h"
#include "station/haptics/sim_rig.h"

namespace ves::haptics::testing {

struct Trace {
  std::vector<double> insertion_m;
  std::vector<double> roll_rad;
  std::vector<double> force_N;
  std::vector<double> torque_Nm;
  std::vector<double> true_roll_scope_rad;
};

// Brings the rig up, then runs `seconds` of simulated time, recording the
// station's measurements after `settle_s`.
inline Trace RunRig(SimulatedRig* rig, double seconds, double settle_s = 0.0) {
  Trace trace;
  if (!rig->BringUp()) return trace;
  const double start_s = rig->now_s();
  while (rig->now_s() - start_s < seconds) {
    rig->Step();
    if (rig->now_s() - start_s < settle_s) continue;
    const DeviceState& state = rig->cycle().device_state();
    trace.insertion_m.push_back(state.insertion_m);
    trace.roll_rad.push_back(state.roll_rad);
    trace.force_N.push_back(state.force_N);
    trace.torque_Nm.push_back(state.torque_Nm);
    trace.true_roll_scope_rad.push_back(rig->device().plant().roll_scope_rad);
  }
  return trace;
}

inline SimulatedRigOptions RigWithHand(const HandProfile& hand, ControlMode mode) {
  SimulatedRigOptions options;
  options.device.hand = hand;
  options.device.seed = 42;
  options.cycle.control.mode = mode;
  return options;
}

}  // namespace ves::haptics::testing
