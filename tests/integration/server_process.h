#pragma once

#include <sys/types.h>

#include <filesystem>
#include <string>

// The real ves-server binary as a child process, for the multi-process tests
// (durability, replicas). Needs VES_SERVER_PATH (tests/integration/CMakeLists.txt).
namespace ves::server::testing {

struct ServerProcess {
  pid_t pid = -1;
  int port = 0;       // gRPC
  int http_port = 0;  // web API and WebSocket, when started with one
  std::string log;    // its stdout and stderr
  std::string address() const { return "127.0.0.1:" + std::to_string(port); }
};

// ves-server --listen 127.0.0.1:0 --db `db_url`, plaintext on loopback, quiet,
// with --http 127.0.0.1:0 when `with_http`. Its port files and log are in
// `dir`, named with `tag` (port<tag>, http<tag>, server<tag>.log; old port
// files are removed first, so a restart reads the new ports). It dies with
// this process. Waits up to 10 s for the ports; they stay 0 if it did not start.
ServerProcess StartServerProcess(const std::string& db_url, const std::filesystem::path& dir,
                                 const std::string& tag, bool with_http = false);

// Sends `signal` and reaps the process: its wait status, or -1 when it was
// not running or the signal could not be sent.
int StopServerProcess(ServerProcess* server, int signal);

}  // namespace ves::server::testing
