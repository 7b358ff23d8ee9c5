#pragma once

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include <google/protobuf/message.h>

#include "patient_db/clock.h"
#include "patient_db/limits.h"
#include "patient_db/store.h"
#include "server/auth.h"
#include "server/lesson_judge.h"
#include "server/session_writer.h"
#include "ves/v1/services.grpc.pb.h"

// The gRPC services (callback API), one file each: cases_service.cc,
// sessions_service.cc, trainees_service.cc, admin_service.cc,
// lessons_service.cc, live_service.cc. Handlers are thin: they run the
// request pipeline of server/pipeline.h (admit, role, institution and store,
// audit), which the HTTP API (docs/web.md) runs too; streams and uploads
// acknowledged once durable run its async form (RunCallAsync), whose audit
// row is written when the call ends. docs/server.md lists who may call what.
namespace ves::server {

// The handlers' clock is the stores' (patient_db/clock.h).
using patient_db::NowUnixMs;

class AsyncCall;  // server/pipeline.h
class CheckedRecord;  // server/checked_record.h
class LiveHub;
class SessionSeries;

inline constexpr size_t kCaseChunkBytes = 1 << 20;          // 1 MiB per download chunk
inline constexpr uint64_t kMaxCaseUploadBytes = 256ull << 20;  // a bundle's limit
inline constexpr size_t kMaxAuditTextBytes = 160;              // audit target, label, institution
// A list reply stops early (with a next_page_token) past this many bytes,
// whatever its page size: no reply can outgrow the 16 MiB message limit.
inline constexpr size_t kPageReplyBudgetBytes = 8u << 20;

// What every handler needs; owned by VesServer.
struct ServiceDeps {
  patient_db::Store* store = nullptr;
  SessionWriter* writer = nullptr;
  Authenticator* auth = nullptr;
  LessonJudge* judge = nullptr;  // lesson sessions are queued here once stored (may be null)
  LiveHub* live = nullptr;       // live proctoring (may be null: no Live service)
  SessionSeries* series = nullptr;  // session pages' series, computed on upload (may be null)
};

// Recently served case bundles by hash (content-addressed, so never stale).
class BlobCache {
 public:
  explicit BlobCache(size_t budget_bytes) : budget_bytes_(budget_bytes) {}
  std::shared_ptr<const std::string> Get(const std::string& sha256_hex);
  void Put(const std::string& sha256_hex, std::shared_ptr<const std::string> bytes);

 private:
  std::mutex mutex_;
  size_t budget_bytes_;
  size_t bytes_ = 0;
  std::map<std::string, std::shared_ptr<const std::string>> blobs_;
};

class CasesService final : public ves::v1::Cases::CallbackService {
 public:
  explicit CasesService(ServiceDeps deps) : deps_(deps), blobs_(512u << 20) {}
  grpc::ServerUnaryReactor* ListCases(grpc::CallbackServerContext* ctx,
                                      const ves::v1::ListCasesRequest* request,
                                      ves::v1::ListCasesResponse* response) override;
  grpc::ServerWriteReactor<ves::v1::CaseChunk>* DownloadCase(
      grpc::CallbackServerContext* ctx, const ves::v1::DownloadCaseRequest* request) override;
  grpc::ServerReadReactor<ves::v1::UploadCaseRequest>* UploadCase(
      grpc::CallbackServerContext* ctx, ves::v1::UploadCaseResponse* response) override;

 private:
  ServiceDeps deps_;
  BlobCache blobs_;
};

class SessionsService final : public ves::v1::Sessions::CallbackService {
 public:
  explicit SessionsService(ServiceDeps deps) : deps_(deps) {}
  grpc::ServerUnaryReactor* UploadSession(grpc::CallbackServerContext* ctx,
                                          const ves::v1::UploadSessionRequest* request,
                                          ves::v1::UploadSessionResponse* response) override;

 private:
  // The trainee's institution; cached, as a trainee never changes institution.
  patient_db::StoreResult<std::string> TraineeInstitution(const std::string& trainee_id);
  // The record's case exists in its version, is visible to `institution` and
  // (when the record names one) has its payload hash.
  grpc::Status CheckRecordCase(const ves::v1::SessionRecord& record,
                               const std::string& institution);
  // After admission and the role: checks the record, then hands it to the
  // group commit; `call` ends when the batch holding it is durable.
  void Store(std::shared_ptr<AsyncCall> call, const ves::v1::UploadSessionRequest& request,
             ves::v1::UploadSessionResponse* response);

  ServiceDeps deps_;
  std::mutex mutex_;
  std::map<std::string, std::string> trainee_institution_;  // guarded by mutex_
};

class TraineesService final : public ves::v1::Trainees::CallbackService {
 public:
  explicit TraineesService(ServiceDeps deps) : deps_(deps) {}
  grpc::ServerUnaryReactor* AddTrainee(grpc::CallbackServerContext* ctx,
                                       const ves::v1::AddTraineeRequest* request,
                                       ves::v1::AddTraineeResponse* response) override;
  grpc::ServerUnaryReactor* ListTrainees(grpc::CallbackServerContext* ctx,
                                         const ves::v1::ListTraineesRequest* request,
                                         ves::v1::ListTraineesResponse* response) override;
  grpc::ServerUnaryReactor* ListSessions(grpc::CallbackServerContext* ctx,
                                         const ves::v1::ListSessionsRequest* request,
                                         ves::v1::ListSessionsResponse* response) override;
  grpc::ServerUnaryReactor* GetLearningCurve(grpc::CallbackServerContext* ctx,
                                             const ves::v1::LearningCurveRequest* request,
                                             ves::v1::LearningCurveResponse* response) override;
  grpc::ServerUnaryReactor* GetSession(grpc::CallbackServerContext* ctx,
                                       const ves::v1::GetSessionRequest* request,
                                       ves::v1::GetSessionResponse* response) override;

 private:
  ServiceDeps deps_;
};

class AdminService final : public ves::v1::Admin::CallbackService {
 public:
  explicit AdminService(ServiceDeps deps) : deps_(deps) {}
  grpc::ServerUnaryReactor* CreateToken(grpc::CallbackServerContext* ctx,
                                        const ves::v1::CreateTokenRequest* request,
                                        ves::v1::CreateTokenResponse* response) override;
  grpc::ServerUnaryReactor* ListAudit(grpc::CallbackServerContext* ctx,
                                      const ves::v1::ListAuditRequest* request,
                                      ves::v1::ListAuditResponse* response) override;
  grpc::ServerUnaryReactor* ListStations(grpc::CallbackServerContext* ctx,
                                         const ves::v1::ListStationsRequest* request,
                                         ves::v1::ListStationsResponse* response) override;

 private:
  ServiceDeps deps_;
};

// Curricula, assignments, next lesson, progress, verdicts (docs/lessons.md).
class LessonsService final : public ves::v1::Lessons::CallbackService {
 public:
  explicit LessonsService(ServiceDeps deps) : deps_(deps) {}
  grpc::ServerUnaryReactor* CreateCurriculum(grpc::CallbackServerContext* ctx,
                                             const ves::v1::CreateCurriculumRequest* request,
                                             ves::v1::CreateCurriculumResponse* response) override;
  grpc::ServerUnaryReactor* ListCurricula(grpc::CallbackServerContext* ctx,
                                          const ves::v1::ListCurriculaRequest* request,
                                          ves::v1::ListCurriculaResponse* response) override;
  grpc::ServerUnaryReactor* AssignCurriculum(grpc::CallbackServerContext* ctx,
                                             const ves::v1::AssignCurriculumRequest* request,
                                             ves::v1::AssignCurriculumResponse* response) override;
  grpc::ServerUnaryReactor* SetTraineeGroup(grpc::CallbackServerContext* ctx,
                                            const ves::v1::SetTraineeGroupRequest* request,
                                            ves::v1::SetTraineeGroupResponse* response) override;
  grpc::ServerUnaryReactor* GetNextLesson(grpc::CallbackServerContext* ctx,
                                          const ves::v1::GetNextLessonRequest* request,
                                          ves::v1::GetNextLessonResponse* response) override;
  grpc::ServerUnaryReactor* GetProgress(grpc::CallbackServerContext* ctx,
                                        const ves::v1::GetProgressRequest* request,
                                        ves::v1::GetProgressResponse* response) override;
  grpc::ServerUnaryReactor* GetLessonVerdict(grpc::CallbackServerContext* ctx,
                                             const ves::v1::GetLessonVerdictRequest* request,
                                             ves::v1::GetLessonVerdictResponse* response) override;

 private:
  ServiceDeps deps_;
};

// Helpers shared by the handlers.
grpc::Status ToGrpcStatus(const patient_db::StoreStatus& status);
grpc::Status ToGrpcStatus(const AuthStatus& status);
patient_db::AuditRow MakeAudit(const Principal& who, const std::string& action,
                               const std::string& target, const grpc::Status& result);
const char* StatusCodeName(grpc::StatusCode code);
ves::v1::Role ToProtoRole(StoreRole role);
// List replies are pages (docs/server.md, "Limits"): the size asked for, 0
// meaning `default_size`, cut to patient_db::kMaxPageSize.
int PageSizeOf(uint32_t requested, int default_size = patient_db::kDefaultPageSize);
// A page token names the listing and the sort key of the last row sent:
// "<listing>:<number>:<text>". Read fills `page` (limit untouched);
// INVALID_ARGUMENT naming page_token when it is not a token of that listing.
std::string MakePageToken(const std::string& listing, int64_t number, const std::string& text);
grpc::Status ReadPageToken(const std::string& token, const std::string& listing,
                           patient_db::ListPage* page);
// What an accepted upload tells of its station (table stations): seen now,
// the record's version, and its StationHealth when it has one.
patient_db::StationRow StationReportOf(const CheckedRecord& record,
                                       const std::string& institution, int64_t now_unix_ms);

}  // namespace ves::server
