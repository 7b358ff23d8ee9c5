// ves-station run end to end: a real ves-server, two headless stations and a
// supervisor's query (issue #8 "Done when").
#include <gtest/gtest.h>

#include <filesystem>

#include "tests/station/app/station_fixture.h"

namespace ves::station::testing {
namespace {

namespace fs = std::filesystem;

using StationRun = StationFixture;

bool ExitedWithSessionOutcome(const ProcessResult& r) {
  return r.exit_code == 0 || r.exit_code == 3;  // cecum reached / timed out or aborted
}

TEST_F(StationRun, TwoHeadlessStationsUploadAndTheSupervisorSeesBothSessions) {
  const fs::path novice_out = dir_ / "novice-out";
  const fs::path expert_out = dir_ / "expert-out";
  auto args_novice = RunArgs("novice", dir_ / "station-a", novice_out);
  auto args_expert = RunArgs("expert", dir_ / "station-b", expert_out);
  args_novice.insert(args_novice.begin(), kStationBin);
  args_expert.insert(args_expert.begin(), kStationBin);
  ChildProcess station_a(args_novice, dir_ / "station-a");
  ChildProcess station_b(args_expert, dir_ / "station-b");
  const ProcessResult a = station_a.Wait();
  const ProcessResult b = station_b.Wait();
  ASSERT_TRUE(ExitedWithSessionOutcome(a)) << a.out << a.err;
  ASSERT_TRUE(ExitedWithSessionOutcome(b)) << b.out << b.err;

  const std::string uuid_a = CommittedUuid(a.out);
  const std::string uuid_b = CommittedUuid(b.out);
  ASSERT_FALSE(uuid_a.empty()) << a.out;
  ASSERT_FALSE(uuid_b.empty()) << b.out;
  EXPECT_NE(uuid_a, uuid_b);
  EXPECT_NE(a.out.find("uploaded 1 session(s)"), std::string::npos) << a.out;
  EXPECT_NE(b.out.find("uploaded 1 session(s)"), std::string::npos) << b.out;
  // Every acknowledged session is on the server, and the supervisor sees both.
  EXPECT_TRUE(SessionOnServer(uuid_a));
  EXPECT_TRUE(SessionOnServer(uuid_b));
  EXPECT_EQ(SessionsOnServer(), 2);
  EXPECT_EQ(PendingUploads(Station({"status", "--data-dir", (dir_ / "station-a").string()}).out),
            0);

  for (const fs::path& out : {novice_out, expert_out}) {
    EXPECT_TRUE(fs::exists(out / "summary.txt"));
    EXPECT_TRUE(fs::exists(out / "fluoroscopy.png"));
    EXPECT_TRUE(fs::exists(out / "endoscope_final.png"));
    EXPECT_GT(fs::file_size(out / "fluoroscopy.png"), 1000u);
  }
  // The summary file holds the line the station printed.
  const std::string summary = ReadFile(novice_out / "summary.txt");
  ASSERT_EQ(summary.rfind("outcome=", 0), 0u) << summary;
  EXPECT_NE(a.out.find(summary), std::string::npos);
}

TEST_F(StationRun, TheCaseComesFromTheCacheWhenTheServerIsDown) {
  const fs::path data = dir_ / "station";
  const ProcessResult online = Station(RunArgs("novice", data, dir_ / "out-1"));
  ASSERT_TRUE(ExitedWithSessionOutcome(online)) << online.out << online.err;
  EXPECT_NE(online.out.find("(from the server)"), std::string::npos) << online.out;
  StopServer();
  auto args = RunArgs("novice", data, dir_ / "out-2");
  args.insert(args.end(), {"--upload-attempts", "1"});
  const ProcessResult offline = Station(args);
  ASSERT_TRUE(ExitedWithSessionOutcome(offline)) << offline.out << offline.err;
  EXPECT_NE(offline.out.find("(offline cache)"), std::string::npos) << offline.out;
}

TEST_F(StationRun, AnUnknownCaseWithNoServerIsBadInput) {
  const ProcessResult r =
      Station(RunArgs("novice", dir_ / "empty-station", dir_ / "out", /*with_server=*/false));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("not in the offline cache"), std::string::npos) << r.err;
}

TEST_F(StationRun, ACanDeviceIsRefusedClearly) {
  auto args = RunArgs("novice", dir_ / "station", dir_ / "out");
  args.insert(args.end(), {"--device", "can:vcan0"});
  // --device given twice is itself an error; build the arguments without the default one.
  std::vector<std::string> clean;
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--device" && args[i + 1] == "sim") {
      ++i;
      continue;
    }
    clean.push_back(args[i]);
  }
  const ProcessResult r = Station(clean);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("can:vcan0"), std::string::npos) << r.err;
}

TEST_F(StationRun, HeadlessWithoutAnOperatorIsAUsageError) {
  const ProcessResult r = Station({"run", "--trainee", kTrainee, "--case", "standard-adult",
                                   "--headless", "--out", (dir_ / "out").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--operator"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace ves::station::testing
