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

// Issue #48: a fresh station could not start the shipped cases by id, and
// `snapshot` refused an id that `run` took. Now the shipped cases are in the
// offline cache from the first command, and run, sim and snapshot take an id
// the same way, with no import step and no server.
TEST_F(StationCli, AFreshStationRunsTheShippedCasesByIdWithoutAnImport) {
  const ProcessResult run = Station({"run", "--trainee", kTrainee, "--case", "standard-adult",
                                     "--headless", "--operator", "novice", "--out",
                                     (dir_ / "out").string(), "--seconds", "1"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_NE(run.out.find("shipped cases put into the offline cache"), std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("case standard-adult v1 "), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("(offline cache)"), std::string::npos) << run.out;
  // Said once: the second command finds them there.
  const ProcessResult sim = Station({"sim", "--case", "redundant-sigmoid", "--operator", "novice",
                                     "--seconds", "0.5"});
  ASSERT_EQ(sim.exit_code, 0) << sim.out << sim.err;
  EXPECT_EQ(sim.out.rfind("outcome=", 0), 0u) << sim.out;
  EXPECT_EQ(sim.err.find("shipped cases"), std::string::npos) << sim.err;
  const ProcessResult snapshot =
      Station({"snapshot", "--case", "paper-sigmoid", "--insert-mm", "100", "--width", "64",
               "--height", "48", "--segments", "40", "--out", (dir_ / "snapshot").string()});
  ASSERT_EQ(snapshot.exit_code, 0) << snapshot.out << snapshot.err;
  EXPECT_TRUE(fs::exists(dir_ / "snapshot" / "fluoroscopy_ap.png"));
  const ProcessResult status = Station({"status"});
  for (const char* id : {"standard-adult", "paper-sigmoid", "redundant-sigmoid",
                         "mobile-descending", "fixed-tube"}) {
    EXPECT_NE(status.out.find(std::string("\n  ") + id + " v"), std::string::npos)
        << id << "\n" << status.out;
  }
}

// An id that is neither a case file nor cached: one line naming what was
// looked for, where, and the ids there are; exit status 2, for every command.
TEST_F(StationCli, AnUnknownCaseNamesWhatWasLookedForAndTheCachedIds) {
  const std::vector<std::vector<std::string>> commands = {
      {"run", "--trainee", kTrainee, "--case", "standard-adlt", "--headless", "--operator",
       "novice", "--out", (dir_ / "out").string(), "--seconds", "1"},
      {"sim", "--case", "standard-adlt", "--operator", "novice", "--seconds", "1"},
      {"snapshot", "--case", "standard-adlt", "--insert-mm", "100", "--out",
       (dir_ / "snapshot").string()}};
  for (const auto& command : commands) {
    const ProcessResult r = Station(command);
    EXPECT_EQ(r.exit_code, 2) << command[0] << ": " << r.out << r.err;
    EXPECT_EQ(Lines(r.err), 1) << command[0] << ": " << r.err;
    EXPECT_NE(r.err.find("case 'standard-adlt' is neither a case file"), std::string::npos)
        << command[0] << ": " << r.err;
    EXPECT_NE(r.err.find((dir_ / "station" / "cases").string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("cached: fixed-tube, mobile-descending, paper-sigmoid, "
                         "redundant-sigmoid, standard-adult"),
              std::string::npos)
        << command[0] << ": " << r.err;
  }
  EXPECT_FALSE(fs::exists(dir_ / "station" / "outbox.db")) << "a session ran";
}

// Interactive without a display: one line saying what to do, nothing stored.
TEST_F(StationCli, WithoutADisplayTheInteractiveRunSaysWhatToDoInOneLine) {
  std::vector<std::string> args = {kStationBin, "run", "--trainee", kTrainee, "--case",
                                   "standard-adult", "--data-dir", (dir_ / "station").string()};
  const ProcessResult r = RunProgram(args, dir_ / "no-display", {"DISPLAY="},
                                     std::chrono::seconds(60));
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("DISPLAY is not set"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--headless"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("case standard-adult v1 "), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "station" / "outbox.db")) << "a session was stored";
}

}  // namespace
}  // namespace ves::station::testing
