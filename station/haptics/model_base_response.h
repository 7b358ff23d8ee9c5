#pragma once

// ModelBaseResponse: the endoscope-colon model (station/model, paper §3) as
// the coupled mode's BaseResponseSource. Each period the model takes one Step
// with the device's measured roll prescribed. Thrust goes through a virtual
// coupling (a spring between the device's insertion and the model's,
// ThrustMode::kForce): the model is pushed by F_c = k_c·(x_device − x_model)
// and the hand feels −F_c. Prescribing the model's insertion directly
// (kPosition) renders the closed end of a tube as a wall of tens of kN/m,
// which a 1 kHz loop with one period of delay cannot render stably (it rings
// at the ±10 N limit); the coupling caps the rendered stiffness at k_c.
// Roll is prescribed and the model's roll reaction is rendered as is.
// The model steps with its own params.dt_s, which
// should equal the loop period. Step neither allocates nor throws, so this is
// fit for the 1 kHz loop; a non-finite model state gives NaN, which the
// safety monitor turns into the safe state.
#include "station/haptics/base_response.h"
#include "station/model/model.h"

namespace ves::haptics {

class ModelBaseResponse final : public BaseResponseSource {
 public:
  // Throws std::invalid_argument (from the model) for invalid params.
  // `insertion_offset_m` is the model insertion when the device reads 0.
  explicit ModelBaseResponse(model::ModelParams params, double insertion_offset_m = 0.0,
                             double coupling_stiffness_N_per_m = kDefaultCouplingStiffness_N_per_m);

  static constexpr double kDefaultCouplingStiffness_N_per_m = 300.0;

  BaseResponse Update(double insertion_m, double roll_rad, double dt_s) override;

  const model::ModelState& state() const { return state_; }
  const model::StepOutput& output() const { return output_; }

 private:
  model::ModelParams params_;
  model::ModelState state_;
  model::Scratch scratch_;
  model::StepOutput output_;
  double insertion_offset_m_;
  double coupling_stiffness_N_per_m_;
  std::uint64_t updates_{0};
};

}  // namespace ves::haptics
