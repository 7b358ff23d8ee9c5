#pragma once

// The candump log format of can-utils (`candump -l`, read by canplayer and
// log2asc): one frame per line, `(1700000000.123456) can0 123#DEADBEEF`.
// Formatting and parsing are pure; CanFrameRecorder takes frames from the
// 1 kHz loop without blocking or allocating and writes them on its own thread.
#include <linux/can.h>

#include <atomic>
#include <cstdint>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace ves::haptics {

struct CandumpRecord {
  double timestamp_s{0.0};  // seconds since the Unix epoch
  std::string interface_name;
  can_frame frame{};
};

// `(seconds.micros) iface id#data`: 3 hex digits for standard ids, 8 for
// extended and error frames (with CAN_ERR_FLAG), `#R` for remote frames.
std::string FormatCandumpLine(double timestamp_s, const std::string& interface_name,
                              const can_frame& frame);
// std::nullopt for a line that is not in that format.
std::optional<CandumpRecord> ParseCandumpLine(const std::string& line);

// Single-producer (the loop) / single-consumer (the writer thread) ring of
// frames with their time. Frames that do not fit are counted, not waited for.
class CanFrameRecorder {
 public:
  // Writes to `path` (truncated). Throws std::runtime_error if it cannot open it.
  // `clock_offset_s` is added to the times given to Record() to make epoch times.
  CanFrameRecorder(const std::string& path, std::string interface_name, double clock_offset_s,
                   std::size_t capacity = 1 << 16);
  ~CanFrameRecorder();  // drains and closes
  CanFrameRecorder(const CanFrameRecorder&) = delete;
  CanFrameRecorder& operator=(const CanFrameRecorder&) = delete;

  // Real-time safe: no lock, no allocation.
  void Record(double time_s, const can_frame& frame);
  // Stops the writer after writing everything recorded so far.
  void Close();

  std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }
  std::uint64_t written() const { return written_.load(std::memory_order_relaxed); }

 private:
  struct Slot {
    double time_s;
    can_frame frame;
  };
  void WriterMain();
  bool DrainOnce();

  std::ofstream out_;
  std::string interface_name_;
  double clock_offset_s_;
  std::vector<Slot> ring_;
  std::atomic<std::uint64_t> head_{0};  // next write index (producer)
  std::atomic<std::uint64_t> tail_{0};  // next read index (consumer)
  std::atomic<std::uint64_t> dropped_{0};
  std::atomic<std::uint64_t> written_{0};
  std::atomic<bool> stop_{false};
  std::thread writer_;
};

// Seconds to add to CLOCK_MONOTONIC times to get CLOCK_REALTIME (epoch) times.
double MonotonicToEpochOffsetSeconds();

}  // namespace ves::haptics
