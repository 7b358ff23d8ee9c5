#include "server/web_api.h"

#include <nlohmann/json.hpp>

#include "patient_db/limits.h"
#include "server/live_hub.h"
#include "server/pipeline.h"
#include "server/web_assets.h"
#include "server/web_reply.h"
#include "server/web_routes.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;

namespace {

HttpReply Healthz(WebCall&) { return JsonReply(200, {{"status", "ok"}}); }

HttpReply Page(WebCall& call) {
  auto it = call.params.find("page");
  const std::string path = it == call.params.end() ? "/index.html" : "/" + it->second;
  const WebAsset* asset = FindWebAsset(path);
  if (asset == nullptr)
    return Error(404, "NOT_FOUND", "no page '" + patient_db::PrintableExcerpt(path, 80) + "'");
  HttpReply r;
  r.content_type = asset->content_type;
  r.body.assign(asset->data, asset->size);
  r.headers.emplace_back("Cache-Control", "no-cache");
  return r;
}

bool IsApi(const std::string& path) { return path.rfind("/api/v1/", 0) == 0; }

// Whether `route` answers `request`'s method.
bool AnswersMethod(const WebRoute& route, const HttpRequest& request) {
  const std::string method = request.websocket ? "WS" : request.method;
  if (method == route.method) return true;
  return method == "HEAD" && std::string(route.method) == "GET" && !IsApi(route.pattern);
}

// The query string as a map; false with a 400 in *error.
bool ParseQuery(std::string_view text, std::map<std::string, std::string>* query,
                HttpReply* error) {
  for (const std::string& pair : SplitText(text, '&')) {
    if (pair.empty()) continue;
    const size_t eq = pair.find('=');
    std::string key, value;
    if (!PercentDecode(pair.substr(0, eq), &key, true) ||
        !PercentDecode(eq == std::string::npos ? "" : pair.substr(eq + 1), &value, true)) {
      *error = Error(400, "INVALID_ARGUMENT", "query: a broken %-escape");
      return false;
    }
    if (query->size() >= 16) {
      *error = Error(400, "INVALID_ARGUMENT", "query: over 16 parameters");
      return false;
    }
    (*query)[key] = value;
  }
  return true;
}

}  // namespace

const std::vector<WebRoute>& WebRoutes() {
  static const std::vector<WebRoute> routes = [] {
    std::vector<WebRoute> all = {{"GET", "/healthz", {}, &Healthz}};
    for (auto part : {&SignInRoutes, &RecordRoutes, &CurveRoutes, &CohortRoutes,
                      &WorkflowRoutes, &AdminRoutes, &LiveRoutes}) {
      for (WebRoute& r : part()) all.push_back(std::move(r));
    }
    all.push_back({"GET", "/", {}, &Page});
    all.push_back({"GET", "/{page}", {}, &Page});
    return all;
  }();
  return routes;
}

bool MatchPattern(const std::string& pattern, const std::string& path,
                  std::map<std::string, std::string>* params) {
  const std::vector<std::string> want = SplitText(pattern, '/');
  const std::vector<std::string> got = SplitText(path, '/');
  if (want.size() != got.size()) return false;
  std::map<std::string, std::string> found;
  for (size_t i = 0; i < want.size(); ++i) {
    const std::string& w = want[i];
    if (w.size() > 2 && w.front() == '{' && w.back() == '}') {
      if (got[i].empty()) return false;
      found[w.substr(1, w.size() - 2)] = got[i];
    } else if (w != got[i]) {
      return false;
    }
  }
  *params = std::move(found);
  return true;
}

Status WebCall::Admit(const google::protobuf::Message& bounds) {
  admitted = true;
  Status s = AdmitRequest(deps, authorization, bounds, &who);
  if (!s.ok()) return s;
  if (!csrf_ok) return Status(StatusCode::PERMISSION_DENIED, "X-CSRF-Token header missing or wrong");
  return s;
}

const std::string& WebCall::Param(const std::string& name) const {
  static const std::string kNone;
  auto it = params.find(name);
  return it == params.end() ? kNone : it->second;
}

std::string WebCall::Query(const std::string& name) const { return QueryText(query, name); }

WebApi::WebApi(ServiceDeps deps, WebOptions options) : deps_(deps), options_(options) {
  if (options_.oidc.enabled()) oidc_ = std::make_unique<OidcClient>(options_.oidc);
}

HttpReply WebApi::Handle(const HttpRequest& request) { return Dispatch(request, nullptr); }

HttpReply WebApi::LiveWatch(const HttpRequest& request, std::string* session_uuid,
                            std::shared_ptr<LiveViewer>* viewer) {
  HttpRequest upgrade = request;
  upgrade.websocket = true;
  LiveWatchSlot slot;
  HttpReply reply = Dispatch(upgrade, &slot);
  if (reply.status == 101) {
    *session_uuid = slot.session_uuid;
    *viewer = slot.viewer;
  }
  return reply;
}

void WebApi::LiveUnwatch(const std::string& session_uuid,
                         const std::shared_ptr<LiveViewer>& viewer) {
  if (deps_.live != nullptr) deps_.live->Unwatch(session_uuid, viewer);
}

HttpReply WebApi::Dispatch(const HttpRequest& request, LiveWatchSlot* live) {
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
  const std::string path = request.target.substr(0, qmark);
  std::map<std::string, std::string> query;
  HttpReply bad;
  if (qmark != std::string::npos &&
      !ParseQuery(std::string_view(request.target).substr(qmark + 1), &query, &bad)) {
    return bad;
  }
  const bool api = IsApi(path);
  if (api && request.method == "POST" && request.content_type.rfind("application/json", 0) != 0) {
    // Forms cannot send JSON across origins without a preflight.
    return Error(415, "INVALID_ARGUMENT", "Content-Type: must be application/json");
  }
  std::string methods;  // of the routes whose pattern matches
  for (const WebRoute& route : WebRoutes()) {
    std::map<std::string, std::string> params;
    if (!MatchPattern(route.pattern, path, &params)) continue;
    if (AnswersMethod(route, request)) {
      HttpReply r = Route(route, request, params, std::move(query), live);
      if (api) r.headers.emplace_back("Cache-Control", "no-store");
      return r;
    }
    if (methods.find(route.method) == std::string::npos) {
      methods += (methods.empty() ? "" : ", ") + std::string(route.method);
    }
  }
  const std::string shown = patient_db::PrintableExcerpt(path, 80);
  if (methods == "WS") {
    return Error(426, "FAILED_PRECONDITION",
                 shown + ": a WebSocket endpoint (Upgrade: websocket), docs/web.md");
  }
  if (!methods.empty()) {
    return Error(405, "METHOD_NOT_ALLOWED", shown + ": answers " + methods);
  }
  if (api) return Error(404, "NOT_FOUND", "no API route '" + shown + "' (docs/web.md)");
  if (request.method != "GET" && request.method != "HEAD") {
    return Error(405, "METHOD_NOT_ALLOWED", "pages answer GET only");
  }
  return Error(404, "NOT_FOUND", "no page '" + shown + "'");
}

HttpReply WebApi::Route(const WebRoute& route, const HttpRequest& request,
                        const std::map<std::string, std::string>& raw_params,
                        std::map<std::string, std::string> query, LiveWatchSlot* live) {
  WebCall call{*this, deps_, request};
  call.query = std::move(query);
  call.live = live;
  for (const auto& [name, raw] : raw_params) {
    if (!PercentDecode(raw, &call.params[name], false)) {
      return Error(400, "INVALID_ARGUMENT", "path: a broken %-escape");
    }
  }
  if (route.roles.empty()) return route.handler(call);
  call.authorization = AuthorizationOf(request, &call.csrf_ok, &call.session_id);
  HttpReply bad;
  if (!QueryNumber(call.query, "page_size", patient_db::kMaxPageSize, &call.page_size, &bad)) {
    return bad;
  }
  HttpReply reply = route.handler(call);
  if (!call.admitted && reply.status < 400) {
    // A route that answers without admitting its request has skipped the pipeline.
    return Error(500, "INTERNAL", std::string(route.pattern) + ": answered outside the pipeline");
  }
  return reply;
}

std::string WebApi::CsrfTokenOf(const std::string& session_id) {
  std::lock_guard lock(mutex_);
  auto it = sessions_.find(session_id);
  return it == sessions_.end() ? std::string() : it->second.csrf_token;
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
