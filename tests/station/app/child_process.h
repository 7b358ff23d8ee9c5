#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

// Real VES programs as child processes for the station's end-to-end tests:
// stdout and stderr go to files, every wait is bounded.
namespace ves::station::testing {

struct ProcessResult {
  int exit_code{-1};    // when it exited
  int term_signal{0};   // when a signal ended it
  bool timed_out{false};
  std::string out;
  std::string err;
};

class ChildProcess {
 public:
  // Starts argv[0] with argv; `env` entries (NAME=VALUE) are added to ours.
  // Output goes to `log_stem`.out / .err.
  ChildProcess(const std::vector<std::string>& argv, const std::filesystem::path& log_stem,
               const std::vector<std::string>& env = {});
  ~ChildProcess();  // SIGKILLs and reaps a child still running
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  bool Running();
  // Waits up to `timeout` (then SIGKILL) and collects the output.
  ProcessResult Wait(std::chrono::seconds timeout = std::chrono::seconds(120));
  // SIGTERM, then Wait.
  ProcessResult Stop(std::chrono::seconds timeout = std::chrono::seconds(30));

 private:
  pid_t pid_{-1};
  bool reaped_{false};
  int status_{0};
  std::filesystem::path log_stem_;
};

// Runs to completion (bounded) and returns the result.
ProcessResult RunProgram(const std::vector<std::string>& argv, const std::filesystem::path& log_stem,
                         const std::vector<std::string>& env = {},
                         std::chrono::seconds timeout = std::chrono::seconds(120));

std::string ReadFile(const std::filesystem::path& path);
std::filesystem::path MakeTempDir(const std::string& tag);

}  // namespace ves::station::testing
