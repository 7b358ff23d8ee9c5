#include "server/web_workflow.h"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "patient_db/limits.h"
#include "server/pipeline.h"
#include "server/web_reply.h"
#include "server/web_routes.h"
#include "ves/v1/services.pb.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using nlohmann::json;

namespace {

// The body as an object of string fields, each one of `allowed`; false with
// a 400 naming what is wrong. Absent fields are absent from *fields.
bool ReadBody(const std::string& body, const std::vector<std::string>& allowed,
              std::map<std::string, std::string>* fields, HttpReply* error) {
  const json j = json::parse(body.empty() ? "{}" : body, nullptr, false);
  if (!j.is_object()) {
    *error = Error(400, "INVALID_ARGUMENT", "body: must be a JSON object");
    return false;
  }
  for (const auto& [key, value] : j.items()) {
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      *error = Error(400, "INVALID_ARGUMENT",
                     "body: unknown field '" + patient_db::PrintableExcerpt(key, 40) + "'");
      return false;
    }
    if (!value.is_string()) {
      *error = Error(400, "INVALID_ARGUMENT", key + ": must be a string");
      return false;
    }
    (*fields)[key] = value.get<std::string>();
  }
  return true;
}

// An id field: 1..kMaxIdBytes printable characters (empty allowed when
// `may_be_empty`); false with a 400 naming it.
bool CheckId(const std::string& name, const std::string& value, bool may_be_empty,
             HttpReply* error) {
  if ((may_be_empty && value.empty()) || patient_db::IsPrintableId(value)) return true;
  *error = Error(400, "INVALID_ARGUMENT",
                 name + " = '" + patient_db::PrintableExcerpt(value, 40) + "': must be 1.." +
                     std::to_string(patient_db::kMaxIdBytes) + " printable characters");
  return false;
}

// The stored session, if `who` may read its trainee's records; another
// institution's session answers as an absent one. The row without its body.
Status ReadableSession(const ServiceDeps& deps, const Principal& who, const std::string& uuid,
                       const std::string& what, patient_db::SessionRow* session) {
  const Status hidden(StatusCode::NOT_FOUND, "no session '" + uuid + "'");
  auto row = deps.store->GetSession(uuid);
  if (row.status.code == patient_db::StoreCode::kNotFound) return hidden;
  if (!row.ok()) return ToGrpcStatus(row.status);
  auto trainee = deps.store->GetTrainee(row.value.trainee_id);
  if (!trainee.ok()) return ToGrpcStatus(trainee.status);
  if (!RequireTraineeReader(who, trainee.value, what).ok()) return hidden;
  *session = std::move(row.value);
  session->body.clear();
  return Status::OK;
}

json SignOffJson(const patient_db::SessionSignOffRow& s) {
  return {{"session_uuid", s.session_uuid},
          {"signed_by", s.signed_by},
          {"signed_by_label", s.signed_by_label},
          {"signed_unix_ms", s.signed_unix_ms}};
}

json NoteJson(const patient_db::SessionNoteRow& n) {
  return {{"note_id", n.note_id},
          {"author", n.author},
          {"author_label", n.author_label},
          {"written_unix_ms", n.written_unix_ms},
          {"text", n.text}};
}

bool MayWrite(const Principal& who) {
  return who.role == StoreRole::kAdmin || who.role == StoreRole::kSupervisor;
}

// GET curricula: what an assignment form offers.
HttpReply ListCurricula(WebCall& call) {
  v1::ListCurriculaRequest req;
  req.set_page_size(100);
  v1::ListCurriculaResponse resp;
  if (auto refused = AdmitAndCall(call, req, &ListCurriculaCall, &resp)) return *refused;
  json out = json::array();
  for (const auto& c : resp.curricula()) {
    out.push_back(
        {{"curriculum_id", c.curriculum_id()}, {"title", c.title()}, {"lessons", c.lessons_size()}});
  }
  return JsonReply(200, {{"curricula", out}, {"next_page_token", resp.next_page_token()}});
}

// POST assignments: a curriculum to a trainee or to a group (Lessons.AssignCurriculum).
HttpReply AssignCurriculum(WebCall& call) {
  HttpReply bad;
  std::map<std::string, std::string> body;
  if (!ReadBody(call.request.body, {"curriculum_id", "trainee_id", "group"}, &body, &bad)) {
    return bad;
  }
  if (!CheckId("curriculum_id", body["curriculum_id"], false, &bad)) return bad;
  const bool to_group = body.count("group") > 0;
  if (to_group == (body.count("trainee_id") > 0)) {
    return Error(400, "INVALID_ARGUMENT", "body: give exactly one of trainee_id and group");
  }
  const std::string assignee_field = to_group ? "group" : "trainee_id";
  if (!CheckId(assignee_field, body[assignee_field], false, &bad)) return bad;
  v1::AssignCurriculumRequest req;
  req.set_curriculum_id(body["curriculum_id"]);
  if (to_group) {
    req.set_group(body["group"]);
  } else {
    req.set_trainee_id(body["trainee_id"]);
  }
  v1::AssignCurriculumResponse resp;
  if (auto refused = AdmitAndCall(call, req, &AssignCurriculumCall, &resp)) return *refused;
  return JsonReply(200, {{"curriculum_id", req.curriculum_id()},
                         {assignee_field, body[assignee_field]},
                         {"trainee_ids", std::vector<std::string>(resp.trainee_ids().begin(),
                                                                  resp.trainee_ids().end())}});
}

// POST trainees/{id}/group: the trainee's one group (Lessons.SetTraineeGroup).
HttpReply SetTraineeGroup(WebCall& call) {
  HttpReply bad;
  std::map<std::string, std::string> body;
  if (!ReadBody(call.request.body, {"group"}, &body, &bad)) return bad;
  if (body.count("group") == 0) {
    return Error(400, "INVALID_ARGUMENT", "group: missing (\"\" takes the trainee out)");
  }
  if (!CheckId("group", body["group"], true, &bad)) return bad;
  v1::SetTraineeGroupRequest req;
  req.set_trainee_id(call.Param("id"));
  req.set_group(body["group"]);
  v1::SetTraineeGroupResponse resp;
  if (auto refused = AdmitAndCall(call, req, &SetTraineeGroupCall, &resp)) return *refused;
  return JsonReply(200, {{"trainee_id", req.trainee_id()}, {"group", req.group()}});
}

// GET trainees/{id}/sign-offs: the trainee's list of sessions shows them.
HttpReply ListSignOffs(WebCall& call) {
  const std::string& id = call.Param("id");
  v1::ListSessionsRequest req;  // the trainee id's bounds
  req.set_trainee_id(id);
  Status s = call.Admit(req);
  if (!s.ok()) return ErrorOf(s);
  // Read with the session listing it annotates: only refusals are audited.
  static const CallSpec spec{"session.sign_offs", kReaders, "read sign-offs",
                             /*audit_every_call=*/false};
  json out = json::array();
  s = RunCall(call.deps, call.who, spec, id, [&]() -> Status {
    const Status hidden(StatusCode::NOT_FOUND, "no trainee '" + id + "'");
    auto trainee = call.deps.store->GetTrainee(id);
    if (trainee.status.code == patient_db::StoreCode::kNotFound) return hidden;
    if (!trainee.ok()) return ToGrpcStatus(trainee.status);
    if (!RequireTraineeReader(call.who, trainee.value, "read sign-offs").ok()) return hidden;
    auto rows = call.deps.store->ListTraineeSignOffs(id);
    if (!rows.ok()) return ToGrpcStatus(rows.status);
    for (const auto& r : rows.value) out.push_back(SignOffJson(r));
    return Status::OK;
  });
  if (!s.ok()) return ErrorOf(s);
  return JsonReply(200, {{"sign_offs", out}});
}

// GET sessions/{uuid}/notes: notes oldest first, the sign-off or null.
HttpReply ListNotes(WebCall& call) {
  const std::string& uuid = call.Param("uuid");
  v1::GetSessionRequest bounds;  // the uuid's bounds
  bounds.set_uuid(uuid);
  Status s = call.Admit(bounds);
  if (!s.ok()) return ErrorOf(s);
  // Read with the session page, whose own read is audited (session.read).
  static const CallSpec spec{"session.notes", kReaders, "read session notes",
                             /*audit_every_call=*/false};
  json out = json::array();
  json signed_off = nullptr;
  s = RunCall(call.deps, call.who, spec, uuid, [&]() -> Status {
    patient_db::SessionRow session;
    Status found = ReadableSession(call.deps, call.who, uuid, "read session notes", &session);
    if (!found.ok()) return found;
    auto rows = call.deps.store->ListSessionNotes(uuid, patient_db::kMaxSessionNotes);
    if (!rows.ok()) return ToGrpcStatus(rows.status);
    for (const auto& n : rows.value) out.push_back(NoteJson(n));
    auto so = call.deps.store->GetSessionSignOff(uuid);
    if (so.ok()) {
      signed_off = SignOffJson(so.value);
    } else if (so.status.code != patient_db::StoreCode::kNotFound) {
      return ToGrpcStatus(so.status);
    }
    return Status::OK;
  });
  if (!s.ok()) return ErrorOf(s);
  return JsonReply(200, {{"session_uuid", uuid},
                         {"notes", out},
                         {"sign_off", signed_off},
                         {"can_write", MayWrite(call.who)}});
}

// POST sessions/{uuid}/notes {"text"}
HttpReply AddNote(WebCall& call) {
  const std::string& uuid = call.Param("uuid");
  HttpReply bad;
  std::map<std::string, std::string> body;
  if (!ReadBody(call.request.body, {"text"}, &body, &bad)) return bad;
  const std::string& text = body["text"];
  if (text.empty() || text.size() > patient_db::kMaxSessionNoteBytes) {
    return Error(400, "INVALID_ARGUMENT",
                 "text: " + std::to_string(text.size()) + " bytes, must be 1.." +
                     std::to_string(patient_db::kMaxSessionNoteBytes));
  }
  if (!patient_db::IsPrintableText(text, /*allow_newlines=*/true)) {
    return Error(400, "INVALID_ARGUMENT",
                 "text: must be printable UTF-8 without control characters (newlines allowed)");
  }
  v1::GetSessionRequest bounds;  // the uuid's bounds
  bounds.set_uuid(uuid);
  Status s = call.Admit(bounds);
  if (!s.ok()) return ErrorOf(s);
  static const CallSpec spec{"session.note", kSupervisors, "write session notes"};
  patient_db::SessionNoteRow note;
  s = RunCall(call.deps, call.who, spec, uuid, [&]() -> Status {
    patient_db::SessionRow session;
    Status found = ReadableSession(call.deps, call.who, uuid, "write session notes", &session);
    if (!found.ok()) return found;
    auto existing = call.deps.store->ListSessionNotes(uuid, patient_db::kMaxSessionNotes);
    if (!existing.ok()) return ToGrpcStatus(existing.status);
    if (static_cast<int>(existing.value.size()) >= patient_db::kMaxSessionNotes) {
      return Status(StatusCode::FAILED_PRECONDITION,
                    "session '" + uuid + "' has " + std::to_string(patient_db::kMaxSessionNotes) +
                        " notes, the most a session keeps");
    }
    note = {NewToken().substr(0, 32), uuid, call.who.token_id, call.who.label, NowUnixMs(), text};
    return ToGrpcStatus(call.deps.store->AddSessionNote(note));
  });
  if (!s.ok()) return ErrorOf(s);
  return JsonReply(200, NoteJson(note));
}

// POST sessions/{uuid}/sign-off {}: once; a second answers 409 with the first.
HttpReply SignOffSession(WebCall& call) {
  const std::string& uuid = call.Param("uuid");
  HttpReply bad;
  std::map<std::string, std::string> body;
  if (!ReadBody(call.request.body, {}, &body, &bad)) return bad;
  v1::GetSessionRequest bounds;  // the uuid's bounds
  bounds.set_uuid(uuid);
  Status s = call.Admit(bounds);
  if (!s.ok()) return ErrorOf(s);
  static const CallSpec spec{"session.sign_off", kSupervisors, "sign off sessions"};
  patient_db::SessionSignOffRow row{uuid, call.who.token_id, call.who.label, NowUnixMs()};
  s = RunCall(call.deps, call.who, spec, uuid, [&]() -> Status {
    patient_db::SessionRow session;
    Status found = ReadableSession(call.deps, call.who, uuid, "sign off sessions", &session);
    if (!found.ok()) return found;
    auto put = call.deps.store->SignOffSession(row);
    if (!put.ok()) return ToGrpcStatus(put.status);
    if (!put.value) {
      auto first = call.deps.store->GetSessionSignOff(uuid);
      const std::string by = first.ok() ? " by " + first.value.signed_by_label : "";
      return Status(StatusCode::ALREADY_EXISTS,
                    "session '" + uuid + "' is already signed off" + by);
    }
    return Status::OK;
  });
  if (!s.ok()) return ErrorOf(s);
  return JsonReply(200, SignOffJson(row));
}

}  // namespace

std::vector<WebRoute> WorkflowRoutes() {
  const std::vector<patient_db::StoreRole> list_curricula = {
      patient_db::StoreRole::kAdmin, patient_db::StoreRole::kSupervisor,
      patient_db::StoreRole::kStation};
  return {{"GET", "/api/v1/curricula", list_curricula, &ListCurricula},
          {"POST", "/api/v1/assignments", kSupervisors, &AssignCurriculum},
          {"POST", "/api/v1/trainees/{id}/group", kSupervisors, &SetTraineeGroup},
          {"GET", "/api/v1/trainees/{id}/sign-offs", kReaders, &ListSignOffs},
          {"GET", "/api/v1/sessions/{uuid}/notes", kReaders, &ListNotes},
          {"POST", "/api/v1/sessions/{uuid}/notes", kSupervisors, &AddNote},
          {"POST", "/api/v1/sessions/{uuid}/sign-off", kSupervisors, &SignOffSession}};
}

}  // namespace ves::server
