#pragma once

#include <chrono>
#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <utility>
#include <vector>

#include "server/accounts.h"
#include "server/oidc.h"
#include "server/services.h"
#include "server/session_replay.h"

// The HTTP side of ves-server without the sockets (docs/web.md): the route
// table's dispatch (server/web_routes.h), browser sessions (cookie + CSRF
// token), JSON in and out. Every /api/v1/ call goes through the request
// pipeline (server/pipeline.h), as gRPC does.
namespace ves::server {

class LiveViewer;

// Bounds on what a request may carry (docs/web.md, "Limits").
inline constexpr size_t kMaxHttpHeaderBytes = 8 << 10;
inline constexpr size_t kMaxHttpBodyBytes = 64 << 10;
inline constexpr size_t kMaxHttpTargetBytes = 2048;
inline constexpr size_t kMaxWebSessions = 10000;
// Replays re-run the model (seconds of CPU each): at most this many at once,
// more answer 429 rather than queue up on the connection threads.
inline constexpr int kMaxConcurrentReplays = 2;

struct HttpRequest {
  std::string method;         // "GET", "POST", ...
  std::string target;         // path and query, as sent
  std::string authorization;  // the Authorization header ("" when absent)
  std::string cookie;         // the Cookie header
  std::string csrf_token;     // the X-CSRF-Token header
  std::string content_type;
  std::string body;
  std::string origin;  // the Origin header (WebSocket upgrades)
  std::string host;    // the Host header
  std::string peer;    // the client's "ADDRESS:PORT" (sign-in throttling)
  bool websocket = false;  // a WebSocket upgrade (routes with method "WS")
};

struct HttpReply {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;  // extra ones (Set-Cookie, ...)
};

struct WebOptions {
  bool secure_cookies = false;                 // Secure flag: on over HTTPS
  std::chrono::seconds session_ttl{8 * 3600};  // a browser session's life
  OidcConfig oidc = {};                        // the identity provider (none: issuer empty)
};

// The cookie of a sign-in through the identity provider, while under way.
inline constexpr char kOidcCookieName[] = "ves_oidc";

// What the stations page flags in a station's latest health (docs/web.md,
// "Stations"): "loop_p99" (a measured loop's p99 over its budget),
// "overruns", "safe_state" (any safe-state entry or force pause) and
// "can_errors" (any CAN error, lost, unsent or malformed frame). Pure.
std::vector<std::string> StationHealthFlags(const v1::StationHealth& health);

// A station's health as the API shows it (docs/web.md): the device, the
// loop's p99 (null when not timed: simulated time) and budget, and every
// counter of kStationHealthCounts as a number. Pure.
nlohmann::json StationHealthJson(const v1::StationHealth& health);

// The header of a sessions CSV export (docs/web.md, "Export"), its columns
// in order, and the export itself: one row per session of `sessions` (in
// their order) with its lesson verdict from `verdicts` (any order), RFC 4180
// quoting, CRLF line ends, text cells that a spreadsheet would take for a
// formula (=, +, -, @ first) prefixed with '. Pure.
const std::vector<std::string>& SessionsCsvColumns();
std::string SessionsCsv(const std::vector<patient_db::SessionRow>& sessions,
                        const std::vector<patient_db::LessonVerdictRow>& verdicts);

struct LiveWatchSlot;
struct WebCall;
struct WebRoute;

class WebApi {
 public:
  WebApi(ServiceDeps deps, WebOptions options);
  // Bounds of the request (target, body), then its route in the table
  // (server/web_routes.h) and the route's handler.
  HttpReply Handle(const HttpRequest& request);

  // A WebSocket upgrade (docs/web.md): through the route table as Handle,
  // to the routes of method "WS" (/api/v1/live/ws?session=UUID: admitted,
  // role supervisor or admin, the session's institution, audited); status
  // 101 with `viewer` set, else the refusal.
  HttpReply LiveWatch(const HttpRequest& request, std::string* session_uuid,
                      std::shared_ptr<LiveViewer>* viewer);
  void LiveUnwatch(const std::string& session_uuid, const std::shared_ptr<LiveViewer>& viewer);

  // JSON text with '<', '>' and '&' written as \u escapes: a value can never
  // close a <script> or start a tag wherever the text lands.
  static std::string HtmlSafeJson(std::string json);

  // What the route handlers (server/web_*.cc) reach of the browser sessions.
  HttpReply SignIn(const HttpRequest& request);
  HttpReply SignOut(WebCall& call);
  bool oidc_enabled() const { return oidc_ != nullptr; }
  // The identity provider's sign-in (web_oidc.cc): to the provider and back.
  HttpReply OidcStart();
  HttpReply OidcCallback(const HttpRequest& request,
                         const std::map<std::string, std::string>& query);
  // The CSRF token of browser session `session_id` ("" when none).
  std::string CsrfTokenOf(const std::string& session_id);
  // The authorization value for this request: the Bearer header, or the
  // browser session's token. `csrf_ok` tells whether a state-changing
  // request may go on (Bearer requests need no CSRF token).
  std::string AuthorizationOf(const HttpRequest& request, bool* csrf_ok, std::string* session_id);
  // The replay (cached or computed); nullptr when kMaxConcurrentReplays run.
  std::shared_ptr<const SessionReplay> CachedReplay(const std::string& uuid,
                                                    const v1::SessionRecord& record);

 private:
  struct WebSession {
    std::string token;  // the bearer token it stands for (memory only)
    std::string csrf_token;
    int64_t expires_unix_ms = 0;
  };
  // The route table's answer; `live` receives what a WebSocket route hands
  // over (null for plain requests).
  HttpReply Dispatch(const HttpRequest& request, LiveWatchSlot* live);
  HttpReply Route(const WebRoute& route, const HttpRequest& request,
                  const std::map<std::string, std::string>& raw_params,
                  std::map<std::string, std::string> query, LiveWatchSlot* live);
  // An account sign-in's outcome as the reply (audited either way).
  HttpReply StartWebSession(const SignInOutcome& outcome, const std::string& peer);
  // A browser session for `token` (a bearer token or an account's secret).
  HttpReply NewWebSession(const std::string& token, const Principal& who,
                          const std::string& audit_target);
  std::string OidcCookie(const std::string& login_id, int64_t max_age_s) const;

  ServiceDeps deps_;
  WebOptions options_;
  std::unique_ptr<OidcClient> oidc_;  // null: no identity provider configured
  std::mutex mutex_;
  std::map<std::string, WebSession> sessions_;  // by session id; guarded by mutex_
  // A few recent replays by uuid (a replay re-runs the model: seconds).
  std::list<std::pair<std::string, std::shared_ptr<const SessionReplay>>> replays_;
  int replays_running_ = 0;  // guarded by mutex_
};

}  // namespace ves::server
