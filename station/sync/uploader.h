#pragma once

#include <chrono>
#include <functional>
#include <string>

#include "station/sync/outbox.h"

namespace ves::sync {

enum class UploadVerdict {
  kAcknowledged,  // durable on the server: leave the pending set
  kRetryLater,    // server unreachable, deadline, overloaded: try again later
  kRejected,      // server refused this record for good: stop retrying, keep it
};

struct UploadResult {
  UploadVerdict verdict{UploadVerdict::kRetryLater};
  std::string message;
};

// Sends one record to the server. The gRPC implementation lives beside the
// client; tests use fakes. Must be idempotent per record UUID on the server.
class SessionUploader {
 public:
  virtual ~SessionUploader() = default;
  virtual UploadResult Upload(const ves::v1::SessionRecord& record) = 0;
};

struct BackoffPolicy {
  std::chrono::milliseconds initial{500};
  std::chrono::milliseconds max{60'000};
  double factor{2.0};
};

// Delay before retry number `failures` (1 = after the first failure):
// initial * factor^(failures-1), capped at max.
std::chrono::milliseconds CalcBackoff(const BackoffPolicy& policy, int failures);

struct DrainResult {
  int acknowledged{0};
  int rejected{0};
  bool stopped_on_retry{false};  // a RetryLater ended this pass early
  bool operator==(const DrainResult&) const = default;
};

// One pass over the outbox, oldest first. Stops at the first RetryLater (the
// server is unreachable: later records would fail the same way). The
// station's upload (ves::station::DeliverOutbox) runs a bounded number of
// passes, CalcBackoff apart.
DrainResult DrainOutbox(Outbox& outbox, SessionUploader& uploader,
                        const std::function<int64_t()>& now_unix_ms);

}  // namespace ves::sync
