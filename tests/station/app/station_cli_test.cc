// ves-station's command line refuses what it must before anything starts:
// plaintext off loopback, unreadable TLS files, bad ids (docs/station-run.md).
// No server: each refusal is one line and exit status 2.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "tests/integration/plaintext_probe.h"
#include "tests/station/app/station_fixture.h"

namespace ves::station::testing {
namespace {

namespace fs = std::filesystem;

class StationCli : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = MakeTempDir("station-cli"); }
  void TearDown() override { fs::remove_all(dir_); }

  ProcessResult Station(std::vector<std::string> args) {
    args.insert(args.begin(), kStationBin);
    args.insert(args.end(), {"--data-dir", (dir_ / "station").string()});
    return RunProgram(args, dir_ / ("run-" + std::to_string(++runs_)), {},
                      std::chrono::seconds(60));
  }

  static int Lines(const std::string& s) {
    return static_cast<int>(std::count(s.begin(), s.end(), '\n'));
  }

  fs::path dir_;
  int runs_{0};
};

TEST_F(StationCli, RunAndSyncRefusePlaintextOffLoopbackBeforeConnecting) {
  ves::testing::NonLoopbackListener listener;
  const std::string address = listener.address().empty() ? "192.0.2.1:50051" : listener.address();
  const ProcessResult run =
      Station({"run", "--trainee", kTrainee, "--case", "standard-adult", "--server", address,
               "--token", "secret-token", "--headless", "--operator", "novice", "--out",
               (dir_ / "out").string(), "--seconds", "1", "--upload-attempts", "1"});
  EXPECT_EQ(run.exit_code, 2) << run.out << run.err;
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("refusing to send the token in plaintext to '" + address + "'"),
            std::string::npos)
      << run.err;
  const ProcessResult sync =
      Station({"sync", "--server", address, "--token", "secret-token", "--attempts", "1"});
  EXPECT_EQ(sync.exit_code, 2) << sync.out << sync.err;
  EXPECT_EQ(Lines(sync.err), 1) << sync.err;
  EXPECT_NE(sync.err.find("--tls-ca"), std::string::npos) << sync.err;
  if (!listener.address().empty()) {
    EXPECT_EQ(listener.Connections(), 0);
  }
}

TEST_F(StationCli, AnUnreadableCaFileIsOneLineAndExitStatus2) {
  for (const std::string command : {"run", "sync"}) {
    std::vector<std::string> args = {command, "--server", "ves.example.org:50051", "--token",
                                     "t",     "--tls-ca", "/nonexistent.pem"};
    if (command == "run") args.insert(args.end(), {"--trainee", kTrainee, "--case", "x"});
    const ProcessResult r = Station(args);
    EXPECT_EQ(r.exit_code, 2) << command << ": " << r.err;
    EXPECT_EQ(r.term_signal, 0) << command;
    EXPECT_EQ(Lines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find("--tls-ca /nonexistent.pem: cannot read the file"), std::string::npos)
        << r.err;
  }
}

// Issue #20: a station id that is not UTF-8 ran a whole session, was
// committed and then blocked the outbox. Now it is refused before anything.
TEST_F(StationCli, IdsThatAreNotPrintableUtf8AreRefusedBeforeTheSession) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"--station-id", "st\xff\xfe"}, {"--station-id", "red\x1b[31m"},
      {"--trainee", std::string(200, 't')}, {"--case", "adult\x07"}};
  for (const auto& [flag, value] : bad) {
    std::vector<std::string> args = {"run", "--trainee", kTrainee, "--case", "standard-adult",
                                     "--headless", "--operator", "novice", "--out",
                                     (dir_ / "out").string(), "--seconds", "1"};
    for (size_t i = 0; i + 1 < args.size(); ++i) {
      if (args[i] == flag) args[i + 1] = value;
    }
    if (flag == "--station-id") args.insert(args.end(), {flag, value});
    const ProcessResult r = Station(args);
    EXPECT_EQ(r.exit_code, 2) << flag << ": " << r.err;
    EXPECT_EQ(Lines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(flag + " '"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("printable UTF-8"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "station" / "outbox.db")) << "a session ran for " << flag;
  }
}

// haptic-check said exit 1 for a CAN interface that is not there, where
// `run` says 2 (bad input): now both say 2, in one line naming the device.
TEST_F(StationCli, HapticCheckOnAMissingCanInterfaceIsBadInputLikeRun) {
  if (fs::exists("/sys/class/net/vcan0")) GTEST_SKIP() << "vcan0 exists here: not missing";
  const ProcessResult r = RunProgram(
      {kStationBin, "haptic-check", "--device", "can:vcan0", "--mode", "free", "--profile",
       "sine:10:0.5", "--seconds", "1", "--csv", (dir_ / "check.csv").string()},
      dir_ / "haptic-check", {}, std::chrono::seconds(60));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("--device can:vcan0: CAN interface 'vcan0'"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace ves::station::testing
