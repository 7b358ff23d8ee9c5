#include "station/sync/lesson_client.h"

#include "ves/v1/services.grpc.pb.h"

namespace ves::sync {
namespace {

void Prepare(const ServerEndpoint& endpoint, grpc::ClientContext* context) {
  context->set_deadline(std::chrono::system_clock::now() + endpoint.deadline);
  context->AddMetadata("authorization", "Bearer " + endpoint.token);
}

LessonCallError ErrorOf(const std::string& what, const grpc::Status& status) {
  return LessonCallError(status.error_code(), what + ": status " +
                                                  std::to_string(status.error_code()) + ": " +
                                                  status.error_message());
}

}  // namespace

ves::v1::GetNextLessonResponse FetchNextLesson(const ServerEndpoint& endpoint,
                                               const std::string& trainee_id) {
  auto stub = ves::v1::Lessons::NewStub(MakeChannel(endpoint));
  grpc::ClientContext context;
  Prepare(endpoint, &context);
  ves::v1::GetNextLessonRequest request;
  request.set_trainee_id(trainee_id);
  ves::v1::GetNextLessonResponse response;
  const grpc::Status status = stub->GetNextLesson(&context, request, &response);
  if (!status.ok()) throw ErrorOf("next lesson of '" + trainee_id + "'", status);
  return response;
}

std::optional<ves::v1::LessonVerdict> FetchLessonVerdict(const ServerEndpoint& endpoint,
                                                         const std::string& session_uuid) {
  auto stub = ves::v1::Lessons::NewStub(MakeChannel(endpoint));
  grpc::ClientContext context;
  Prepare(endpoint, &context);
  ves::v1::GetLessonVerdictRequest request;
  request.set_session_uuid(session_uuid);
  ves::v1::GetLessonVerdictResponse response;
  const grpc::Status status = stub->GetLessonVerdict(&context, request, &response);
  if (!status.ok()) throw ErrorOf("verdict of session " + session_uuid, status);
  if (!response.judged()) return std::nullopt;
  return response.verdict();
}

}  // namespace ves::sync
