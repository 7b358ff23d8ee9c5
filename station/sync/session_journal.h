#pragma once

// The journal of a session while it runs (docs/station-run.md, "Journal"):
// an append-only file per running session, so that a station that dies
// mid-session (a crash, a dead X server, a power cut) loses about its last
// second of inputs at most. The file holds a header (the session's record without
// its inputs or results) and then chunks of the input log, each framed with
// its length and CRC-32; the station recovers an interrupted session from it
// on its next run and deletes it once the session's record is in the outbox.
// The payloads are opaque here (sync depends on proto only); the station
// encodes the chunks with training::EncodeInputSamples.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "ves/v1/session.pb.h"

namespace ves::sync {

// A journal that cannot be read at all (its header is missing or damaged).
class JournalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Largest chunk a journal may hold: a minute of inputs at 1 kHz encodes to
// well under 1 MiB, so anything larger is damage, not data.
inline constexpr std::uint32_t kMaxJournalFrameBytes = 16u << 20;
// Largest journal read: a 600 s session writes about 0.5 MB.
inline constexpr std::uintmax_t kMaxJournalBytes = 256u << 20;

// dir/<uuid>.journal
std::filesystem::path JournalPath(const std::filesystem::path& dir, const std::string& uuid);

class SessionJournalWriter {
 public:
  // Creates dir (if needed) and dir/<header.uuid>.journal, locked while the
  // writer lives, and writes the header durably (the file and its folder
  // entry on disk). Throws std::runtime_error naming the path: the file
  // exists, or the disk refused.
  SessionJournalWriter(const std::filesystem::path& dir, const ves::v1::SessionRecord& header);
  ~SessionJournalWriter();
  SessionJournalWriter(const SessionJournalWriter&) = delete;
  SessionJournalWriter& operator=(const SessionJournalWriter&) = delete;

  // Appends one chunk and hands it to the OS; it reaches the disk within
  // sync_interval (fdatasync), so a power cut loses at most that much.
  // Throws std::runtime_error naming the path when the write fails.
  void Append(std::string_view chunk);
  // Flushes to disk now (a session that ended, before its record is built).
  void Sync();
  const std::filesystem::path& path() const { return path_; }
  std::string uuid() const { return path_.stem().string(); }  // the session's

  static constexpr std::chrono::milliseconds kSyncInterval{1000};

 private:
  void WriteFrame(std::string_view payload);

  std::filesystem::path path_;
  int fd_{-1};
  std::chrono::steady_clock::time_point last_sync_;
  bool unsynced_{false};
};

struct JournalContents {
  ves::v1::SessionRecord header;
  std::vector<std::string> chunks;  // in the order written
  // The file ended inside a chunk or with a chunk whose CRC did not match
  // (the station died while writing it): that chunk and anything after it
  // were dropped.
  bool torn_tail{false};
};

// Reads a journal. Throws JournalError naming the path when its magic or
// header is missing or damaged, its header names another session than its
// file name, or it is larger than kMaxJournalBytes; a torn last chunk is
// dropped (torn_tail).
JournalContents ReadSessionJournal(const std::filesystem::path& path);

// The reader's parse of a journal's bytes (ReadSessionJournal less the file
// and its name's check); `name` is the one its errors give. A fuzz target
// (docs/fuzzing.md).
JournalContents ParseSessionJournal(std::string_view bytes, const std::string& name);

// One frame as the writer appends it: length and CRC-32 (little-endian), then
// the payload (at most kMaxJournalFrameBytes; the writer refuses larger).
std::string EncodeJournalFrame(std::string_view payload);
// A whole journal as a writer that lived to write these chunks leaves it.
std::string EncodeSessionJournal(const ves::v1::SessionRecord& header,
                                 const std::vector<std::string>& chunks);

// Whether a live writer holds the journal (a station still running that
// session: its lock goes with its process, however that ends).
bool JournalInUse(const std::filesystem::path& path);

// Removes the *.journal.part files in dir that no writer holds: a station
// that died between creating a journal and renaming it leaves one, holding
// at most a header (no inputs, nothing to recover). Returns how many.
int RemoveStaleJournalParts(const std::filesystem::path& dir);

// The journals in dir (*.journal), sorted by name; none when dir does not exist.
std::vector<std::filesystem::path> ListJournals(const std::filesystem::path& dir);

}  // namespace ves::sync
