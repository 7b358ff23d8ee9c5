#include "station/haptics/model_base_response.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace ves::haptics {

ModelBaseResponse::ModelBaseResponse(model::ModelParams params, double insertion_offset_m,
                                     double coupling_stiffness_N_per_m)
    : params_(std::move(params)),
      state_(model::MakeInitialState(params_)),
      scratch_(model::MakeScratch(params_)),
      output_(model::MakeStepOutput(params_)),
      insertion_offset_m_(insertion_offset_m),
      coupling_stiffness_N_per_m_(coupling_stiffness_N_per_m) {
  if (!(coupling_stiffness_N_per_m_ > 0.0)) {
    throw std::invalid_argument("ModelBaseResponse coupling stiffness must be > 0 N/m, got " +
                                std::to_string(coupling_stiffness_N_per_m_));
  }
}

BaseResponse ModelBaseResponse::Update(double insertion_m, double roll_rad, double /*dt_s*/) {
  const double coupling_force_N = CalcCouplingForce_N(
      coupling_stiffness_N_per_m_, insertion_m, insertion_offset_m_, state_.inserted_m);
  model::StepInput input;
  input.thrust_mode = model::ThrustMode::kForce;
  input.push_force_N = coupling_force_N;
  input.roll_rad = roll_rad;
  model::Step(params_, input, &state_, &scratch_, &output_);
  BaseResponse response;
  response.update_count = ++updates_;
  if (!output_.finite) {  // the model diverged (a NaN offset poisons it too)
    response.thrust_force_N = std::numeric_limits<double>::quiet_NaN();
    return response;
  }
  // On the scope along +insertion: the coupling pulls the device back by F_c.
  // The model's roll reaction is + when it resists +roll.
  response.thrust_force_N = -coupling_force_N;
  response.roll_torque_Nm = -output_.roll_torque_Nm;
  return response;
}

}  // namespace ves::haptics
