#include "station/app/run_sync.h"

#include <chrono>
#include <ostream>
#include <thread>

#include "patient_db/case_format.h"
#include "station/sync/uploader.h"

namespace ves::station {

int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

namespace {

// Remembers the last transient failure so the caller can say why a session
// stayed pending.
class ReportingUploader : public sync::SessionUploader {
 public:
  explicit ReportingUploader(sync::ServerEndpoint endpoint) : inner_(std::move(endpoint)) {}
  sync::UploadResult Upload(const ves::v1::SessionRecord& record) override {
    sync::UploadResult result = inner_.Upload(record);
    if (result.verdict != sync::UploadVerdict::kAcknowledged) last_error_ = result.message;
    return result;
  }
  const std::string& last_error() const { return last_error_; }

 private:
  sync::GrpcSessionUploader inner_;
  std::string last_error_;
};

}  // namespace

std::optional<ObtainedCase> ObtainCase(const std::optional<sync::ServerEndpoint>& endpoint,
                                       const std::string& case_id, sync::CaseCache& cache,
                                       std::ostream& log) {
  std::optional<sync::CachedCase> entry;
  bool from_server = false;
  if (endpoint) {
    try {
      entry = sync::DownloadCaseToCache(*endpoint, case_id, cache);
      from_server = true;
    } catch (const std::exception& error) {
      log << "ves-station run: could not get case '" << case_id << "' from "
          << endpoint->address << " (" << error.what() << "); trying the offline cache\n";
    }
  }
  if (!entry) entry = cache.FindLatest(case_id);
  if (!entry) return std::nullopt;
  ObtainedCase obtained;
  obtained.entry = *entry;
  obtained.colon_case = cache.Load(entry->sha256_hex);  // verified on read
  obtained.from_server = from_server;
  return obtained;
}

bool IsCaseFileArgument(const std::string& arg) {
  return patient_db::CaseFileKindOf(arg).has_value();
}

ObtainedCase ObtainCaseFile(const std::filesystem::path& path, sync::CaseCache& cache,
                            const patient_db::ImportOptions& import) {
  ObtainedCase obtained;
  obtained.colon_case = patient_db::LoadCaseFile(path, import);
  obtained.entry = cache.Put(obtained.colon_case);
  return obtained;
}

DeliveryReport DeliverOutbox(const sync::ServerEndpoint& endpoint, sync::Outbox& outbox,
                             int attempts) {
  DeliveryReport report;
  ReportingUploader uploader(endpoint);
  const sync::BackoffPolicy policy;
  for (int attempt = 1; attempt <= attempts; ++attempt) {
    const sync::DrainResult pass = sync::DrainOutbox(outbox, uploader, NowUnixMs);
    report.acknowledged += pass.acknowledged;
    report.rejected += pass.rejected;
    if (!pass.stopped_on_retry) break;
    if (attempt < attempts) std::this_thread::sleep_for(sync::CalcBackoff(policy, attempt));
  }
  report.still_pending = outbox.PendingCount();
  if (report.still_pending > 0 || report.rejected > 0) report.last_error = uploader.last_error();
  return report;
}

}  // namespace ves::station
