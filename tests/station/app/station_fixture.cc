#include "tests/station/app/station_fixture.h"

#include <regex>
#include <sstream>
#include <thread>

namespace ves::station::testing {
namespace {

std::string Trim(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' ')) {
    text.pop_back();
  }
  return text;
}

}  // namespace

void StationFixture::SetUp() {
  dir_ = MakeTempDir("station-app");
  db_ = "sqlite:" + (dir_ / "ves.db").string();
  const ProcessResult init = Admin({"init", "--db", db_, "--institution", "north"});
  ASSERT_EQ(init.exit_code, 0) << init.err;
  admin_token_ = Trim(init.out);
  StartServer();
  auto remote = [this](std::vector<std::string> args) {
    args.insert(args.end(), {"--server", address_, "--token", admin_token_});
    return Admin(args);
  };
  const ProcessResult station = remote({"token", "create", "--role", "station"});
  ASSERT_EQ(station.exit_code, 0) << station.err;
  station_token_ = Trim(station.out);
  const ProcessResult supervisor = remote({"token", "create", "--role", "supervisor"});
  ASSERT_EQ(supervisor.exit_code, 0) << supervisor.err;
  supervisor_token_ = Trim(supervisor.out);
  const ProcessResult trainee = remote({"trainee", "add", "--id", kTrainee, "--name", "T Seven"});
  ASSERT_EQ(trainee.exit_code, 0) << trainee.err;
  const ProcessResult upload = remote({"case", "upload", kCaseFile});
  ASSERT_EQ(upload.exit_code, 0) << upload.err;
}

void StationFixture::TearDown() {
  StopServer();
  std::error_code ignored;
  std::filesystem::remove_all(dir_, ignored);
}

void StationFixture::StartServer(int port, bool http) {
  const auto port_file = dir_ / "port";
  const auto http_port_file = dir_ / "http-port";
  std::filesystem::remove(port_file);
  std::filesystem::remove(http_port_file);
  std::vector<std::string> argv = {kServerBin, "--listen", "127.0.0.1:" + std::to_string(port),
                                   "--db", db_, "--insecure-loopback", "--port-file",
                                   port_file.string(), "--drain-s", "2", "--quiet"};
  if (http) {
    argv.insert(argv.end(),
                {"--http", "127.0.0.1:0", "--http-port-file", http_port_file.string()});
  }
  server_ = std::make_unique<ChildProcess>(argv, dir_ / ("server-" + std::to_string(++log_counter_)));
  for (int i = 0; i < 300 && !std::filesystem::exists(port_file); ++i) {
    ASSERT_TRUE(server_->Running()) << ReadFile(dir_ / ("server-" + std::to_string(log_counter_) +
                                                        ".err"));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(std::filesystem::exists(port_file)) << "ves-server did not start";
  port_ = std::stoi(ReadFile(port_file));
  http_port_ = 0;
  if (http) {
    for (int i = 0; i < 300 && ReadFile(http_port_file).empty(); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ASSERT_FALSE(ReadFile(http_port_file).empty()) << "ves-server wrote no --http-port-file";
    http_port_ = std::stoi(ReadFile(http_port_file));
  }
  address_ = "127.0.0.1:" + std::to_string(port_);
}

void StationFixture::StopServer() {
  if (server_) server_->Stop();
  server_.reset();
}

ProcessResult StationFixture::Admin(std::vector<std::string> args) {
  args.insert(args.begin(), kAdminBin);
  return RunProgram(args, dir_ / ("admin-" + std::to_string(++log_counter_)));
}

ProcessResult StationFixture::Station(std::vector<std::string> args,
                                      const std::vector<std::string>& env) {
  args.insert(args.begin(), kStationBin);
  return RunProgram(args, dir_ / ("station-" + std::to_string(++log_counter_)), env);
}

std::vector<std::string> StationFixture::RunArgs(const std::string& operator_kind,
                                                 const std::filesystem::path& data_dir,
                                                 const std::filesystem::path& out_dir,
                                                 bool with_server) const {
  std::vector<std::string> args = {"run",       "--trainee",   kTrainee,
                                   "--case",    "standard-adult",
                                   "--device",  "sim",         "--headless",
                                   "--operator", operator_kind, "--out",
                                   out_dir.string(), "--data-dir", data_dir.string(),
                                   "--seconds", kSessionSeconds, "--frame-every-s", "3"};
  if (with_server) args.insert(args.end(), {"--server", address_, "--token", station_token_});
  return args;
}

int StationFixture::SessionsOnServer() {
  const ProcessResult scores = Admin(
      {"scores", "--trainee", kTrainee, "--server", address_, "--token", supervisor_token_});
  if (scores.exit_code != 0) {
    ADD_FAILURE() << "ves-admin scores failed: " << scores.err;
    return -1;
  }
  std::istringstream lines(scores.out);
  int count = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.find("standard-adult") != std::string::npos) ++count;
  }
  return count;
}

bool StationFixture::SessionOnServer(const std::string& uuid) {
  const ProcessResult shown =
      Admin({"session", "show", uuid, "--server", address_, "--token", supervisor_token_});
  return shown.exit_code == 0 && shown.out.find(uuid) != std::string::npos;
}

std::string CommittedUuid(const std::string& station_stdout) {
  static const std::regex kCommitted("session ([0-9a-f-]{36}) committed to the outbox");
  std::smatch match;
  return std::regex_search(station_stdout, match, kCommitted) ? match[1].str() : "";
}

int PendingUploads(const std::string& status_stdout) {
  static const std::regex kPending("pending uploads: ([0-9]+)");
  std::smatch match;
  return std::regex_search(status_stdout, match, kPending) ? std::stoi(match[1].str()) : -1;
}

}  // namespace ves::station::testing
