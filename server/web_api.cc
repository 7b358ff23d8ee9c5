#include "server/web_api.h"

#include <google/protobuf/util/json_util.h>
#include <openssl/crypto.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <ctime>
#include <nlohmann/json.hpp>
#include <set>

#include "patient_db/limits.h"
#include "server/live_hub.h"
#include "server/pipeline.h"
#include "server/session_check.h"
#include "server/session_series.h"
#include "server/web_assets.h"
#include "server/web_cohort.h"
#include "server/web_reply.h"
#include "server/web_workflow.h"
#include "ves/v1/lesson.pb.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using nlohmann::json;

namespace {

constexpr const char* kCookieName = "ves_session";

int HttpStatusOf(StatusCode code) {
  switch (code) {
    case StatusCode::OK:
      return 200;
    case StatusCode::INVALID_ARGUMENT:
    case StatusCode::OUT_OF_RANGE:
      return 400;
    case StatusCode::UNAUTHENTICATED:
      return 401;
    case StatusCode::PERMISSION_DENIED:
      return 403;
    case StatusCode::NOT_FOUND:
      return 404;
    case StatusCode::ALREADY_EXISTS:
    case StatusCode::FAILED_PRECONDITION:
    case StatusCode::ABORTED:
      return 409;
    case StatusCode::RESOURCE_EXHAUSTED:
      return 429;
    case StatusCode::UNIMPLEMENTED:
      return 501;
    case StatusCode::UNAVAILABLE:
      return 503;
    default:
      return 500;
  }
}

std::string Dump(const json& j) {
  return WebApi::HtmlSafeJson(j.dump(-1, ' ', false, json::error_handler_t::replace));
}

}  // namespace

HttpReply JsonReply(int status, const json& body) {
  HttpReply r;
  r.status = status;
  r.body = Dump(body);
  return r;
}

HttpReply Error(int status, const std::string& code, const std::string& message) {
  return JsonReply(status, {{"error", {{"code", code}, {"message", message}}}});
}

HttpReply ErrorOf(const Status& s) {
  return Error(HttpStatusOf(s.error_code()), StatusCodeName(s.error_code()), s.error_message());
}

namespace {

// A proto message as JSON: field names as in the .proto, defaults printed.
json ProtoJson(const google::protobuf::Message& m) {
  google::protobuf::util::JsonPrintOptions o;
  o.always_print_primitive_fields = true;
  o.preserve_proto_field_names = true;
  std::string text;
  if (!google::protobuf::util::MessageToJsonString(m, &text, o).ok()) return json::object();
  return json::parse(text, nullptr, false);
}

std::string RandomHex() { return NewToken(); }  // 256 bits from OpenSSL

bool ConstantTimeEquals(const std::string& a, const std::string& b) {
  return a.size() == b.size() && CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// Percent-decoding; false on a broken escape.
bool Decode(std::string_view in, std::string* out, bool plus_is_space) {
  out->clear();
  for (size_t i = 0; i < in.size(); ++i) {
    if (in[i] == '%') {
      if (i + 2 >= in.size()) return false;
      const int hi = HexValue(in[i + 1]);
      const int lo = HexValue(in[i + 2]);
      if (hi < 0 || lo < 0) return false;
      out->push_back(static_cast<char>(hi * 16 + lo));
      i += 2;
    } else if (in[i] == '+' && plus_is_space) {
      out->push_back(' ');
    } else {
      out->push_back(in[i]);
    }
  }
  return true;
}

std::vector<std::string> Split(std::string_view s, char sep) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (true) {
    const size_t end = s.find(sep, start);
    parts.emplace_back(s.substr(start, end == std::string_view::npos ? s.npos : end - start));
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
  return parts;
}

std::string CookieValue(const std::string& header, const std::string& name) {
  for (std::string part : Split(header, ';')) {
    const size_t b = part.find_first_not_of(' ');
    if (b == std::string::npos) continue;
    part = part.substr(b);
    if (part.compare(0, name.size() + 1, name + "=") == 0) return part.substr(name.size() + 1);
  }
  return {};
}

}  // namespace

bool QueryNumber(const std::map<std::string, std::string>& q, const std::string& name, uint64_t max,
                 uint64_t* value, HttpReply* error) {
  auto it = q.find(name);
  if (it == q.end()) return true;
  uint64_t v = 0;
  const auto [end, ec] =
      std::from_chars(it->second.data(), it->second.data() + it->second.size(), v);
  if (it->second.empty() || ec != std::errc() || end != it->second.data() + it->second.size() ||
      v > max) {
    *error = Error(400, "INVALID_ARGUMENT",
                   "query " + name + " = '" + patient_db::PrintableExcerpt(it->second, 40) +
                       "': must be a whole number in 0.." + std::to_string(max));
    return false;
  }
  *value = v;
  return true;
}

bool QueryTimeRange(const std::map<std::string, std::string>& q, int64_t* from_unix_ms,
                    int64_t* to_unix_ms, HttpReply* error) {
  uint64_t from = 0, to = 0;
  if (!QueryNumber(q, "from_unix_ms", INT64_MAX, &from, error)) return false;
  if (!QueryNumber(q, "to_unix_ms", INT64_MAX, &to, error)) return false;
  if (to != 0 && to <= from) {
    *error = Error(400, "INVALID_ARGUMENT",
                   "query to_unix_ms = " + std::to_string(to) +
                       ": must be after from_unix_ms = " + std::to_string(from));
    return false;
  }
  *from_unix_ms = static_cast<int64_t>(from);
  *to_unix_ms = static_cast<int64_t>(to);
  return true;
}

namespace {

std::string QueryText(const std::map<std::string, std::string>& q, const std::string& name) {
  auto it = q.find(name);
  return it == q.end() ? std::string() : it->second;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// RFC 4180: quoted when it holds a comma, quote or line end. A text cell a
// spreadsheet would run as a formula gets a leading ' (ids are printable
// text from uploads; a trainee id may well start with '=').
std::string CsvText(const std::string& text) {
  std::string cell = text;
  if (!cell.empty() && std::string_view("=+-@").find(cell[0]) != std::string_view::npos) {
    cell.insert(cell.begin(), '\'');
  }
  if (cell.find_first_of(",\"\r\n") == std::string::npos) return cell;
  std::string quoted = "\"";
  for (char c : cell) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}

std::string CsvNumber(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// ISO 8601 in UTC to the millisecond: 2026-12-07T14:53:22.123Z.
std::string IsoUtc(int64_t unix_ms) {
  const std::time_t secs = static_cast<std::time_t>(unix_ms / 1000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[96];  // room for any int the compiler cannot rule out
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900,
                tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec,
                static_cast<int>(unix_ms % 1000));
  return buf;
}

// "cecum_reached", "timed_out", ...: the station's names for an outcome.
std::string OutcomeText(int outcome) {
  std::string name = v1::Outcome_IsValid(outcome)
                         ? v1::Outcome_Name(static_cast<v1::Outcome>(outcome))
                         : "OUTCOME_UNSPECIFIED";
  name = name.substr(name.rfind("OUTCOME_", 0) == 0 ? 8 : 0);
  std::transform(name.begin(), name.end(), name.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return name;
}

}  // namespace

std::string FileNamePart(const std::string& id) {
  std::string out;
  for (char c : id) {
    const bool kept =
        std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_';
    out += kept ? c : '_';
  }
  return out.substr(0, 64);
}

std::string WebApi::HtmlSafeJson(std::string in) {
  std::string out;
  out.reserve(in.size());
  for (char c : in) {
    switch (c) {
      case '<':
        out += "\\u003c";
        break;
      case '>':
        out += "\\u003e";
        break;
      case '&':
        out += "\\u0026";
        break;
      default:
        out.push_back(c);
    }
  }
  return out;
}

WebApi::WebApi(ServiceDeps deps, WebOptions options) : deps_(deps), options_(options) {
  if (options_.oidc.enabled()) oidc_ = std::make_unique<OidcClient>(options_.oidc);
}

std::string WebApi::AuthorizationOf(const HttpRequest& request, bool* csrf_ok,
                                    std::string* session_id) {
  *csrf_ok = true;
  if (!request.authorization.empty()) return request.authorization;  // scripts: Bearer
  const std::string sid = CookieValue(request.cookie, kCookieName);
  if (sid.empty()) return {};
  std::lock_guard lock(mutex_);
  auto it = sessions_.find(sid);
  if (it == sessions_.end()) return {};
  if (it->second.expires_unix_ms <= NowUnixMs()) {
    sessions_.erase(it);
    return {};
  }
  *session_id = sid;
  // A cookie rides along on any request the browser makes: a state change
  // must also carry the token only this origin's pages can read.
  *csrf_ok =
      request.method == "GET" || ConstantTimeEquals(request.csrf_token, it->second.csrf_token);
  return "Bearer " + it->second.token;
}

HttpReply WebApi::SignIn(const HttpRequest& request) {
  json body = json::parse(request.body, nullptr, false);
  if (body.is_object() && body.contains("username")) {
    // A person's account (server/accounts.h): the session holds a secret of
    // its own, resolved against the account on every request.
    if (!body["username"].is_string() || !body.contains("password") ||
        !body["password"].is_string()) {
      return Error(400, "INVALID_ARGUMENT",
                   "body: must be {\"username\": \"...\", \"password\": \"...\"}");
    }
    const SignInOutcome out = deps_.auth->accounts().PasswordSignIn(
        body["username"].get<std::string>(), body["password"].get<std::string>(), request.peer,
        options_.session_ttl);
    return StartWebSession(out, request.peer);
  }
  if (!body.is_object() || !body.contains("token") || !body["token"].is_string()) {
    return Error(400, "INVALID_ARGUMENT", "body: must be {\"token\": \"<token>\"}");
  }
  const std::string token = body["token"].get<std::string>();
  if (token.empty() || token.size() > 128) {
    return Error(400, "INVALID_ARGUMENT", "token: must be 1..128 characters");
  }
  Principal who;
  const AuthStatus a = deps_.auth->Authenticate("Bearer " + token, &who);
  if (!a.ok()) {
    return Error(a.code == AuthCode::kUnauthenticated ? 401 : 500,
                 a.code == AuthCode::kUnauthenticated ? "UNAUTHENTICATED" : "INTERNAL", a.message);
  }
  return NewWebSession(token, who, "");
}

HttpReply WebApi::StartWebSession(const SignInOutcome& out, const std::string& peer) {
  // The source address is the audit row's target: who tried from where.
  const std::string where = "from " + SourceAddress(peer);
  if (!out.ok()) {
    if (out.audit) {
      deps_.writer->SubmitAudit(MakeAudit(out.principal, "web.sign_in", where,
                                          Status(out.http_status == 429
                                                     ? StatusCode::RESOURCE_EXHAUSTED
                                                     : StatusCode::UNAUTHENTICATED,
                                                 out.message)));
    }
    HttpReply r = Error(out.http_status, out.code, out.message);
    if (out.retry_after_s > 0) r.headers.emplace_back("Retry-After", std::to_string(out.retry_after_s));
    return r;
  }
  HttpReply r = NewWebSession(out.secret, out.principal, where);
  if (r.status != 200) deps_.auth->accounts().EndSession(out.secret);
  return r;
}

HttpReply WebApi::NewWebSession(const std::string& token, const Principal& who,
                                const std::string& audit_target) {
  WebSession session{
      token, RandomHex(),
      NowUnixMs() +
          std::chrono::duration_cast<std::chrono::milliseconds>(options_.session_ttl).count()};
  const std::string sid = RandomHex();
  {
    std::lock_guard lock(mutex_);
    const int64_t now = NowUnixMs();
    for (auto it = sessions_.begin(); it != sessions_.end();) {
      it = it->second.expires_unix_ms <= now ? sessions_.erase(it) : std::next(it);
    }
    if (sessions_.size() >= kMaxWebSessions) {
      return Error(429, "RESOURCE_EXHAUSTED", "too many signed-in browsers; try again later");
    }
    sessions_[sid] = session;
  }
  deps_.writer->SubmitAudit(MakeAudit(who, "web.sign_in", audit_target, Status::OK));
  HttpReply r = JsonReply(200, {{"csrf_token", session.csrf_token},
                                {"role", patient_db::RoleName(who.role)},
                                {"institution", who.institution},
                                {"label", who.label},
                                {"expires_unix_ms", session.expires_unix_ms}});
  r.headers.emplace_back("Set-Cookie", std::string(kCookieName) + "=" + sid + "; Path=/; Max-Age=" +
                                           std::to_string(options_.session_ttl.count()) +
                                           "; HttpOnly; SameSite=Strict" +
                                           (options_.secure_cookies ? "; Secure" : ""));
  return r;
}

HttpReply WebApi::SignOut(const HttpRequest& request) {
  bool csrf_ok = false;
  std::string sid;
  const std::string authorization = AuthorizationOf(request, &csrf_ok, &sid);
  if (sid.empty()) return Error(401, "UNAUTHENTICATED", "not signed in");
  if (!csrf_ok) return Error(403, "PERMISSION_DENIED", "X-CSRF-Token header missing or wrong");
  Principal who;
  if (deps_.auth->Authenticate(authorization, &who).ok()) {
    deps_.writer->SubmitAudit(MakeAudit(who, "web.sign_out", "", Status::OK));
  }
  {
    std::lock_guard lock(mutex_);
    auto it = sessions_.find(sid);
    if (it != sessions_.end()) {
      deps_.auth->accounts().EndSession(it->second.token);
      sessions_.erase(it);
    }
  }
  HttpReply r = JsonReply(200, {{"signed_out", true}});
  r.headers.emplace_back("Set-Cookie", std::string(kCookieName) +
                                           "=; Path=/; Max-Age=0; HttpOnly; SameSite=Strict" +
                                           (options_.secure_cookies ? "; Secure" : ""));
  return r;
}

HttpReply WebApi::Handle(const HttpRequest& request) {
  if (request.target.size() > kMaxHttpTargetBytes) {
    return Error(414, "INVALID_ARGUMENT",
                 "request target: " + std::to_string(request.target.size()) +
                     " bytes, over the limit of " + std::to_string(kMaxHttpTargetBytes));
  }
  if (request.body.size() > kMaxHttpBodyBytes) {
    return Error(413, "INVALID_ARGUMENT",
                 "body: over the limit of " + std::to_string(kMaxHttpBodyBytes) + " bytes");
  }
  const size_t qmark = request.target.find('?');
  const std::string raw_path = request.target.substr(0, qmark);
  std::map<std::string, std::string> query;
  if (qmark != std::string::npos) {
    for (const std::string& pair : Split(std::string_view(request.target).substr(qmark + 1), '&')) {
      if (pair.empty()) continue;
      const size_t eq = pair.find('=');
      std::string key, value;
      if (!Decode(pair.substr(0, eq), &key, true) ||
          !Decode(eq == std::string::npos ? "" : pair.substr(eq + 1), &value, true)) {
        return Error(400, "INVALID_ARGUMENT", "query: a broken %-escape");
      }
      if (query.size() >= 16) return Error(400, "INVALID_ARGUMENT", "query: over 16 parameters");
      query[key] = value;
    }
  }
  if (raw_path == "/healthz") {
    if (request.method != "GET" && request.method != "HEAD") {
      return Error(405, "METHOD_NOT_ALLOWED", "/healthz answers GET only");
    }
    return JsonReply(200, {{"status", "ok"}});
  }
  if (raw_path.rfind("/api/v1/", 0) == 0) {
    HttpReply r = Api(request, raw_path.substr(8), query);
    r.headers.emplace_back("Cache-Control", "no-store");
    return r;
  }
  if (request.method != "GET" && request.method != "HEAD") {
    return Error(405, "METHOD_NOT_ALLOWED", "pages answer GET only");
  }
  const WebAsset* asset = FindWebAsset(raw_path == "/" ? "/index.html" : raw_path);
  if (asset == nullptr)
    return Error(404, "NOT_FOUND", "no page '" + patient_db::PrintableExcerpt(raw_path, 80) + "'");
  HttpReply r;
  r.content_type = asset->content_type;
  r.body.assign(asset->data, asset->size);
  r.headers.emplace_back("Cache-Control", "no-cache");
  return r;
}

HttpReply WebApi::Api(const HttpRequest& request, const std::string& raw_path,
                      const std::map<std::string, std::string>& query) {
  std::vector<std::string> path;
  for (const std::string& part : Split(raw_path, '/')) {
    std::string decoded;
    if (!Decode(part, &decoded, false)) {
      return Error(400, "INVALID_ARGUMENT", "path: a broken %-escape");
    }
    path.push_back(std::move(decoded));
  }
  const bool get = request.method == "GET";
  const bool post = request.method == "POST";
  if (post && request.content_type.rfind("application/json", 0) != 0) {
    // Forms cannot send JSON across origins without a preflight.
    return Error(415, "INVALID_ARGUMENT", "Content-Type: must be application/json");
  }
  if (path.size() == 1 && path[0] == "sign-in") {
    // GET: which ways of signing in this server offers (the sign-in page).
    if (get) return JsonReply(200, {{"token", true}, {"password", true}, {"oidc", oidc_ != nullptr}});
    if (!post) return Error(405, "METHOD_NOT_ALLOWED", "sign-in: GET or POST");
    return SignIn(request);
  }
  if (path.size() == 2 && path[0] == "oidc") {
    if (!oidc_) {
      return Error(404, "NOT_FOUND", "no identity provider is configured (ves-server --oidc-issuer)");
    }
    if (!get) return Error(405, "METHOD_NOT_ALLOWED", "oidc: GET only");
    if (path[1] == "start") return OidcStart();
    if (path[1] == "callback") return OidcCallback(request, query, CookieValue(request.cookie, kOidcCookieName));
  }
  if (path.size() == 1 && path[0] == "sign-out") {
    if (!post) return Error(405, "METHOD_NOT_ALLOWED", "sign-out: POST only");
    return SignOut(request);
  }
  if (!get && !post) return Error(405, "METHOD_NOT_ALLOWED", "the API answers GET and POST");

  bool csrf_ok = true;
  std::string sid;
  const std::string authorization = AuthorizationOf(request, &csrf_ok, &sid);
  HttpReply bad;
  uint64_t page_size = 0;
  if (!QueryNumber(query, "page_size", patient_db::kMaxPageSize, &page_size, &bad)) return bad;
  const std::string page_token = QueryText(query, "page_token");
  const std::string institution = QueryText(query, "institution");

  // Admits the request (bounds, then authentication) and, for a
  // state-changing one from a browser, its CSRF token.
  Principal who;
  const auto admit = [&](const google::protobuf::Message& m) -> Status {
    Status s = AdmitRequest(deps_, authorization, m, &who);
    if (s.ok() && !csrf_ok) {
      return Status(StatusCode::PERMISSION_DENIED, "X-CSRF-Token header missing or wrong");
    }
    return s;
  };

  // GET me
  if (get && path.size() == 1 && path[0] == "me") {
    v1::ListTraineesRequest empty;
    Status s = admit(empty);
    if (!s.ok()) return ErrorOf(s);
    json j = {{"role", patient_db::RoleName(who.role)},
              {"institution", who.institution},
              {"label", who.label},
              {"trainee_id", who.trainee_id}};
    if (!sid.empty()) {
      std::lock_guard lock(mutex_);
      auto it = sessions_.find(sid);
      if (it != sessions_.end()) j["csrf_token"] = it->second.csrf_token;
    }
    return JsonReply(200, j);
  }

  // trainees (GET list with groups and last activity; POST add)
  if (path.size() == 1 && path[0] == "trainees") {
    if (post) {
      v1::AddTraineeRequest req;
      if (!google::protobuf::util::JsonStringToMessage(request.body, req.mutable_trainee()).ok()) {
        return Error(400, "INVALID_ARGUMENT",
                     "body: must be {\"trainee_id\": ..., \"display_name\": ..., "
                     "\"institution\": ...}");
      }
      Status s = admit(req);
      if (!s.ok()) return ErrorOf(s);
      v1::AddTraineeResponse resp;
      s = AddTraineeCall(deps_, who, req, &resp);
      if (!s.ok()) return ErrorOf(s);
      return JsonReply(200, ProtoJson(resp));
    }
    v1::ListTraineesRequest req;
    req.set_institution(institution);
    req.set_page_size(static_cast<uint32_t>(page_size));
    req.set_page_token(page_token);
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    v1::ListTraineesResponse resp;
    s = ListTraineesCall(deps_, who, req, &resp);
    if (!s.ok()) return ErrorOf(s);
    // The call admitted reading this institution's trainees: their groups,
    // activity, assignments and verdicts are read for the whole page, one
    // store read each (not per trainee: docs/server.md, "Web pages at scale").
    json trainees = json::array();
    std::map<std::string, std::vector<std::string>> groups;
    std::vector<std::string> ids;
    for (const auto& t : resp.trainees()) ids.push_back(t.trainee_id());
    auto group_of = deps_.store->GetTraineeGroups(ids);
    if (!group_of.ok()) return ErrorOf(ToGrpcStatus(group_of.status));
    auto activity = deps_.store->GetTraineeActivity(ids);
    if (!activity.ok()) return ErrorOf(ToGrpcStatus(activity.status));
    auto assignments = deps_.store->ListAssignmentsOf(ids);
    if (!assignments.ok()) return ErrorOf(ToGrpcStatus(assignments.status));
    auto verdicts = deps_.store->ListLessonVerdictsOf(ids);
    if (!verdicts.ok()) return ErrorOf(ToGrpcStatus(verdicts.status));
    CurriculumCache curricula(deps_.store);
    for (int i = 0; i < resp.trainees_size(); ++i) {
      const auto& t = resp.trainees(i);
      json row = ProtoJson(t);
      const std::string& group = group_of.value[i];
      row["group"] = group;
      if (!group.empty()) groups[group].push_back(t.trainee_id());
      row["sessions"] = activity.value[i].sessions;
      row["last_activity_unix_ms"] = activity.value[i].last_end_unix_ms;
      row["curricula"] =
          CurriculaProgressJson(curricula, assignments.value[i], verdicts.value[i]);
      trainees.push_back(std::move(row));
    }
    json group_list = json::array();
    for (auto& [name, members] : groups)
      group_list.push_back({{"group", name}, {"trainees", members}});
    return JsonReply(200, {{"trainees", trainees},
                           {"groups", group_list},
                           {"next_page_token", resp.next_page_token()}});
  }
  // curricula, assignments, groups, session notes and sign-offs (web_workflow.cc)
  if (auto reply = WorkflowRoute(deps_, request, path, admit, who)) return *std::move(reply);
  if (!get) return Error(405, "METHOD_NOT_ALLOWED", "this route answers GET only");
  // groups/{group}/cohort, groups/{group}/sessions.csv, trainees/{id}/report
  if (auto reply = CohortRoute(deps_, path, query, admit, who)) return *std::move(reply);

  // trainees/{id}/sessions.csv: the export (docs/web.md, "Export")
  if (path.size() == 3 && path[0] == "trainees" && path[2] == "sessions.csv") {
    v1::ListSessionsRequest req;  // the trainee id's bounds
    req.set_trainee_id(path[1]);
    int64_t from = 0, to = 0;
    if (!QueryTimeRange(query, &from, &to, &bad)) return bad;
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    std::vector<patient_db::SessionRow> sessions;
    std::vector<patient_db::LessonVerdictRow> verdicts;
    s = ExportSessionsCall(deps_, who, path[1], from, to, &sessions, &verdicts);
    if (!s.ok()) return ErrorOf(s);
    HttpReply r;
    r.content_type = "text/csv; charset=utf-8";
    r.body = SessionsCsv(sessions, verdicts);
    r.headers.emplace_back("Content-Disposition", "attachment; filename=\"ves-sessions-" +
                                                      FileNamePart(path[1]) + ".csv\"");
    return r;
  }

  // trainees/{id}/sessions
  if (path.size() == 3 && path[0] == "trainees" && path[2] == "sessions") {
    v1::ListSessionsRequest req;
    req.set_trainee_id(path[1]);
    req.set_case_id(QueryText(query, "case_id"));
    req.set_page_size(static_cast<uint32_t>(page_size));
    req.set_page_token(page_token);
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    v1::ListSessionsResponse resp;
    s = ListSessionsCall(deps_, who, req, &resp);
    if (!s.ok()) return ErrorOf(s);
    return JsonReply(200, ProtoJson(resp));
  }

  // trainees/{id}/curve: per case and per lesson, with pass lines and the
  // group's median per attempt.
  if (path.size() == 3 && path[0] == "trainees" && path[2] == "curve") {
    v1::LearningCurveRequest req;
    req.set_trainee_id(path[1]);
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    v1::LearningCurveResponse resp;
    s = GetLearningCurveCall(deps_, who, req, &resp);
    if (!s.ok()) return ErrorOf(s);
    // Read only after the call allowed this trainee's records.
    struct Point {
      std::string uuid, case_id, lesson_id;
      int64_t start = 0;
      double score = 0, time_to_cecum_s = 0, pain_s = 0, loop_s = 0;
      bool completed = false;
    };
    const auto points_of = [&](const std::string& trainee_id, std::vector<Point>* out,
                               bool with_loop) -> Status {
      auto rows = deps_.store->ListSessions(trainee_id, "");
      if (!rows.ok()) return ToGrpcStatus(rows.status);
      for (const auto& r : rows.value) {
        Point p{r.uuid,   r.case_id, r.lesson_id, r.start_unix_ms, r.score, r.time_to_cecum_s,
                r.pain_s, 0,         r.completed};
        if (with_loop && r.loop_s >= 0) {
          p.loop_s = r.loop_s;
        } else if (with_loop) {
          // Stored before the row kept it: loop time is in the record only.
          auto full = deps_.store->GetSession(r.uuid);
          v1::SessionRecord rec;
          if (full.ok() && rec.ParseFromString(full.value.body)) p.loop_s = rec.metrics().loop_s();
        }
        out->push_back(std::move(p));
      }
      return Status::OK;
    };
    std::vector<Point> mine;
    s = points_of(path[1], &mine, true);
    if (!s.ok()) return ErrorOf(s);
    // The group's median score per attempt of each case (the trainee's group).
    std::map<std::string, std::map<int, std::vector<double>>> group_scores;
    auto group = deps_.store->GetTraineeGroup(path[1]);
    auto trainee_row = deps_.store->GetTrainee(path[1]);
    std::string group_name = group.ok() ? group.value : "";
    const std::string institution_of_trainee = trainee_row.ok() ? trainee_row.value.institution : "";
    if (!group_name.empty() && trainee_row.ok()) {
      auto members = deps_.store->ListGroupTrainees(trainee_row.value.institution, group_name);
      for (const std::string& m : members.ok() ? members.value : std::vector<std::string>{}) {
        std::vector<Point> theirs;
        if (!points_of(m, &theirs, false).ok()) continue;
        std::map<std::string, int> attempt;
        for (const Point& p : theirs) {
          group_scores[p.case_id][++attempt[p.case_id]].push_back(p.score);
        }
      }
    }
    const auto curve_json = [](const std::vector<const Point*>& pts) {
      json a = json::array();
      int n = 0;
      for (const Point* p : pts) {
        a.push_back({{"attempt", ++n},
                     {"uuid", p->uuid},
                     {"case_id", p->case_id},
                     {"start_unix_ms", p->start},
                     {"score", p->score},
                     {"completed", p->completed},
                     // Null when the cecum was not reached: no time to plot.
                     {"time_to_cecum_s",
                      p->completed ? json(p->time_to_cecum_s) : json(nullptr)},
                     {"pain_s", p->pain_s},
                     {"loop_s", p->loop_s}});
      }
      return a;
    };
    std::map<std::string, std::vector<const Point*>> by_case, by_lesson;
    for (const Point& p : mine) {
      by_case[p.case_id].push_back(&p);
      if (!p.lesson_id.empty()) by_lesson[p.lesson_id].push_back(&p);
    }
    json cases = json::array();
    for (auto& [case_id, pts] : by_case) {
      json median = json::array();
      for (auto& [attempt, scores] : group_scores[case_id]) {
        median.push_back({{"attempt", attempt}, {"score", Median(scores)}});
      }
      cases.push_back({{"case_id", case_id},
                       {"points", curve_json(pts)},
                       {"group_median", median},
                       {"expert_band", ExpertBandJson(*deps_.store, institution_of_trainee, case_id)}});
    }
    json lessons = json::array();
    for (auto& [lesson_id, pts] : by_lesson) {
      json pass = json::object();
      json band = nullptr;  // the scripted expert's runs of the lesson's case
      auto curriculum_id = deps_.store->FindLessonCurriculum(lesson_id);
      auto curriculum = curriculum_id.ok() ? deps_.store->GetCurriculum(curriculum_id.value)
                                           : patient_db::StoreResult<patient_db::CurriculumRow>{};
      v1::Curriculum c;
      if (curriculum_id.ok() && curriculum.ok() && c.ParseFromString(curriculum.value.body)) {
        for (const auto& l : c.lessons()) {
          if (l.lesson_id() != lesson_id) continue;
          if (l.pass().has_min_score()) pass["score"] = l.pass().min_score();
          if (l.pass().has_max_time_to_cecum_s())
            pass["time_to_cecum_s"] = l.pass().max_time_to_cecum_s();
          if (l.pass().has_max_pain_s()) pass["pain_s"] = l.pass().max_pain_s();
          if (l.pass().has_max_loop_s()) pass["loop_s"] = l.pass().max_loop_s();
          pass["title"] = l.title();
          band = ExpertBandJson(*deps_.store, institution_of_trainee, l.case_ref().case_id());
        }
      }
      lessons.push_back({{"lesson_id", lesson_id},
                         {"points", curve_json(pts)},
                         {"pass_line", pass},
                         {"expert_band", band}});
    }
    return JsonReply(200, {{"trainee_id", resp.trainee_id()},
                           {"group", group_name},
                           {"cases", cases},
                           {"lessons", lessons}});
  }

  // sessions/{uuid}/series: the page's plots and replay track, computed once
  if (path.size() == 3 && path[0] == "sessions" && path[2] == "series") {
    v1::GetSessionRequest req;
    req.set_uuid(path[1]);
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    HttpReply r;
    s = SessionSeriesCall(deps_, who, req, &r.body);
    if (!s.ok()) return ErrorOf(s);
    return r;
  }

  // sessions/{uuid} and sessions/{uuid}/replay
  if ((path.size() == 2 || (path.size() == 3 && path[2] == "replay")) && path[0] == "sessions") {
    v1::GetSessionRequest req;
    req.set_uuid(path[1]);
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    v1::GetSessionResponse resp;
    if (path.size() == 2) {
      s = GetSessionCall(deps_, who, req, &resp);
      if (!s.ok()) return ErrorOf(s);
      v1::SessionRecord summary = resp.record();
      summary.clear_input_log();  // bulky and of no use to a reader
      summary.clear_replay_setup();
      // The station's health during this session, shaped as on the
      // stations page (numbers, not the proto's uint64 strings).
      const bool has_health = resp.record().has_station_health();
      return JsonReply(
          200, {{"record", ProtoJson(summary)},
                {"stored_unix_ms", resp.stored_unix_ms()},
                {"input_samples", resp.record().input_log().sample_count()},
                {"station_health",
                 has_health ? StationHealthJson(resp.record().station_health()) : json(nullptr)},
                {"station_health_flags", has_health
                                             ? json(StationHealthFlags(resp.record().station_health()))
                                             : json::array()},
                {"lesson_verdict", LessonVerdictJson(*deps_.store, resp.record())}});
    }
    static const CallSpec spec{"session.replay",
                               {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kTrainee},
                               "replay sessions"};
    std::shared_ptr<const SessionReplay> replay;
    s = RunCall(deps_, who, spec, req.uuid(), [&]() -> Status {
      // The read rules of GetSession (its own audit row names the read).
      Status read = GetSessionCall(deps_, who, req, &resp);
      if (!read.ok()) return read;
      try {
        replay = CachedReplay(req.uuid(), resp.record());
      } catch (const std::exception& e) {
        return Status(StatusCode::FAILED_PRECONDITION,
                      "session " + req.uuid() + " cannot be replayed: " + e.what());
      }
      if (!replay) {
        return Status(StatusCode::RESOURCE_EXHAUSTED,
                      std::to_string(kMaxConcurrentReplays) +
                          " replays are running; ask again in a few seconds");
      }
      return Status::OK;
    });
    if (!s.ok()) return ErrorOf(s);
    json frames = json::array();
    for (const ReplayFrame& f : replay->frames) {
      json j = {{"t_s", f.t_s},
                {"hand_force_N", f.hand_force_N},
                {"stretch_m", f.stretch_m},
                {"tip_arc_m", f.tip_arc_m},
                {"inserted_m", f.inserted_m},
                {"pain", f.pain},
                {"loop", f.loop}};
      if (!f.scope_mm.empty()) j["scope_mm"] = f.scope_mm;
      if (!f.colon_mm.empty()) j["colon_mm"] = f.colon_mm;
      frames.push_back(std::move(j));
    }
    return JsonReply(200, {{"uuid", req.uuid()},
                           {"pain_stretch_m", replay->pain_stretch_m},
                           {"cecum_arc_m", replay->cecum_arc_m},
                           {"final_tip_arc_m", replay->final_tip_arc_m},
                           {"summary", replay->summary_line},
                           {"frames", frames}});
  }

  // groups/{group}/progress
  if (path.size() == 3 && path[0] == "groups" && path[2] == "progress") {
    v1::GetProgressRequest req;
    req.set_group(path[1]);
    req.set_institution(institution);
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    v1::GetProgressResponse resp;
    s = GetProgressCall(deps_, who, req, &resp);
    if (!s.ok()) return ErrorOf(s);
    return JsonReply(200, ProtoJson(resp));
  }

  // live sessions (GET list); live/ws is the WebSocket (LiveWatch)
  if (get && path.size() == 1 && path[0] == "live") {
    v1::ListTraineesRequest req;  // bounds of the institution filter
    req.set_institution(institution);
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    static const CallSpec spec{"live.list",
                               {StoreRole::kAdmin, StoreRole::kSupervisor},
                               "list live sessions",
                               /*audit_every_call=*/false};
    std::vector<LiveSessionInfo> live;
    s = RunCall(
        deps_, who, spec, institution.empty() ? who.institution : institution, [&]() -> Status {
          const std::string scope =
              institution.empty() && who.role != StoreRole::kAdmin ? who.institution : institution;
          if (!scope.empty()) {
            AuthStatus a = RequireInstitution(who, scope, "list live sessions");
            if (!a.ok()) return ToGrpcStatus(a);
          }
          if (deps_.live != nullptr) live = deps_.live->List(scope);
          return Status::OK;
        });
    if (!s.ok()) return ErrorOf(s);
    json out = json::array();
    const int64_t now = NowUnixMs();
    for (const LiveSessionInfo& l : live) {
      out.push_back({{"session_uuid", l.session_uuid},
                     {"institution", l.institution},
                     {"trainee_id", l.trainee_id},
                     {"case_id", l.case_id},
                     {"case_version", l.case_version},
                     {"station", l.station},
                     {"started_unix_ms", l.started_unix_ms},
                     {"last_frame_unix_ms", l.last_frame_unix_ms},
                     {"frames", l.frames},
                     {"station_dropped", l.station_dropped},
                     {"t_s", l.t_s},
                     {"remote", !l.origin_replica.empty()},
                     {"now_unix_ms", now}});
    }
    return JsonReply(200, {{"live", out}});
  }
  if (path.size() == 2 && path[0] == "live" && path[1] == "ws") {
    return Error(426, "FAILED_PRECONDITION",
                 "live/ws: a WebSocket endpoint (Upgrade: websocket), docs/web.md");
  }

  // stations: last seen, version and health as their uploads reported them
  if (path.size() == 1 && path[0] == "stations") {
    v1::ListStationsRequest req;
    req.set_institution(institution);
    req.set_page_size(static_cast<uint32_t>(page_size));
    req.set_page_token(page_token);
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    v1::ListStationsResponse resp;
    s = ListStationsCall(deps_, who, req, &resp);
    if (!s.ok()) return ErrorOf(s);
    json stations = json::array();
    for (const auto& st : resp.stations()) {
      json row = {{"station_id", st.station_id()},
                  {"institution", st.institution()},
                  {"last_seen_unix_ms", st.last_seen_unix_ms()},
                  {"software_version", st.software_version()},
                  {"health", nullptr},
                  {"flags", json::array()}};
      if (st.has_health()) {
        json health = StationHealthJson(st.health());
        health["session_uuid"] = st.health_session_uuid();
        health["session_end_unix_ms"] = st.health_session_end_unix_ms();
        row["health"] = std::move(health);
        row["flags"] = StationHealthFlags(st.health());
      }
      stations.push_back(std::move(row));
    }
    return JsonReply(200, {{"stations", stations},
                           {"next_page_token", resp.next_page_token()},
                           {"now_unix_ms", NowUnixMs()}});
  }

  // audit: newest first, filtered by actor, action and time, paged
  if (path.size() == 1 && path[0] == "audit") {
    v1::ListAuditRequest req;  // the page token's bounds
    req.set_page_token(page_token);
    patient_db::AuditQuery q;
    uint64_t from = 0, to = 0, limit = 0;
    if (!QueryNumber(query, "from_unix_ms", INT64_MAX, &from, &bad)) return bad;
    if (!QueryNumber(query, "since_unix_ms", INT64_MAX, &from, &bad)) return bad;  // older name
    if (!QueryNumber(query, "to_unix_ms", INT64_MAX, &to, &bad)) return bad;
    if (!QueryNumber(query, "limit", patient_db::kMaxPageSize, &limit, &bad)) return bad;
    if (page_size > 0) limit = page_size;
    for (const auto& [name, field] : {std::pair{"actor", &q.actor}, {"action", &q.action}}) {
      *field = QueryText(query, name);
      if (!field->empty() && !patient_db::IsPrintableId(*field)) {
        return Error(400, "INVALID_ARGUMENT",
                     std::string("query ") + name + " = '" +
                         patient_db::PrintableExcerpt(*field, 40) + "': must be 1.." +
                         std::to_string(patient_db::kMaxIdBytes) + " printable characters");
      }
    }
    if (to != 0 && to <= from) {
      return Error(400, "INVALID_ARGUMENT",
                   "query to_unix_ms = " + std::to_string(to) +
                       ": must be after from_unix_ms = " + std::to_string(from));
    }
    q.from_unix_ms = static_cast<int64_t>(from);
    q.to_unix_ms = static_cast<int64_t>(to);
    Status s = admit(req);
    if (!s.ok()) return ErrorOf(s);
    // The rules of Admin.ListAudit: admins only, reading it is not audited
    // (every page would write to it), refusals are.
    static const CallSpec spec{"audit.list",
                               {StoreRole::kAdmin},
                               "read the audit log",
                               /*audit_every_call=*/false};
    std::vector<patient_db::AuditRow> rows;
    std::string next;
    s = RunCall(deps_, who, spec, "", [&]() -> Status {
      const int size = PageSizeOf(static_cast<uint32_t>(limit), patient_db::kDefaultPageSize);
      patient_db::ListPage after;
      Status token = ReadPageToken(page_token, "audit-newest", &after);
      if (!token.ok()) return token;
      q.before_id = after.has_after ? after.after_number : 0;
      q.limit = size + 1;
      auto listed = deps_.store->ListAuditNewest(q);
      if (!listed.ok()) return ToGrpcStatus(listed.status);
      rows = std::move(listed.value);
      if (static_cast<int>(rows.size()) > size) {
        rows.resize(size);
        next = MakePageToken("audit-newest", rows.back().id, "");
      }
      return Status::OK;
    });
    if (!s.ok()) return ErrorOf(s);
    json entries = json::array();
    for (const auto& r : rows) {
      StoreRole role = StoreRole::kTrainee;
      entries.push_back(
          {{"id", r.id},
           {"at_unix_ms", r.at_unix_ms},
           {"actor", r.actor},
           {"actor_label", r.actor_label},
           {"role", patient_db::ParseRoleName(r.role, &role) ? v1::Role_Name(ToProtoRole(role))
                                                             : "ROLE_UNSPECIFIED"},
           {"institution", r.institution},
           {"action", r.action},
           {"target", r.target},
           {"result", r.result}});
    }
    return JsonReply(200, {{"entries", entries}, {"next_page_token", next}});
  }
  return Error(404, "NOT_FOUND",
               "no API route '" + patient_db::PrintableExcerpt(raw_path, 80) + "' (docs/web.md)");
}

nlohmann::json StationHealthJson(const v1::StationHealth& h) {
  const bool timed = h.loop_cycles() > 0;  // headless runs have no loop timing
  json health = {{"device", h.device()},
                 {"loop_cycle_p99_us", timed ? json(h.loop_cycle_p99_us()) : json(nullptr)},
                 {"loop_budget_us", h.loop_budget_us()}};
  for (const auto& [name, get] : kStationHealthCounts) health[name] = (h.*get)();
  return health;
}

std::vector<std::string> StationHealthFlags(const v1::StationHealth& h) {
  std::vector<std::string> flags;
  if (h.loop_cycles() > 0 && h.loop_cycle_p99_us() > h.loop_budget_us()) {
    flags.push_back("loop_p99");
  }
  if (h.loop_overruns() > 0) flags.push_back("overruns");
  if (h.safe_state_entries() + h.force_pauses() > 0) flags.push_back("safe_state");
  if (h.can_bus_errors() + h.can_lost_frames() + h.can_send_failures() + h.can_malformed_frames() >
      0) {
    flags.push_back("can_errors");
  }
  return flags;
}

const std::vector<std::string>& SessionsCsvColumns() {
  static const std::vector<std::string> columns = {
      "session_uuid",   "trainee_id",    "case_id",    "case_version", "lesson_id",
      "lesson_verdict", "lesson_checks", "station_id", "operator",     "start_utc",
      "end_utc",        "duration_s",    "outcome",    "completed",    "time_to_cecum_s",
      "pain_s",         "max_tip_arc_m", "score",      "loop_s",       "xray_s"};
  return columns;
}

std::string SessionsCsv(const std::vector<patient_db::SessionRow>& sessions,
                        const std::vector<patient_db::LessonVerdictRow>& verdicts) {
  std::map<std::string, const patient_db::LessonVerdictRow*> verdict_of;
  for (const auto& v : verdicts) verdict_of[v.session_uuid] = &v;
  std::string out;
  const auto line = [&out](const std::vector<std::string>& cells) {
    for (size_t i = 0; i < cells.size(); ++i) {
      if (i > 0) out += ',';
      out += cells[i];
    }
    out += "\r\n";
  };
  line(SessionsCsvColumns());
  for (const auto& s : sessions) {
    std::string verdict, checks;
    if (!s.lesson_id.empty()) {
      auto it = verdict_of.find(s.uuid);
      if (it == verdict_of.end()) {
        verdict = "pending";  // the judge has not replayed it yet
      } else {
        verdict = it->second->rejected ? "rejected" : it->second->passed ? "passed" : "failed";
        for (const std::string& check : Split(it->second->detail, '\n')) {
          if (check.empty()) continue;
          checks += (checks.empty() ? "" : "; ") + check;
        }
      }
    }
    line({CsvText(s.uuid), CsvText(s.trainee_id), CsvText(s.case_id),
          std::to_string(s.case_version), CsvText(s.lesson_id), verdict, CsvText(checks),
          CsvText(s.station_id), CsvText(s.operator_kind), IsoUtc(s.start_unix_ms),
          IsoUtc(s.end_unix_ms), CsvNumber((s.end_unix_ms - s.start_unix_ms) / 1000.0, 3),
          OutcomeText(s.outcome), s.completed ? "true" : "false",
          s.completed ? CsvNumber(s.time_to_cecum_s, 3) : "", CsvNumber(s.pain_s, 3),
          CsvNumber(s.max_tip_arc_m, 4), CsvNumber(s.score, 2),
          s.loop_s >= 0 ? CsvNumber(s.loop_s, 3) : "", s.xray_s >= 0 ? CsvNumber(s.xray_s, 3) : ""});
  }
  return out;
}

HttpReply WebApi::LiveWatch(const HttpRequest& request, std::string* session_uuid,
                            std::shared_ptr<LiveViewer>* viewer) {
  if (request.target.size() > kMaxHttpTargetBytes) {
    return Error(414, "INVALID_ARGUMENT", "request target: over the limit");
  }
  const size_t qmark = request.target.find('?');
  if (request.target.substr(0, qmark) != "/api/v1/live/ws") {
    return Error(404, "NOT_FOUND", "WebSocket only at /api/v1/live/ws?session=UUID");
  }
  // A page of another origin may open a WebSocket with our cookie where
  // SameSite does not hold (old browsers): the origin must be our own.
  if (!request.origin.empty() && request.origin != "http://" + request.host &&
      request.origin != "https://" + request.host) {
    return Error(
        403, "PERMISSION_DENIED",
        "Origin '" + patient_db::PrintableExcerpt(request.origin, 80) + "': not this server's");
  }
  std::string uuid;
  if (qmark != std::string::npos) {
    for (const std::string& pair : Split(std::string_view(request.target).substr(qmark + 1), '&')) {
      if (pair.rfind("session=", 0) == 0 && !Decode(pair.substr(8), &uuid, true)) {
        return Error(400, "INVALID_ARGUMENT", "query: a broken %-escape");
      }
    }
  }
  if (uuid.empty()) return Error(400, "INVALID_ARGUMENT", "query: session=UUID missing");
  bool csrf_ok = true;
  std::string sid;
  const std::string authorization = AuthorizationOf(request, &csrf_ok, &sid);
  v1::GetSessionRequest bounds;  // the uuid's bounds, as for a stored session
  bounds.set_uuid(uuid);
  Principal who;
  Status s = AdmitRequest(deps_, authorization, bounds, &who);
  if (!s.ok()) return ErrorOf(s);
  static const CallSpec spec{
      "live.watch", {StoreRole::kAdmin, StoreRole::kSupervisor}, "watch live sessions"};
  s = RunCall(deps_, who, spec, uuid, [&]() -> Status {
    LiveSessionInfo info;
    if (deps_.live == nullptr || !deps_.live->Find(uuid, &info)) {
      return Status(StatusCode::NOT_FOUND, "session " + uuid + " is not live");
    }
    AuthStatus a = RequireInstitution(who, info.institution, "watch");
    if (!a.ok()) return ToGrpcStatus(a);
    std::string why;
    *viewer = deps_.live->Watch(uuid, &why);
    if (!*viewer) return Status(StatusCode::RESOURCE_EXHAUSTED, why);
    return Status::OK;
  });
  if (!s.ok()) return ErrorOf(s);
  *session_uuid = uuid;
  HttpReply ok;
  ok.status = 101;
  return ok;
}

void WebApi::LiveUnwatch(const std::string& session_uuid,
                         const std::shared_ptr<LiveViewer>& viewer) {
  if (deps_.live != nullptr) deps_.live->Unwatch(session_uuid, viewer);
}

std::shared_ptr<const SessionReplay> WebApi::CachedReplay(const std::string& uuid,
                                                          const v1::SessionRecord& record) {
  {
    std::lock_guard lock(mutex_);
    for (auto it = replays_.begin(); it != replays_.end(); ++it) {
      if (it->first == uuid) {
        replays_.splice(replays_.begin(), replays_, it);
        return replays_.front().second;
      }
    }
  }
  {
    std::lock_guard lock(mutex_);
    if (replays_running_ >= kMaxConcurrentReplays) return nullptr;
    ++replays_running_;
  }
  std::shared_ptr<const SessionReplay> replay;
  try {
    replay = std::make_shared<const SessionReplay>(ReplaySession(record));
  } catch (...) {
    std::lock_guard lock(mutex_);
    --replays_running_;
    throw;
  }
  std::lock_guard lock(mutex_);
  --replays_running_;
  replays_.emplace_front(uuid, replay);
  if (replays_.size() > 8) replays_.pop_back();
  return replay;
}

}  // namespace ves::server
