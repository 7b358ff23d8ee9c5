#pragma once

// The virtual coupling between the device and the model (the one place the
// law is written; SessionModelSource and ModelBaseResponse both use it): a
// spring of stiffness k_c from the model's base to the device's insertion
// mapped into the model, so F_c = k_c·(x_device + offset − x_model) pushes the
// model's base in (ThrustMode::kForce) and the hand feels −F_c. Prescribing
// the model's insertion directly renders the closed end of a tube as a wall
// of tens of kN/m, which a 1 kHz loop with one period of delay cannot render
// stably (it rings at the ±10 N limit); the coupling caps the rendered
// stiffness at k_c. Roll is not coupled: it is prescribed, and the model's
// roll reaction is rendered as is.
#include "station/haptics/base_response.h"

namespace ves::haptics {

class VirtualCoupling {
 public:
  static constexpr double kDefaultStiffness_N_per_m = 300.0;

  // Throws std::invalid_argument unless the stiffness is > 0 N/m; `owner`
  // names the source in the message. `insertion_offset_m` is the model's
  // insertion when the device reads 0.
  explicit VirtualCoupling(const char* owner, double stiffness_N_per_m = kDefaultStiffness_N_per_m,
                           double insertion_offset_m = 0.0);

  // Maps the device's present reading onto the model's present insertion.
  void MapOnto(double model_insertion_m, double device_insertion_m) {
    insertion_offset_m_ = model_insertion_m - device_insertion_m;
  }
  double insertion_offset_m() const { return insertion_offset_m_; }  // model − device
  double stiffness_N_per_m() const { return stiffness_N_per_m_; }

  // The device's insertion in model coordinates.
  double ModelInsertion_m(double device_insertion_m) const {
    return device_insertion_m + insertion_offset_m_;
  }
  // F_c, the force on the model's base along +insertion.
  double CalcPushForce_N(double device_insertion_m, double model_insertion_m) const {
    return stiffness_N_per_m_ * (device_insertion_m + insertion_offset_m_ - model_insertion_m);
  }
  // What the motors render for the push F_c the model took and the model's
  // roll reaction (+ when it resists +roll): the coupling pulls the device
  // back by F_c, the roll reaction turns it back.
  static BaseResponse CalcReaction(double push_force_N, double model_roll_torque_Nm,
                                   std::uint64_t update_count) {
    BaseResponse response;
    response.update_count = update_count;
    response.thrust_force_N = -push_force_N;
    response.roll_torque_Nm = -model_roll_torque_Nm;
    return response;
  }

 private:
  double stiffness_N_per_m_;
  double insertion_offset_m_;
};

}  // namespace ves::haptics
