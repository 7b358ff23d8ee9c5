#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "tests/station/app/child_process.h"

// A real ves-server on 127.0.0.1 (SQLite in a temp folder) set up with
// ves-admin like deploy/demo.sh does: an institution, station and supervisor
// tokens, a trainee and the standard-adult case. Stations are real
// ves-station processes. Binaries come from the build (VES_BINARY_DIR).
namespace ves::station::testing {

inline const std::string kStationBin = VES_BINARY_DIR "/station/app/ves-station";
inline const std::string kServerBin = VES_BINARY_DIR "/server/ves-server";
inline const std::string kAdminBin = VES_BINARY_DIR "/server/ves-admin";
inline const std::string kCaseFile = VES_SOURCE_DIR "/patient_db/cases/standard-adult.textproto";
inline constexpr char kTrainee[] = "trainee-7";
// Short sessions: the tests are about the station's plumbing, not the score.
inline constexpr char kSessionSeconds[] = "6";

class StationFixture : public ::testing::Test {
 protected:
  void SetUp() override;
  void TearDown() override;

  // Starts ves-server on `port` (0: a free one) over the fixture's database;
  // with `http`, also its web listener on a free loopback port (http_port_).
  void StartServer(int port = 0, bool http = false);
  void StopServer();
  ProcessResult Admin(std::vector<std::string> args);
  // `ves-station ARGS`; `env` NAME=VALUE added.
  ProcessResult Station(std::vector<std::string> args, const std::vector<std::string>& env = {});
  // A headless run (server options included when `with_server`).
  std::vector<std::string> RunArgs(const std::string& operator_kind,
                                   const std::filesystem::path& data_dir,
                                   const std::filesystem::path& out_dir,
                                   bool with_server = true) const;
  // Number of standard-adult sessions `ves-admin scores` lists for the trainee.
  int SessionsOnServer();
  bool SessionOnServer(const std::string& uuid);

  std::filesystem::path dir_;
  std::string db_;
  std::string address_;
  int port_{0};
  int http_port_{0};
  std::string admin_token_;
  std::string station_token_;
  std::string supervisor_token_;
  std::unique_ptr<ChildProcess> server_;
  int log_counter_{0};
};

// The UUID from "session <uuid> committed to the outbox", or "".
std::string CommittedUuid(const std::string& station_stdout);
// "pending uploads: N" from `ves-station status`, or -1.
int PendingUploads(const std::string& status_stdout);

}  // namespace ves::station::testing
