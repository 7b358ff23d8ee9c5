#include "tests/integration/server_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <thread>
#include <vector>

namespace ves::server::testing {

ServerProcess StartServerProcess(const std::string& db_url, const std::filesystem::path& dir,
                                 const std::string& tag, bool with_http) {
  const std::string port_file = (dir / ("port" + tag)).string();
  const std::string http_file = (dir / ("http" + tag)).string();
  std::filesystem::remove(port_file);
  std::filesystem::remove(http_file);
  ServerProcess server;
  server.log = (dir / ("server" + tag + ".log")).string();
  std::vector<const char*> argv = {"ves-server", "--listen", "127.0.0.1:0", "--db",
                                   db_url.c_str(), "--insecure-loopback", "--quiet",
                                   "--port-file", port_file.c_str()};
  if (with_http) {
    for (const char* a : {"--http", "127.0.0.1:0", "--http-port-file"}) argv.push_back(a);
    argv.push_back(http_file.c_str());
  }
  argv.push_back(nullptr);
  server.pid = ::fork();
  if (server.pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlive the test
    const int fd = ::open(server.log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::execv(VES_SERVER_PATH, const_cast<char* const*>(argv.data()));
    ::_exit(127);
  }
  const auto started = [&] {
    return std::filesystem::exists(port_file) && (!with_http || std::filesystem::exists(http_file));
  };
  for (int i = 0; i < 400 && !started(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  std::ifstream(port_file) >> server.port;
  if (with_http) std::ifstream(http_file) >> server.http_port;
  return server;
}

int StopServerProcess(ServerProcess* server, int signal) {
  if (server->pid <= 0) return -1;
  const int sent = ::kill(server->pid, signal);
  int status = 0;
  ::waitpid(server->pid, &status, 0);
  server->pid = -1;
  return sent == 0 ? status : -1;
}

}  // namespace ves::server::testing
