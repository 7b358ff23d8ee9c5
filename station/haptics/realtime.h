#pragma once

// Real-time set-up of the calling thread: SCHED_FIFO at `priority`,
// mlockall(MCL_CURRENT | MCL_FUTURE) and a 1 ns timer slack. Each is tried;
// what is not permitted is said in one log line and the thread runs on as a
// normal thread.
#include <string>

namespace ves::haptics {

struct RealtimeStatus {
  bool fifo{false};
  bool memory_locked{false};
  std::string detail;  // the one line that was logged
};

RealtimeStatus TryEnableRealtime(int priority, const char* thread_name);

// CLOCK_MONOTONIC in seconds / nanoseconds.
double MonotonicSeconds();
long long MonotonicNanoseconds();

}  // namespace ves::haptics
