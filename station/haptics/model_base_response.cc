#include "station/haptics/model_base_response.h"

#include <cmath>
#include <limits>
#include <utility>

namespace ves::haptics {

ModelBaseResponse::ModelBaseResponse(model::ModelParams params, double insertion_offset_m,
                                     double coupling_stiffness_N_per_m)
    : params_(std::move(params)),
      state_(model::MakeInitialState(params_)),
      scratch_(model::MakeScratch(params_)),
      output_(model::MakeStepOutput(params_)),
      coupling_("ModelBaseResponse", coupling_stiffness_N_per_m, insertion_offset_m) {}

BaseResponse ModelBaseResponse::Update(double insertion_m, double roll_rad, double /*dt_s*/) {
  const double coupling_force_N = coupling_.CalcPushForce_N(insertion_m, state_.inserted_m);
  model::StepInput input;
  input.thrust_mode = model::ThrustMode::kForce;
  input.push_force_N = coupling_force_N;
  input.roll_rad = roll_rad;
  model::Step(params_, input, &state_, &scratch_, &output_);
  ++updates_;
  if (!output_.finite) {  // the model diverged (a NaN offset poisons it too)
    BaseResponse response;
    response.update_count = updates_;
    response.thrust_force_N = std::numeric_limits<double>::quiet_NaN();
    return response;
  }
  return VirtualCoupling::CalcReaction(coupling_force_N, output_.roll_torque_Nm, updates_);
}

}  // namespace ves::haptics
