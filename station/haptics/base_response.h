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

class BaseResponseSource {
 public:
  virtual ~BaseResponseSource() = default;
  // Called from the 1 kHz loop: must not block, throw or allocate. The
  // readings are finite (HapticCycle::Run checks them before the call).
  virtual BaseResponse Update(double insertion_m, double roll_rad, double dt_s) = 0;
};

}  // namespace ves::haptics
