#pragma once

// Single-producer single-consumer ring: the 1 kHz loop pushes (never blocks,
// never allocates; a full ring drops and counts), another thread pops.
#include <atomic>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace ves::haptics {

template <typename T>
class SpscRing {
 public:
  explicit SpscRing(std::size_t capacity) : slots_(capacity) {
    if (capacity == 0) throw std::invalid_argument("SpscRing capacity must be > 0");
  }

  bool Push(const T& value) {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_.load(std::memory_order_acquire) >= slots_.size()) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    slots_[head % slots_.size()] = value;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  bool Pop(T* value) {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    *value = slots_[tail % slots_.size()];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  std::vector<T> slots_;
  std::atomic<std::uint64_t> head_{0};
  std::atomic<std::uint64_t> tail_{0};
  std::atomic<std::uint64_t> dropped_{0};
};

}  // namespace ves::haptics
