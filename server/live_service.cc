// Live.StreamSession (docs/web.md, "Live proctoring"): admitted like an
// upload (bounds, token, role station or admin), then the first frame names
// the session, whose trainee must be of the caller's institution; one audit
// row per stream start. Frames go to the LiveHub; a bad frame ends the
// stream with INVALID_ARGUMENT naming the field.
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
  LiveReactor(ServiceDeps deps, Principal who, v1::LiveStreamSummary* summary)
      : deps_(deps), who_(std::move(who)), summary_(summary) {
    StartRead(&frame_);
  }
  void OnReadDone(bool ok) override {
    if (!ok) {  // the station closed its side (or went away)
      summary_->set_frames_received(received_);
      Close(Status::OK);
      return;
    }
    const std::string why = CheckLiveFrame(frame_, !begun_);
    if (!why.empty()) {
      if (!begun_) Audit("?", Status(StatusCode::INVALID_ARGUMENT, why));
      Close(Status(StatusCode::INVALID_ARGUMENT, why));
      return;
    }
    if (!begun_) {
      const Status s = Begin();
      Audit(frame_.session_uuid(), s);
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
    Finish(status);
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
  void Audit(const std::string& target, const Status& s) {
    deps_.writer->SubmitAudit(MakeAudit(who_, "live.stream", target, s));
  }

  ServiceDeps deps_;
  Principal who_;
  v1::LiveStreamSummary* summary_;
  v1::LiveFrame frame_;
  bool begun_ = false;
  std::string uuid_;
  uint64_t received_ = 0;
};

}  // namespace

grpc::ServerReadReactor<v1::LiveFrame>* LiveService::StreamSession(grpc::CallbackServerContext* ctx,
                                                                   v1::LiveStreamSummary* summary) {
  Principal who;
  const Status admitted = AdmitRequest(deps_, AuthorizationOf(ctx), v1::LiveFrame(), &who);
  if (!admitted.ok()) return new ErrorReactor(admitted);
  const AuthStatus a =
      RequireRole(who, {StoreRole::kAdmin, StoreRole::kStation}, "stream live sessions");
  if (!a.ok()) {
    deps_.writer->SubmitAudit(MakeAudit(who, "live.stream", "?", ToGrpcStatus(a)));
    return new ErrorReactor(ToGrpcStatus(a));
  }
  if (deps_.live == nullptr)
    return new ErrorReactor(Status(StatusCode::UNIMPLEMENTED, "no live hub"));
  return new LiveReactor(deps_, std::move(who), summary);
}

}  // namespace ves::server
