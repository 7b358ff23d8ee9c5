#pragma once

#include <chrono>
#include <cstdint>

namespace ves::patient_db {

// Wall-clock milliseconds since the Unix epoch: the one clock of stored rows
// (stored_unix_ms, audit at_unix_ms, ...) and of the server above the stores.
inline int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace ves::patient_db
