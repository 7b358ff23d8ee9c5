// The Sessions service: UploadSession, a record checked, stored through the
// group commit and acknowledged once durable (docs/server.md).
#include <algorithm>

#include "patient_db/limits.h"
#include "server/pipeline.h"
#include "server/services.h"
#include "server/checked_record.h"
#include "server/session_check.h"
#include "server/session_series.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using patient_db::StoreCode;
using patient_db::StoreRole;

patient_db::StationRow StationReportOf(const CheckedRecord& checked,
                                       const std::string& institution, int64_t now_unix_ms) {
  const ves::v1::SessionRecord& rec = checked.record();
  patient_db::StationRow r;
  r.institution = institution;
  r.station_id = rec.station_id();
  r.last_seen_unix_ms = now_unix_ms;
  r.software_version = rec.software_version();
  r.version_session_end_unix_ms = rec.end_unix_ms();
  if (rec.has_station_health()) {
    const ves::v1::StationHealth& h = rec.station_health();
    r.has_health = true;
    r.health_session_uuid = rec.uuid();
    r.health_session_end_unix_ms = rec.end_unix_ms();
    r.health = {
        h.device(),          h.loop_cycles(),        h.loop_cycle_p99_us(),   h.loop_budget_us(),
        h.loop_overruns(),   h.hard_faults(), h.transient_faults(),        h.can_bus_errors(),
        h.can_lost_frames(), h.can_send_failures(),  h.can_malformed_frames()};
  }
  return r;
}

namespace {

// The stored row of a checked record: its columns, its deterministic bytes
// and their hash, and the station's report merged in the same transaction.
patient_db::SessionRow SessionRowOf(const CheckedRecord& checked,
                                    const std::string& institution) {
  const ves::v1::SessionRecord& rec = checked.record();
  patient_db::SessionRow row;
  row.uuid = rec.uuid();
  row.trainee_id = rec.trainee_id();
  row.institution = institution;
  row.case_id = rec.case_id();
  row.case_version = rec.case_version();
  row.station_id = rec.station_id();
  row.start_unix_ms = rec.start_unix_ms();
  row.end_unix_ms = rec.end_unix_ms();
  row.outcome = rec.outcome();
  row.completed = rec.metrics().completed();
  row.time_to_cecum_s = rec.metrics().time_to_cecum_s();
  row.pain_s = rec.metrics().pain_s();
  row.score = rec.score();
  row.operator_kind = rec.operator_kind();
  row.max_tip_arc_m = rec.metrics().max_tip_arc_m();
  row.loop_s = rec.metrics().loop_s();
  row.xray_s = rec.metrics().xray_s();
  row.body = patient_db::SerializeDeterministic(rec);
  row.body_sha256_hex = Sha256Hex(row.body);
  row.stored_unix_ms = NowUnixMs();
  row.lesson_id = rec.lesson_id();  // queued for the lesson judge in the same transaction
  row.station = StationReportOf(checked, institution, row.stored_unix_ms);
  return row;
}

}  // namespace

patient_db::StoreResult<std::string> SessionsService::TraineeInstitution(
    const std::string& trainee_id) {
  {
    std::lock_guard lock(mutex_);
    auto it = trainee_institution_.find(trainee_id);
    if (it != trainee_institution_.end()) return it->second;
  }
  auto trainee = deps_.store->GetTrainee(trainee_id);
  if (!trainee.ok()) return trainee.status;
  std::lock_guard lock(mutex_);
  trainee_institution_[trainee_id] = trainee.value.institution;
  return trainee.value.institution;
}

Status SessionsService::CheckRecordCase(const ves::v1::SessionRecord& rec,
                                        const std::string& institution) {
  const std::string named = "record.case_id = '" + rec.case_id() + "' version " +
                            std::to_string(rec.case_version());
  auto row = deps_.store->GetCase(rec.case_id(), rec.case_version());
  if (!row.ok() && row.status.code != StoreCode::kNotFound) return ToGrpcStatus(row.status);
  const bool visible = row.ok() && (row.value.institution == institution ||
                                    std::find(row.value.shared_with.begin(),
                                              row.value.shared_with.end(),
                                              institution) != row.value.shared_with.end());
  if (!visible) {
    return Status(StatusCode::FAILED_PRECONDITION,
                  named + ": no such case visible to institution '" + institution + "'");
  }
  if (!rec.case_sha256_hex().empty() && rec.case_sha256_hex() != row.value.payload_sha256_hex) {
    return Status(StatusCode::INVALID_ARGUMENT,
                  "record.case_sha256_hex = " + rec.case_sha256_hex() + ": " + named +
                      " has payload sha256 " + row.value.payload_sha256_hex);
  }
  return Status::OK;
}

grpc::ServerUnaryReactor* SessionsService::UploadSession(
    grpc::CallbackServerContext* ctx, const ves::v1::UploadSessionRequest* request,
    ves::v1::UploadSessionResponse* response) {
  auto* reactor = ctx->DefaultReactor();
  Principal who;
  const Status admitted = AdmitRequest(deps_, AuthorizationOf(ctx), *request, &who);
  if (!admitted.ok()) {
    reactor->Finish(admitted);
    return reactor;
  }
  // Audited when it ends: a refusal here, or with the session in its
  // group-commit transaction.
  static const CallSpec spec{
      "session.upload", {StoreRole::kAdmin, StoreRole::kStation}, "upload sessions"};
  const auto body = [&](std::shared_ptr<AsyncCall> call) {
    call->set_finisher([reactor](const Status& s) { reactor->Finish(s); });
    Store(std::move(call), *request, response);
  };
  const Status refused = RunCallAsync(deps_, who, spec, request->record().uuid(), body);
  if (!refused.ok()) reactor->Finish(refused);
  return reactor;
}

void SessionsService::Store(std::shared_ptr<AsyncCall> call,
                            const ves::v1::UploadSessionRequest& request,
                            ves::v1::UploadSessionResponse* response) {
  const Principal& who = call->who();
  if (!request.has_record()) {
    return call->Finish(Status(StatusCode::INVALID_ARGUMENT, "record missing"));
  }
  // Checked once, here; the row, the judge and the series worker share it.
  std::string problem;
  std::shared_ptr<const CheckedRecord> checked =
      CheckedRecord::Check(request.record(), NowUnixMs(), &problem);
  if (checked == nullptr) return call->Finish(Status(StatusCode::INVALID_ARGUMENT, problem));
  const ves::v1::SessionRecord& rec = checked->record();
  auto institution = TraineeInstitution(rec.trainee_id());
  // Absent, or of another institution: the same answer (no existence leak).
  if (institution.status.code == StoreCode::kNotFound ||
      (institution.ok() && !RequireInstitution(who, institution.value, "upload").ok())) {
    return call->Finish(Status(StatusCode::FAILED_PRECONDITION,
                               "record.trainee_id = '" + rec.trainee_id() + "': no such trainee in "
                               "institution '" + who.institution + "'"));
  }
  if (!institution.ok()) return call->Finish(ToGrpcStatus(institution.status));
  // The case must exist in the version named and be visible to the trainee's
  // institution; its payload hash, when the record gives one, must match.
  const Status case_status = CheckRecordCase(rec, institution.value);
  if (!case_status.ok()) return call->Finish(case_status);

  patient_db::SessionRow row = SessionRowOf(*checked, institution.value);
  const std::string body_sha = row.body_sha256_hex;
  LessonJudge* judge = rec.lesson_id().empty() ? nullptr : deps_.judge;
  SessionSeries* series = deps_.series;
  // Acknowledged from the writer thread once the batch holding it is durable.
  deps_.writer->Submit(
      std::move(row), call->TakeAuditRow(),
      [call, checked, response, body_sha, judge, series, institution = institution.value](
          const patient_db::StoreStatus& status, const patient_db::SessionPutResult& result) {
        if (!status.ok()) return call->Finish(ToGrpcStatus(status));
        if (result.outcome == patient_db::SessionPut::kConflict &&
            result.first.institution != institution) {
          // Another institution's session: nothing about it is told.
          return call->Finish(Status(StatusCode::ALREADY_EXISTS,
                                     "session " + result.first.uuid +
                                         ": this uuid is taken; a record needs a new uuid"));
        }
        if (result.outcome == patient_db::SessionPut::kConflict) {
          return call->Finish(Status(StatusCode::ALREADY_EXISTS,
                                     "session " + result.first.uuid +
                                         " was already uploaded with other content (stored body "
                                         "sha256 " + result.first.body_sha256_hex + ", this one " +
                                         body_sha + "); a changed record needs a new uuid"));
        }
        if (judge && result.outcome == patient_db::SessionPut::kStored) {
          judge->Enqueue(result.first.uuid, checked);  // durable now; judged off the gRPC threads
        }
        // The session page's plots, computed once: a lesson session's by the
        // judge's replay, a free run's by the series worker.
        if (series && !judge && result.outcome == patient_db::SessionPut::kStored) {
          series->Enqueue(result.first.uuid, checked);
        }
        response->set_uuid(result.first.uuid);
        response->set_body_sha256_hex(result.first.body_sha256_hex);
        response->set_stored_unix_ms(result.first.stored_unix_ms);
        call->Finish(Status::OK);
      });
}

}  // namespace ves::server
