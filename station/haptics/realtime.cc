#include "station/haptics/realtime.h"

#include <pthread.h>
#include <sched.h>
#include <spdlog/spdlog.h>
#include <sys/mman.h>
#include <sys/prctl.h>

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <ctime>

namespace ves::haptics {

RealtimeStatus TryEnableRealtime(int priority, const char* thread_name) {
  RealtimeStatus status;
  sched_param param{};
  param.sched_priority = priority;
  const int fifo_error = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
  status.fifo = fifo_error == 0;
  status.memory_locked = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;
  const int lock_error = status.memory_locked ? 0 : errno;
  // Wake at the deadline, not up to 50 µs after it (the default timer slack).
  prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  status.detail = std::string(thread_name) + ": ";
  status.detail += status.fifo ? "SCHED_FIFO priority " + std::to_string(priority)
                               : std::string("SCHED_FIFO not permitted (") +
                                     std::strerror(fifo_error) + "), normal scheduling";
  status.detail += status.memory_locked ? ", memory locked"
                                        : std::string(", mlockall not permitted (") +
                                              std::strerror(lock_error) + ")";
  if (status.fifo && status.memory_locked) {
    spdlog::info("{}", status.detail);
  } else {
    spdlog::warn("{}; timing will suffer under load", status.detail);
  }
  return status;
}

CpuLatencyRequest::CpuLatencyRequest(int max_latency_us) {
  fd_ = open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);
  const std::int32_t value = max_latency_us;
  if (fd_ >= 0 && write(fd_, &value, sizeof(value)) == static_cast<ssize_t>(sizeof(value))) {
    spdlog::info("haptic loop: CPU wake-up latency held at <= {} us (/dev/cpu_dma_latency)",
                 max_latency_us);
    return;
  }
  spdlog::warn("haptic loop: cannot hold the CPU wake-up latency (/dev/cpu_dma_latency: {}); "
               "idle CPUs may wake the loop late",
               std::strerror(errno));
  if (fd_ >= 0) close(fd_);
  fd_ = -1;
}

CpuLatencyRequest::~CpuLatencyRequest() {
  if (fd_ >= 0) close(fd_);  // closing withdraws the request
}

double MonotonicSeconds() { return static_cast<double>(MonotonicNanoseconds()) * 1e-9; }

long long MonotonicNanoseconds() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<long long>(now.tv_sec) * 1000000000LL + now.tv_nsec;
}

}  // namespace ves::haptics
