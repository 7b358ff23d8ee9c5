#include "station/haptics/virtual_coupling.h"

#include <stdexcept>
#include <string>

namespace ves::haptics {

VirtualCoupling::VirtualCoupling(const char* owner, double stiffness_N_per_m,
                                 double insertion_offset_m)
    : stiffness_N_per_m_(stiffness_N_per_m), insertion_offset_m_(insertion_offset_m) {
  if (!(stiffness_N_per_m_ > 0.0)) {
    throw std::invalid_argument(std::string(owner) + " coupling stiffness must be > 0 N/m, got " +
                                std::to_string(stiffness_N_per_m_));
  }
}

}  // namespace ves::haptics
