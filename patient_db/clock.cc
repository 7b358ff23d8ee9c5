#include "patient_db/clock.h"

#include <chrono>

namespace ves::patient_db {

int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace ves::patient_db
