#pragma once

#include <cstddef>

// The supervisors' workflow in the browser (docs/web.md, "Workflow"): trainees
// put in groups, curricula assigned, notes written on sessions and sessions
// signed off. Every write is a supervisor's or an admin's, carries the
// browser's CSRF token and writes an audit row. The routes are
// WorkflowRoutes() (server/web_routes.h):
//   GET  curricula                  the institution's curricula (id, title, lessons)
//   POST assignments                {"curriculum_id", "trainee_id" | "group"}
//   POST trainees/{id}/group        {"group"} ("" takes the trainee out of any group)
//   GET  sessions/{uuid}/notes      the session's notes and its sign-off
//   POST sessions/{uuid}/notes      {"text"}
//   POST sessions/{uuid}/sign-off   {}
//   GET  trainees/{id}/sign-offs    the sign-offs of the trainee's sessions
namespace ves::server {

// Bounds of what the workflow's bodies carry (a 400 names the field).
inline constexpr size_t kMaxSignOffLabelBytes = 160;  // the signer's label as stored

}  // namespace ves::server
