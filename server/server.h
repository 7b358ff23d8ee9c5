#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <memory>
#include <string>

#include "patient_db/store.h"
#include "server/auth.h"
#include "server/http_server.h"
#include "server/live_hub.h"
#include "server/live_pg_relay.h"
#include "server/live_service.h"
#include "server/oidc.h"
#include "server/services.h"
#include "server/session_series.h"
#include "server/session_writer.h"

// The ves-server process in a class: services, group-commit writer, TLS,
// limits, keepalive, per-call log and draining shutdown (docs/server.md).
namespace ves::server {

struct ServerOptions {
  std::string listen = "127.0.0.1:50051";  // host:port; port 0 picks a free one
  std::string tls_cert_file;               // PEM; with tls_key_file enables TLS
  std::string tls_key_file;
  std::string tls_client_ca_file;          // PEM; when set, clients must present a cert it signed
  bool insecure_loopback = false;          // plaintext, allowed only on a loopback address
  int max_receive_message_bytes = 16 << 20;
  int max_send_message_bytes = 16 << 20;
  bool log_calls = true;                   // one spdlog line per call
  training::JudgeBudget judge_budget;      // what judging one lesson session may cost
  // host:port of the web front end and JSON API (docs/web.md); empty: none.
  // HTTPS with the TLS files above; plain HTTP only on a loopback address.
  std::string http_listen;
  // libpq URI of the store's PostgreSQL: live sessions are shared with the
  // other replicas on it (LivePgRelay, docs/web.md). Empty: this replica's
  // only (SQLite: one process).
  std::string live_relay_url;
  // The hospital's identity provider for the web pages (docs/web.md); none
  // when its issuer is empty.
  OidcConfig oidc = {};
};

// Checks the TLS/plaintext choice and reads the PEM files. Throws
// std::invalid_argument with one clear line when the options are refused
// (plaintext off loopback, plaintext without --insecure-loopback, a cert
// without a key, an unreadable file).
std::shared_ptr<grpc::ServerCredentials> MakeServerCredentials(const ServerOptions& options);

class VesServer {
 public:
  VesServer(ServerOptions options, std::unique_ptr<patient_db::Store> store);
  ~VesServer();

  // Binds and starts serving; throws std::runtime_error when the address
  // cannot be bound, std::invalid_argument for refused options.
  void Start();
  int port() const { return port_; }
  int http_port() const { return http_ ? http_->port() : 0; }
  patient_db::Store& store() { return *store_; }
  Authenticator& auth() { return *auth_; }
  // Stops accepting calls, lets in-flight calls finish for up to `grace`
  // (then cancels them), commits what the writer holds. Idempotent.
  void Shutdown(std::chrono::milliseconds grace);
  uint64_t commit_batches() const { return writer_->batches(); }
  LessonJudge& judge() { return *judge_; }
  SessionSeries& series() { return *series_; }

 private:
  ServerOptions options_;
  std::unique_ptr<patient_db::Store> store_;
  std::unique_ptr<SessionWriter> writer_;
  std::unique_ptr<Authenticator> auth_;
  std::unique_ptr<LiveHub> live_;  // before the services that point to it
  std::unique_ptr<LivePgRelay> relay_;  // points to live_
  std::unique_ptr<CasesService> cases_;
  std::unique_ptr<SessionsService> sessions_;
  std::unique_ptr<TraineesService> trainees_;
  std::unique_ptr<AdminService> admin_;
  std::unique_ptr<SessionSeries> series_;  // before judge_, which hands it sessions
  std::unique_ptr<LessonJudge> judge_;
  std::unique_ptr<LessonsService> lessons_;
  std::unique_ptr<LiveService> live_service_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<HttpServer> http_;
  int port_ = 0;
  bool shut_down_ = false;
};

}  // namespace ves::server
