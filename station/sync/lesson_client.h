#pragma once

#include <optional>
#include <stdexcept>
#include <string>

#include "station/sync/server_client.h"
#include "ves/v1/lesson.pb.h"
#include "ves/v1/services.pb.h"

// The station's calls to the Lessons service (docs/lessons.md), with the
// endpoint's deadline and token.
namespace ves::sync {

// A call that did not succeed; `code` says whether the server was unreachable
// (UNAVAILABLE, DEADLINE_EXCEEDED) or refused.
class LessonCallError : public std::runtime_error {
 public:
  LessonCallError(grpc::StatusCode code, const std::string& message)
      : std::runtime_error(message), code_(code) {}
  grpc::StatusCode code() const { return code_; }

 private:
  grpc::StatusCode code_;
};

// Lessons.GetNextLesson for the trainee. Throws LessonCallError.
ves::v1::GetNextLessonResponse FetchNextLesson(const ServerEndpoint& endpoint,
                                               const std::string& trainee_id);

// Lessons.GetLessonVerdict: the verdict, or nullopt while the server has not
// judged the session yet. Throws LessonCallError.
std::optional<ves::v1::LessonVerdict> FetchLessonVerdict(const ServerEndpoint& endpoint,
                                                         const std::string& session_uuid);

}  // namespace ves::sync
