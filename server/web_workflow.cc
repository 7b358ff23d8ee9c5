#include "server/web_workflow.h"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "patient_db/limits.h"
#include "server/pipeline.h"
#include "server/web_reply.h"
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

}  // namespace

std::optional<HttpReply> WorkflowRoute(
    const ServiceDeps& deps, const HttpRequest& request, const std::vector<std::string>& path,
    const std::function<grpc::Status(const google::protobuf::Message&)>& admit,
    const Principal& who) {
  const bool get = request.method == "GET";
  const bool post = request.method == "POST";
  HttpReply bad;
  std::map<std::string, std::string> body;

  // GET curricula: what an assignment form offers.
  if (path.size() == 1 && path[0] == "curricula") {
    if (!get) return Error(405, "METHOD_NOT_ALLOWED", "curricula: GET only");
    v1::ListCurriculaRequest req;
    req.set_page_size(100);
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    v1::ListCurriculaResponse resp;
    s = ListCurriculaCall(deps, who, req, &resp);
    if (!s.ok()) return ErrorOf(s);
    json out = json::array();
    for (const auto& c : resp.curricula()) {
      out.push_back({{"curriculum_id", c.curriculum_id()},
                     {"title", c.title()},
                     {"lessons", c.lessons_size()}});
    }
    return JsonReply(200, {{"curricula", out}, {"next_page_token", resp.next_page_token()}});
  }

  // POST assignments: a curriculum to a trainee or to a group (Lessons.AssignCurriculum).
  if (path.size() == 1 && path[0] == "assignments") {
    if (!post) return Error(405, "METHOD_NOT_ALLOWED", "assignments: POST only");
    if (!ReadBody(request.body, {"curriculum_id", "trainee_id", "group"}, &body, &bad)) return bad;
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
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    v1::AssignCurriculumResponse resp;
    s = AssignCurriculumCall(deps, who, req, &resp);
    if (!s.ok()) return ErrorOf(s);
    return JsonReply(200, {{"curriculum_id", req.curriculum_id()},
                           {assignee_field, body[assignee_field]},
                           {"trainee_ids", std::vector<std::string>(resp.trainee_ids().begin(),
                                                                    resp.trainee_ids().end())}});
  }

  // POST trainees/{id}/group: the trainee's one group (Lessons.SetTraineeGroup).
  if (path.size() == 3 && path[0] == "trainees" && path[2] == "group") {
    if (!post) return Error(405, "METHOD_NOT_ALLOWED", "trainees/{id}/group: POST only");
    if (!ReadBody(request.body, {"group"}, &body, &bad)) return bad;
    if (body.count("group") == 0) {
      return Error(400, "INVALID_ARGUMENT", "group: missing (\"\" takes the trainee out)");
    }
    if (!CheckId("group", body["group"], true, &bad)) return bad;
    v1::SetTraineeGroupRequest req;
    req.set_trainee_id(path[1]);
    req.set_group(body["group"]);
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    v1::SetTraineeGroupResponse resp;
    s = SetTraineeGroupCall(deps, who, req, &resp);
    if (!s.ok()) return ErrorOf(s);
    return JsonReply(200, {{"trainee_id", req.trainee_id()}, {"group", req.group()}});
  }

  // GET trainees/{id}/sign-offs: the trainee's list of sessions shows them.
  if (path.size() == 3 && path[0] == "trainees" && path[2] == "sign-offs") {
    if (!get) return Error(405, "METHOD_NOT_ALLOWED", "trainees/{id}/sign-offs: GET only");
    v1::ListSessionsRequest req;  // the trainee id's bounds
    req.set_trainee_id(path[1]);
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    // Read with the session listing it annotates: only refusals are audited.
    static const CallSpec spec{"session.sign_offs",
                               {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kTrainee},
                               "read sign-offs",
                               /*audit_every_call=*/false};
    json out = json::array();
    s = RunCall(deps, who, spec, path[1], [&]() -> Status {
      const Status hidden(StatusCode::NOT_FOUND, "no trainee '" + path[1] + "'");
      auto trainee = deps.store->GetTrainee(path[1]);
      if (trainee.status.code == patient_db::StoreCode::kNotFound) return hidden;
      if (!trainee.ok()) return ToGrpcStatus(trainee.status);
      if (!RequireTraineeReader(who, trainee.value, "read sign-offs").ok()) return hidden;
      auto rows = deps.store->ListTraineeSignOffs(path[1]);
      if (!rows.ok()) return ToGrpcStatus(rows.status);
      for (const auto& r : rows.value) out.push_back(SignOffJson(r));
      return Status::OK;
    });
    if (!s.ok()) return ErrorOf(s);
    return JsonReply(200, {{"sign_offs", out}});
  }

  const bool notes = path.size() == 3 && path[0] == "sessions" && path[2] == "notes";
  const bool sign_off = path.size() == 3 && path[0] == "sessions" && path[2] == "sign-off";
  if (!notes && !sign_off) return std::nullopt;
  const std::string& uuid = path[1];
  v1::GetSessionRequest bounds;  // the uuid's bounds
  bounds.set_uuid(uuid);

  // GET sessions/{uuid}/notes: notes oldest first, the sign-off or null.
  if (notes && get) {
    Status s = admit(bounds);
    if (!s.ok()) return ErrorOf(s);
    // Read with the session page, whose own read is audited (session.read).
    static const CallSpec spec{"session.notes",
                               {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kTrainee},
                               "read session notes",
                               /*audit_every_call=*/false};
    json out = json::array();
    json signed_off = nullptr;
    s = RunCall(deps, who, spec, uuid, [&]() -> Status {
      patient_db::SessionRow session;
      Status found = ReadableSession(deps, who, uuid, "read session notes", &session);
      if (!found.ok()) return found;
      auto rows = deps.store->ListSessionNotes(uuid, patient_db::kMaxSessionNotes);
      if (!rows.ok()) return ToGrpcStatus(rows.status);
      for (const auto& n : rows.value) out.push_back(NoteJson(n));
      auto so = deps.store->GetSessionSignOff(uuid);
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
                           {"can_write", MayWrite(who)}});
  }
  if (!post) return Error(405, "METHOD_NOT_ALLOWED", "this route answers GET and POST");

  // POST sessions/{uuid}/notes {"text"}
  if (notes) {
    if (!ReadBody(request.body, {"text"}, &body, &bad)) return bad;
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
    Status s = admit(bounds);
    if (!s.ok()) return ErrorOf(s);
    static const CallSpec spec{
        "session.note", {StoreRole::kAdmin, StoreRole::kSupervisor}, "write session notes"};
    patient_db::SessionNoteRow note;
    s = RunCall(deps, who, spec, uuid, [&]() -> Status {
      patient_db::SessionRow session;
      Status found = ReadableSession(deps, who, uuid, "write session notes", &session);
      if (!found.ok()) return found;
      auto existing = deps.store->ListSessionNotes(uuid, patient_db::kMaxSessionNotes);
      if (!existing.ok()) return ToGrpcStatus(existing.status);
      if (static_cast<int>(existing.value.size()) >= patient_db::kMaxSessionNotes) {
        return Status(StatusCode::FAILED_PRECONDITION,
                      "session '" + uuid + "' has " + std::to_string(patient_db::kMaxSessionNotes) +
                          " notes, the most a session keeps");
      }
      note = {NewToken().substr(0, 32), uuid, who.token_id, who.label, NowUnixMs(), text};
      return ToGrpcStatus(deps.store->AddSessionNote(note));
    });
    if (!s.ok()) return ErrorOf(s);
    return JsonReply(200, NoteJson(note));
  }

  // POST sessions/{uuid}/sign-off {}: once; a second answers 409 with the first.
  if (!ReadBody(request.body, {}, &body, &bad)) return bad;
  Status s = admit(bounds);
  if (!s.ok()) return ErrorOf(s);
  static const CallSpec spec{
      "session.sign_off", {StoreRole::kAdmin, StoreRole::kSupervisor}, "sign off sessions"};
  patient_db::SessionSignOffRow row{uuid, who.token_id, who.label, NowUnixMs()};
  s = RunCall(deps, who, spec, uuid, [&]() -> Status {
    patient_db::SessionRow session;
    Status found = ReadableSession(deps, who, uuid, "sign off sessions", &session);
    if (!found.ok()) return found;
    auto put = deps.store->SignOffSession(row);
    if (!put.ok()) return ToGrpcStatus(put.status);
    if (!put.value) {
      auto first = deps.store->GetSessionSignOff(uuid);
      const std::string by = first.ok() ? " by " + first.value.signed_by_label : "";
      return Status(StatusCode::ALREADY_EXISTS,
                    "session '" + uuid + "' is already signed off" + by);
    }
    return Status::OK;
  });
  if (!s.ok()) return ErrorOf(s);
  return JsonReply(200, SignOffJson(row));
}

}  // namespace ves::server
