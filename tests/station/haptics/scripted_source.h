#pragma once

// A synthetic BaseResponseSource for the coupled mode in tests: a virtual
// wall along insertion (the model's "colon wall" reduced to one spring), an
// optional constant load, and switches to stall or poison the model.
#include <cstdint>
#include <limits>

#include "station/haptics/base_response.h"

namespace ves::haptics::testing {

class ScriptedSource final : public BaseResponseSource {
 public:
  BaseResponse Update(double insertion_m, double /*roll_rad*/, double /*dt_s*/) override {
    if (!stalled) ++count_;
    BaseResponse response;
    response.update_count = count_;
    // A wall at wall_insertion_m pushing back with wall_stiffness_N_per_m.
    const double penetration_m = insertion_m - wall_insertion_m;
    response.thrust_force_N =
        constant_force_N + (penetration_m > 0.0 ? -wall_stiffness_N_per_m * penetration_m : 0.0);
    response.roll_torque_Nm = constant_torque_Nm;
    if (poison) response.thrust_force_N = std::numeric_limits<double>::quiet_NaN();
    return response;
  }

  double wall_insertion_m{1e9};
  double wall_stiffness_N_per_m{0.0};
  double constant_force_N{0.0};
  double constant_torque_Nm{0.0};
  bool stalled{false};
  bool poison{false};
  std::uint64_t updates() const { return count_; }

 private:
  std::uint64_t count_{0};
};

}  // namespace ves::haptics::testing
