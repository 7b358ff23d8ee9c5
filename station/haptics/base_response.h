#pragma once

// What the coupled mode renders: the model's response at the scope's base
// (paper §3: thrust force and roll torque from the contact forces along the
// scope). The loop asks a BaseResponseSource once per period with the
// measured insertion and roll; the source may compute it there or hand over
// the latest result of a model running elsewhere. update_count must advance
// with each new model result: a count that stalls for 2 periods is a fault.
#include <cstdint>

namespace ves::haptics {

struct BaseResponse {
  double thrust_force_N{0.0};  // force of the colon on the scope along +insertion
  double roll_torque_Nm{0.0};  // torque of the colon on the scope about +roll
  std::uint64_t update_count{0};
  bool operator==(const BaseResponse&) const = default;
};

// The virtual coupling between the device and the model (the one place the
// law is written): a spring of stiffness k_c from the model's base to the
// device's insertion (mapped into the model by the offset), so
// F_c = k_c·(x_device + offset − x_model) pushes the model's base in
// (ThrustMode::kForce) and the hand feels −F_c. It caps the stiffness the
// 1 kHz loop has to render at k_c (ModelBaseResponse, SessionModelSource).
inline double CalcCouplingForce_N(double coupling_stiffness_N_per_m, double device_insertion_m,
                                  double insertion_offset_m, double model_insertion_m) {
  return coupling_stiffness_N_per_m * (device_insertion_m + insertion_offset_m - model_insertion_m);
}

class BaseResponseSource {
 public:
  virtual ~BaseResponseSource() = default;
  // Called from the 1 kHz loop: must not block, throw or allocate. The
  // readings are finite (HapticCycle::Run checks them before the call).
  virtual BaseResponse Update(double insertion_m, double roll_rad, double dt_s) = 0;
};

}  // namespace ves::haptics
