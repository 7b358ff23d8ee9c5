#pragma once

// SeqLock<T>: one writer (the 1 kHz loop) publishes a small trivially
// copyable value; any number of readers (render, UI) take consistent copies
// without ever blocking the writer. The value is kept in atomic words so
// there is no data race; the sequence number says whether a copy is torn.
// Ordering without fences (Boehm, "Can seqlocks get along with programming
// language memory models?", MSPC 2012): the words are stored with release
// after the odd sequence and loaded with acquire before the second sequence
// load. On x86 these are plain moves.
#include <array>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace ves::haptics {

template <typename T>
class SeqLock {
  static_assert(std::is_trivially_copyable_v<T>, "SeqLock needs a trivially copyable type");
  static constexpr std::size_t kWords = (sizeof(T) + 7) / 8;

 public:
  SeqLock() { Store(T{}); }

  // Writer only (a single thread). Wait-free.
  void Store(const T& value) {
    std::array<std::uint64_t, kWords> words{};
    std::memcpy(words.data(), &value, sizeof(T));
    const std::uint64_t sequence = sequence_.load(std::memory_order_relaxed);
    sequence_.store(sequence + 1, std::memory_order_relaxed);  // odd: writing
    // Release stores of the words (not a fence, which ThreadSanitizer cannot
    // check): a reader that sees any new word also sees the odd sequence.
    for (std::size_t i = 0; i < kWords; ++i) words_[i].store(words[i], std::memory_order_release);
    sequence_.store(sequence + 2, std::memory_order_release);  // even: stable
  }

  // Any thread. Retries while a write is in progress; false if it never got a
  // stable copy in `max_attempts` (the writer cannot hold it longer than a copy).
  bool Load(T* out, int max_attempts = 1000) const {
    std::array<std::uint64_t, kWords> words{};
    for (int attempt = 0; attempt < max_attempts; ++attempt) {
      const std::uint64_t before = sequence_.load(std::memory_order_acquire);
      if (before & 1) continue;
      for (std::size_t i = 0; i < kWords; ++i) words[i] = words_[i].load(std::memory_order_acquire);
      if (sequence_.load(std::memory_order_relaxed) == before) {
        std::memcpy(static_cast<void*>(out), words.data(), sizeof(T));
        return true;
      }
    }
    return false;
  }

  std::uint64_t version() const { return sequence_.load(std::memory_order_acquire) / 2; }

 private:
  std::atomic<std::uint64_t> sequence_{0};
  std::array<std::atomic<std::uint64_t>, kWords> words_{};
};

}  // namespace ves::haptics
