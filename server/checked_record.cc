#include "server/checked_record.h"

#include "server/session_check.h"

namespace ves::server {

std::shared_ptr<const CheckedRecord> CheckedRecord::Check(const ves::v1::SessionRecord& record,
                                                          int64_t now_unix_ms,
                                                          std::string* problem) {
  *problem = CheckSessionRecord(record, now_unix_ms);
  if (!problem->empty()) return nullptr;
  return std::shared_ptr<const CheckedRecord>(new CheckedRecord(record));
}

void HeldRecords::Hold(const std::string& uuid, std::shared_ptr<const CheckedRecord> record) {
  if (record == nullptr || held_.count(uuid) > 0) return;
  if (bytes_ + record->bytes() > budget_bytes_) return;
  bytes_ += record->bytes();
  held_.emplace(uuid, std::move(record));
}

std::shared_ptr<const CheckedRecord> HeldRecords::Take(const std::string& uuid) {
  auto it = held_.find(uuid);
  if (it == held_.end()) return nullptr;
  std::shared_ptr<const CheckedRecord> record = std::move(it->second);
  held_.erase(it);
  bytes_ -= record->bytes();
  return record;
}

}  // namespace ves::server
