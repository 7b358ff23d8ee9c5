#pragma once

// ModelBaseResponse: the endoscope-colon model (station/model, paper §3) alone
// as the coupled mode's BaseResponseSource, with no session around it (the
// station's is SessionModelSource, station/app/haptic_session.h): the haptic
// loop bench and the coupling tests put it behind the device. Each period the
// model takes one Step with the device's measured roll prescribed and its
// thrust through the VirtualCoupling. The model steps with its own
// params.dt_s, which should equal the loop period. Step neither allocates nor
// throws, so this is fit for the 1 kHz loop; a non-finite model state gives
// NaN, which the safety monitor turns into the safe state.
#include "station/haptics/base_response.h"
#include "station/haptics/virtual_coupling.h"
#include "station/model/model.h"

namespace ves::haptics {

class ModelBaseResponse final : public BaseResponseSource {
 public:
  // Throws std::invalid_argument (from the model) for invalid params, and for
  // a coupling stiffness that is not > 0 N/m. `insertion_offset_m` is the
  // model insertion when the device reads 0.
  explicit ModelBaseResponse(
      model::ModelParams params, double insertion_offset_m = 0.0,
      double coupling_stiffness_N_per_m = VirtualCoupling::kDefaultStiffness_N_per_m);

  BaseResponse Update(double insertion_m, double roll_rad, double dt_s) override;

  const model::ModelState& state() const { return state_; }
  const model::StepOutput& output() const { return output_; }

 private:
  model::ModelParams params_;
  model::ModelState state_;
  model::Scratch scratch_;
  model::StepOutput output_;
  VirtualCoupling coupling_;
  std::uint64_t updates_{0};
};

}  // namespace ves::haptics
