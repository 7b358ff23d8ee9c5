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

// While it lives, asks the kernel's PM QoS (/dev/cpu_dma_latency, as
// cyclictest does) to keep the CPUs out of idle states whose exit latency
// exceeds max_latency_us: with 0 an idle CPU polls instead of halting, so a
// timer wakes the loop without a C-state exit (on a VM: without the host
// rescheduling a halted vCPU). Costs idle power. Not permitted: one log line.
class CpuLatencyRequest {
 public:
  explicit CpuLatencyRequest(int max_latency_us);
  ~CpuLatencyRequest();
  CpuLatencyRequest(const CpuLatencyRequest&) = delete;
  CpuLatencyRequest& operator=(const CpuLatencyRequest&) = delete;
  bool active() const { return fd_ >= 0; }

 private:
  int fd_{-1};
};

// CLOCK_MONOTONIC in seconds / nanoseconds.
double MonotonicSeconds();
long long MonotonicNanoseconds();

}  // namespace ves::haptics
