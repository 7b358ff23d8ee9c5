// Live.StreamSession (docs/web.md, "Live proctoring"): through the pipeline's
// async form (token, role station or admin; each frame bounded by the bounds
// stage), then the first frame names the session, whose trainee must be of
// the caller's institution; one audit row per stream, written at its first
// frame (or at its end when no frame began it). Frames go to the LiveHub; a
// bad frame ends the stream with INVALID_ARGUMENT naming the field.
#include "server/live_service.h"

#include <utility>

#include "server/live_hub.h"
#include "server/pipeline.h"
#include "server/services.h"

namespace ves::server {
namespace {

using grpc::Status;
using grpc::StatusCode;
using patient_db::StoreCode;

class ErrorReactor final : public grpc::ServerReadReactor<v1::LiveFrame> {
 public:
  explicit ErrorReactor(const Status& status) { Finish(status); }
  void OnDone() override { delete this; }
};

class LiveReactor final : public grpc::ServerReadReactor<v1::LiveFrame> {
 public:
  LiveReactor(ServiceDeps deps, std::shared_ptr<AsyncCall> call, v1::LiveStreamSummary* summary)
      : deps_(deps), call_(std::move(call)), who_(call_->who()), summary_(summary) {
    call_->set_finisher([this](const Status& status) { Finish(status); });
    StartRead(&frame_);
  }
  void OnReadDone(bool ok) override {
    if (!ok) {  // the station closed its side (or went away)
      summary_->set_frames_received(received_);
      Close(Status::OK);
      return;
    }
    const Status bounds = call_->AdmitMessage(frame_, "frame");
    const std::string why = bounds.ok() ? CheckLiveFrame(frame_, !begun_) : bounds.error_message();
    if (!why.empty()) {
      Close(Status(StatusCode::INVALID_ARGUMENT, why));
      return;
    }
    if (!begun_) {
      const Status s = Begin();
      call_->set_target(frame_.session_uuid());
      call_->Audit(s);
      if (!s.ok()) {
        Close(s);
        return;
      }
    } else if (!frame_.session_uuid().empty() && frame_.session_uuid() != uuid_) {
      Close(Status(StatusCode::INVALID_ARGUMENT,
                   "frame.session_uuid = '" + patient_db::PrintableExcerpt(frame_.session_uuid()) +
                       "': a stream carries one session (" + uuid_ + ")"));
      return;
    }
    deps_.live->Publish(uuid_, frame_);
    ++received_;
    StartRead(&frame_);
  }
  void OnDone() override {
    if (begun_) deps_.live->End(uuid_);  // a stream cancelled before any Close
    delete this;
  }

 private:
  // The hub forgets the session before the station hears the stream's end:
  // OnDone runs only after the status has reached the client, so a viewer's
  // live list could still show a stream that was already refused or closed.
  void Close(const Status& status) {
    if (begun_) {
      deps_.live->End(uuid_);
      begun_ = false;
    }
    call_->Finish(status);
  }
  Status Begin() {
    auto trainee = deps_.store->GetTrainee(frame_.trainee_id());
    if (!trainee.ok() && trainee.status.code != StoreCode::kNotFound) {
      return ToGrpcStatus(trainee.status);
    }
    // Absent, or of another institution: the same answer (no existence leak).
    if (!trainee.ok() || !RequireInstitution(who_, trainee.value.institution, "stream").ok()) {
      return Status(StatusCode::FAILED_PRECONDITION, "frame.trainee_id = '" + frame_.trainee_id() +
                                                         "': no such trainee in institution '" +
                                                         who_.institution + "'");
    }
    LiveSessionInfo info;
    info.session_uuid = frame_.session_uuid();
    info.institution = trainee.value.institution;
    info.trainee_id = frame_.trainee_id();
    info.case_id = frame_.case_id();
    info.case_version = frame_.case_version();
    info.station = who_.label;
    std::string why;
    if (!deps_.live->Begin(info, &why)) return Status(StatusCode::RESOURCE_EXHAUSTED, why);
    uuid_ = info.session_uuid;
    begun_ = true;
    return Status::OK;
  }
  ServiceDeps deps_;
  std::shared_ptr<AsyncCall> call_;
  const Principal& who_;
  v1::LiveStreamSummary* summary_;
  v1::LiveFrame frame_;
  bool begun_ = false;
  std::string uuid_;
  uint64_t received_ = 0;
};

}  // namespace

grpc::ServerReadReactor<v1::LiveFrame>* LiveService::StreamSession(grpc::CallbackServerContext* ctx,
                                                                   v1::LiveStreamSummary* summary) {
  static const CallSpec spec{
      "live.stream", {StoreRole::kAdmin, StoreRole::kStation}, "stream live sessions"};
  return ServeAsync<grpc::ServerReadReactor<v1::LiveFrame>>(
      ctx, deps_, spec, "?",
      [&](std::shared_ptr<AsyncCall> call) -> grpc::ServerReadReactor<v1::LiveFrame>* {
        if (deps_.live == nullptr) {
          const Status none(StatusCode::UNIMPLEMENTED, "no live hub");
          call->Finish(none);
          return new ErrorReactor(none);
        }
        return new LiveReactor(deps_, std::move(call), summary);
      },
      [](const Status& status) { return new ErrorReactor(status); });
}

}  // namespace ves::server
