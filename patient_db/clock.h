#pragma once

#include <cstdint>

// The wall clock as the stores and the server stamp rows with it.
namespace ves::patient_db {

// Milliseconds since the Unix epoch, by the system clock.
int64_t NowUnixMs();

}  // namespace ves::patient_db
