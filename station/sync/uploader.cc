#include "station/sync/uploader.h"

#include <algorithm>
#include <cmath>

#include <boost/asio/post.hpp>

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

OutboxSync::OutboxSync(boost::asio::io_context& io, Outbox& outbox, SessionUploader& uploader,
                       BackoffPolicy policy, std::chrono::milliseconds idle_poll)
    : io_(io),
      outbox_(outbox),
      uploader_(uploader),
      policy_(policy),
      idle_poll_(idle_poll),
      timer_(io) {}

void OutboxSync::Start() {
  stopped_ = false;
  boost::asio::post(io_, [this] { RunPass(); });
}

void OutboxSync::Notify() {
  // Cancelling the wait runs the pass now (the handler sees operation_aborted).
  boost::asio::post(io_, [this] { timer_.cancel(); });
}

void OutboxSync::Stop() {
  boost::asio::post(io_, [this] {
    stopped_ = true;
    timer_.cancel();
  });
}

void OutboxSync::RunPass() {
  if (stopped_) return;
  const DrainResult result = DrainOutbox(outbox_, uploader_, [] {
    return std::chrono::duration_cast<std::chrono::milliseconds>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
  });
  failures_ = result.stopped_on_retry ? failures_ + 1 : 0;
  ScheduleAfter(failures_ > 0 ? CalcBackoff(policy_, failures_) : idle_poll_);
}

void OutboxSync::ScheduleAfter(std::chrono::milliseconds delay) {
  timer_.expires_after(delay);
  timer_.async_wait([this](const boost::system::error_code&) { RunPass(); });
}

}  // namespace ves::sync
