#include "station/haptics/candump_log.h"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <stdexcept>
#include <string_view>

namespace ves::haptics {
namespace {

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

double TimespecSeconds(const timespec& time) { return time.tv_sec + time.tv_nsec * 1e-9; }

}  // namespace

std::string FormatCandumpLine(double timestamp_s, const std::string& interface_name,
                              const can_frame& frame) {
  // Integer microseconds so rounding never prints ".1000000".
  const auto micros_total = static_cast<long long>(std::llround(timestamp_s * 1e6));
  char head[64];
  std::snprintf(head, sizeof(head), "(%lld.%06lld) ", micros_total / 1000000,
                micros_total % 1000000);
  std::string line = head;
  line += interface_name;
  line += ' ';
  char id[16];
  if (frame.can_id & CAN_ERR_FLAG) {
    std::snprintf(id, sizeof(id), "%08X", frame.can_id & (CAN_ERR_MASK | CAN_ERR_FLAG));
  } else if (frame.can_id & CAN_EFF_FLAG) {
    std::snprintf(id, sizeof(id), "%08X", frame.can_id & CAN_EFF_MASK);
  } else {
    std::snprintf(id, sizeof(id), "%03X", frame.can_id & CAN_SFF_MASK);
  }
  line += id;
  line += '#';
  if (frame.can_id & CAN_RTR_FLAG) {
    line += 'R';
    return line;
  }
  static constexpr char kHex[] = "0123456789ABCDEF";
  const int length = frame.can_dlc > CAN_MAX_DLEN ? CAN_MAX_DLEN : frame.can_dlc;
  for (int i = 0; i < length; ++i) {
    line += kHex[frame.data[i] >> 4];
    line += kHex[frame.data[i] & 0xF];
  }
  return line;
}

std::optional<CandumpRecord> ParseCandumpLine(const std::string& line) {
  CandumpRecord record;
  long long seconds = 0;
  char micros[16] = {};
  char iface[32] = {};
  char body[64] = {};
  if (std::sscanf(line.c_str(), "(%lld.%15[0-9]) %31s %63s", &seconds, micros, iface, body) != 4) {
    return std::nullopt;
  }
  // candump writes six digits of microseconds; seconds past year ~5000 are
  // not a log of ours (and would overflow the microseconds when written back).
  if (seconds < 0 || seconds > 100'000'000'000LL || std::string_view(micros).size() != 6) {
    return std::nullopt;
  }
  record.timestamp_s = static_cast<double>(seconds) + std::atof(micros) / 1e6;
  record.interface_name = iface;
  const std::string text = body;
  const auto hash = text.find('#');
  if (hash == std::string::npos || (hash != 3 && hash != 8)) return std::nullopt;
  canid_t id = 0;
  for (std::size_t i = 0; i < hash; ++i) {
    const int digit = HexValue(text[i]);
    if (digit < 0) return std::nullopt;
    id = (id << 4) | static_cast<canid_t>(digit);
  }
  // Three digits: an 11-bit id. Eight: a 29-bit id, or an error frame's
  // class bits with CAN_ERR_FLAG; never the EFF or RTR flag bits themselves.
  if (hash == 3 && id > CAN_SFF_MASK) return std::nullopt;
  if (hash == 8 && (id & (CAN_EFF_FLAG | CAN_RTR_FLAG))) return std::nullopt;
  if (hash == 8 && !(id & CAN_ERR_FLAG)) id |= CAN_EFF_FLAG;
  record.frame.can_id = id;
  const std::string data = text.substr(hash + 1);
  if (!data.empty() && (data[0] == 'R' || data[0] == 'r')) {
    record.frame.can_id |= CAN_RTR_FLAG;
    return record;
  }
  if (data.size() % 2 != 0 || data.size() / 2 > CAN_MAX_DLEN) return std::nullopt;
  for (std::size_t i = 0; i < data.size(); i += 2) {
    const int high = HexValue(data[i]);
    const int low = HexValue(data[i + 1]);
    if (high < 0 || low < 0) return std::nullopt;
    record.frame.data[i / 2] = static_cast<std::uint8_t>(high << 4 | low);
  }
  record.frame.can_dlc = static_cast<std::uint8_t>(data.size() / 2);
  return record;
}

CanFrameRecorder::CanFrameRecorder(const std::string& path, std::string interface_name,
                                   double clock_offset_s, std::size_t capacity)
    : out_(path, std::ios::out | std::ios::trunc),
      interface_name_(std::move(interface_name)),
      clock_offset_s_(clock_offset_s),
      ring_(capacity) {
  if (!out_) throw std::runtime_error("cannot open CAN log '" + path + "' for writing");
  if (capacity == 0) throw std::invalid_argument("CanFrameRecorder capacity must be > 0");
  writer_ = std::thread([this] { WriterMain(); });
}

CanFrameRecorder::~CanFrameRecorder() { Close(); }

void CanFrameRecorder::Record(double time_s, const can_frame& frame) {
  const std::uint64_t head = head_.load(std::memory_order_relaxed);
  if (head - tail_.load(std::memory_order_acquire) >= ring_.size()) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  ring_[head % ring_.size()] = Slot{time_s, frame};
  head_.store(head + 1, std::memory_order_release);
}

bool CanFrameRecorder::DrainOnce() {
  const std::uint64_t head = head_.load(std::memory_order_acquire);
  std::uint64_t tail = tail_.load(std::memory_order_relaxed);
  const bool any = tail != head;
  for (; tail != head; ++tail) {
    const Slot& slot = ring_[tail % ring_.size()];
    out_ << FormatCandumpLine(slot.time_s + clock_offset_s_, interface_name_, slot.frame) << '\n';
    written_.fetch_add(1, std::memory_order_relaxed);
    tail_.store(tail + 1, std::memory_order_release);
  }
  return any;
}

void CanFrameRecorder::WriterMain() {
  while (!stop_.load(std::memory_order_acquire)) {
    if (!DrainOnce()) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  DrainOnce();
  out_.flush();
}

void CanFrameRecorder::Close() {
  if (writer_.joinable()) {
    stop_.store(true, std::memory_order_release);
    writer_.join();
  }
}

double MonotonicToEpochOffsetSeconds() {
  timespec realtime{};
  timespec monotonic{};
  clock_gettime(CLOCK_REALTIME, &realtime);
  clock_gettime(CLOCK_MONOTONIC, &monotonic);
  return TimespecSeconds(realtime) - TimespecSeconds(monotonic);
}

}  // namespace ves::haptics
