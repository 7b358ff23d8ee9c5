#pragma once

#include <google/protobuf/message.h>
#include <grpcpp/grpcpp.h>

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "server/services.h"
#include "server/web_api.h"

// The supervisors' workflow in the browser (docs/web.md, "Workflow"): trainees
// put in groups, curricula assigned, notes written on sessions and sessions
// signed off. Every write is a supervisor's or an admin's, carries the
// browser's CSRF token and writes an audit row.
namespace ves::server {

// Bounds of what the workflow's bodies carry (a 400 names the field).
inline constexpr size_t kMaxSignOffLabelBytes = 160;  // the signer's label as stored

// Serves (docs/web.md, "Workflow"):
//   GET  curricula                  the institution's curricula (id, title, lessons)
//   POST assignments                {"curriculum_id", "trainee_id" | "group"}
//   POST trainees/{id}/group        {"group"} ("" takes the trainee out of any group)
//   GET  sessions/{uuid}/notes      the session's notes and its sign-off
//   POST sessions/{uuid}/notes      {"text"}
//   POST sessions/{uuid}/sign-off   {}
//   GET  trainees/{id}/sign-offs    the sign-offs of the trainee's sessions
// `admit` admits a request message (bounds, token, CSRF) and fills `who`.
// nullopt: not one of these routes.
std::optional<HttpReply> WorkflowRoute(
    const ServiceDeps& deps, const HttpRequest& request, const std::vector<std::string>& path,
    const std::function<grpc::Status(const google::protobuf::Message&)>& admit,
    const Principal& who);

}  // namespace ves::server
