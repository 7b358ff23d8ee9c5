#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "ves/v1/session.pb.h"

// An uploaded session record checked once, where it enters the server
// (Sessions.UploadSession): its message bounds by the pipeline's bounds stage,
// then CheckSessionRecord (plausibility, the input log's encoding, step and
// header). Only Check makes one, so whatever takes a CheckedRecord (the
// stored row, the station report, the lesson judge, the series worker) holds
// the parsed, checked record and neither parses nor checks it again. A record
// read back from the store (after a restart) is parsed there, once, by the
// worker that needs it.
namespace ves::server {

class CheckedRecord {
 public:
  // The record when CheckSessionRecord(record, now_unix_ms) accepts it; else
  // null with the one-line `problem` naming the field.
  static std::shared_ptr<const CheckedRecord> Check(const ves::v1::SessionRecord& record,
                                                    int64_t now_unix_ms, std::string* problem);

  const ves::v1::SessionRecord& record() const { return record_; }
  // What holding it costs (the workers' queues keep a budget of these).
  size_t bytes() const { return bytes_; }

 private:
  explicit CheckedRecord(const ves::v1::SessionRecord& record)
      : record_(record), bytes_(record.SpaceUsedLong()) {}

  const ves::v1::SessionRecord record_;
  const size_t bytes_;
};

// Records held for the background workers by uuid, within a byte budget: one
// over it is not held and the worker reads it back from the store. Guarded
// by its owner's mutex.
class HeldRecords {
 public:
  explicit HeldRecords(size_t budget_bytes) : budget_bytes_(budget_bytes) {}
  // Keeps `record` for `uuid` when the budget allows (a null record: nothing).
  void Hold(const std::string& uuid, std::shared_ptr<const CheckedRecord> record);
  // The record held for `uuid`, released; null when none is.
  std::shared_ptr<const CheckedRecord> Take(const std::string& uuid);

 private:
  const size_t budget_bytes_;
  size_t bytes_ = 0;
  std::map<std::string, std::shared_ptr<const CheckedRecord>> held_;
};

// Records waiting for the judge or the series worker, held in memory.
inline constexpr size_t kHeldRecordBytes = size_t{256} << 20;

}  // namespace ves::server
