#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "station/sync/session_journal.h"
#include "station/training/case_run.h"
#include "station/training/input_log.h"
#include "ves/v1/case.pb.h"
#include "ves/v1/session.pb.h"

// The journal of an interactive run's running session (docs/station-run.md,
// "Journal"): the loop thread pushes JournalEntry values into a ring, the UI
// thread drains them into the session's journal file.
namespace ves::station {

// A session's UUID as a fixed, NUL-terminated array, which the loop thread
// can copy without allocating.
using UuidChars = std::array<char, 40>;
inline UuidChars UuidCharsOf(const std::string& uuid) {
  UuidChars chars{};
  std::memcpy(chars.data(), uuid.data(), std::min(uuid.size(), chars.size() - 1));
  return chars;
}

// Loop thread -> UI thread, for the journal of the running session: a
// session's start (its UUID and start time) or one logged input.
struct JournalEntry {
  bool starts{false};
  UuidChars uuid{};
  std::int64_t start_unix_ms{0};
  training::InputSample sample;
};
// 8 s at 1 kHz: the UI thread drains it every frame.
inline constexpr std::size_t kJournalRingEntries = 8192;

// The UI thread's side of the journal: one file per session
// (sync::SessionJournalWriter) holding its record's header and its inputs in
// chunks of a quarter second. A failure (a full disk, inputs dropped while
// the screen stalled) ends the journaling of that session, said once; its
// record is still stored when it ends, as without a journal.
class JournalKeeper {
 public:
  JournalKeeper(std::filesystem::path dir, const training::CaseRun& run,
                const ves::v1::ColonCase& colon_case, double time_limit_s);

  // The session's record is in the outbox (and its journal deleted): its
  // writer and lock go.
  void Release(const std::string& uuid);
  void Take(const JournalEntry& entry);

 private:
  static constexpr std::size_t kChunkSamples = 250;

  void Flush();
  void Fail(const std::string& why);

  std::filesystem::path dir_;
  ves::v1::SessionRecord header_;
  std::unique_ptr<sync::SessionJournalWriter> writer_;
  std::vector<std::unique_ptr<sync::SessionJournalWriter>> retired_;  // ended, not yet committed
  std::vector<training::InputSample> pending_;
  std::uint64_t next_tick_{0};
};

}  // namespace ves::station
