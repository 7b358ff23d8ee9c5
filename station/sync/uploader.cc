#include "station/sync/uploader.h"

#include <algorithm>
#include <cmath>

namespace ves::sync {

std::chrono::milliseconds CalcBackoff(const BackoffPolicy& policy, int failures) {
  if (failures <= 0) return std::chrono::milliseconds(0);
  const double scaled = static_cast<double>(policy.initial.count()) *
                        std::pow(policy.factor, static_cast<double>(failures - 1));
  const double capped = std::min(scaled, static_cast<double>(policy.max.count()));
  return std::chrono::milliseconds(static_cast<int64_t>(capped));
}

DrainResult DrainOutbox(Outbox& outbox, SessionUploader& uploader,
                        const std::function<int64_t()>& now_unix_ms) {
  DrainResult result;
  for (const PendingUpload& pending : outbox.Pending()) {
    const UploadResult upload = uploader.Upload(pending.record);
    switch (upload.verdict) {
      case UploadVerdict::kAcknowledged:
        outbox.MarkAcknowledged(pending.uuid, now_unix_ms());
        ++result.acknowledged;
        break;
      case UploadVerdict::kRejected:
        outbox.MarkRejected(pending.uuid, upload.message);
        ++result.rejected;
        break;
      case UploadVerdict::kRetryLater:
        outbox.RecordFailure(pending.uuid, upload.message);
        result.stopped_on_retry = true;
        return result;
    }
  }
  return result;
}

}  // namespace ves::sync
