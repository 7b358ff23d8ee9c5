// The outbox across failures with real processes: the server down during a
// session, and a station SIGKILLed between the commit and the upload.
#include <gtest/gtest.h>
#include <signal.h>

#include <filesystem>

#include "tests/station/app/station_fixture.h"

namespace ves::station::testing {
namespace {

namespace fs = std::filesystem;

using StationOffline = StationFixture;

TEST_F(StationOffline, ASessionRunWhileTheServerIsDownArrivesWhenItComesBack) {
  const fs::path data = dir_ / "station";
  // The station has the case in its cache (downloaded on an earlier run).
  const ProcessResult first = Station(RunArgs("novice", data, dir_ / "out-1"));
  ASSERT_TRUE(first.exit_code == 0) << first.out << first.err;
  ASSERT_EQ(SessionsOnServer(), 1);

  const int port = port_;
  StopServer();
  auto args = RunArgs("expert", data, dir_ / "out-2");
  args.insert(args.end(), {"--upload-attempts", "2"});
  const ProcessResult offline = Station(args);
  ASSERT_TRUE(offline.exit_code == 0) << offline.out << offline.err;
  const std::string uuid = CommittedUuid(offline.out);
  ASSERT_FALSE(uuid.empty()) << offline.out;
  EXPECT_NE(offline.out.find("stays in the outbox"), std::string::npos) << offline.out;
  const ProcessResult status = Station({"status", "--data-dir", data.string()});
  EXPECT_EQ(PendingUploads(status.out), 1) << status.out;
  EXPECT_NE(status.out.find(uuid), std::string::npos) << status.out;

  StartServer(port);  // the server comes back on the same address
  const ProcessResult sync = Station(
      {"sync", "--server", address_, "--token", station_token_, "--data-dir", data.string()});
  EXPECT_EQ(sync.exit_code, 0) << sync.out << sync.err;
  EXPECT_NE(sync.out.find("uploaded 1 session(s)"), std::string::npos) << sync.out;
  EXPECT_TRUE(SessionOnServer(uuid));
  EXPECT_EQ(SessionsOnServer(), 2);
  EXPECT_EQ(PendingUploads(Station({"status", "--data-dir", data.string()}).out), 0);
}

TEST_F(StationOffline, AStationKilledBetweenCommitAndUploadDeliversOnRestartExactlyOnce) {
  const fs::path data = dir_ / "station";
  const ProcessResult killed =
      Station(RunArgs("novice", data, dir_ / "out-1"), {"VES_STATION_KILL_AFTER_COMMIT=1"});
  ASSERT_EQ(killed.term_signal, SIGKILL) << killed.out << killed.err;
  const std::string uuid = CommittedUuid(killed.out);
  ASSERT_FALSE(uuid.empty()) << killed.out;
  EXPECT_EQ(SessionsOnServer(), 0);  // it never got to the upload
  EXPECT_EQ(PendingUploads(Station({"status", "--data-dir", data.string()}).out), 1);

  // The restarted station's next run delivers the old session with its own.
  const ProcessResult restarted = Station(RunArgs("novice", data, dir_ / "out-2"));
  ASSERT_TRUE(restarted.exit_code == 0) << restarted.out
                                                                    << restarted.err;
  EXPECT_NE(restarted.out.find("uploaded 2 session(s)"), std::string::npos) << restarted.out;
  EXPECT_TRUE(SessionOnServer(uuid));
  EXPECT_EQ(SessionsOnServer(), 2);

  // Syncing again sends nothing: each session is on the server exactly once.
  const ProcessResult sync = Station(
      {"sync", "--server", address_, "--token", station_token_, "--data-dir", data.string()});
  EXPECT_EQ(sync.exit_code, 0) << sync.err;
  EXPECT_NE(sync.out.find("uploaded 0 session(s)"), std::string::npos) << sync.out;
  EXPECT_EQ(SessionsOnServer(), 2);
}

// A session the server refuses for good (here: its case was never uploaded,
// so it is not visible to the trainee's institution) is set aside, listed by
// `status` with the reason, and delivers nothing in the way of the others.
TEST_F(StationOffline, ARecordTheServerRefusesIsSetAsideAndTheOthersArrive) {
  const fs::path data = dir_ / "station";
  for (const std::string id : {"paper-sigmoid", "standard-adult"}) {  // both run offline
    const fs::path bundle = dir_ / (id + ".vescase");
    ASSERT_EQ(Admin({"case", "convert",
                     std::string(VES_SOURCE_DIR) + "/patient_db/cases/" + id + ".textproto",
                     bundle.string()})
                  .exit_code,
              0);
    ASSERT_EQ(Station({"import-case", bundle.string(), "--data-dir", data.string()}).exit_code, 0);
  }
  auto refused_args = RunArgs("novice", data, dir_ / "out-1", /*with_server=*/false);
  for (size_t i = 0; i + 1 < refused_args.size(); ++i) {
    if (refused_args[i] == "--case") refused_args[i + 1] = "paper-sigmoid";
  }
  const ProcessResult refused_run = Station(refused_args);
  ASSERT_TRUE(refused_run.exit_code == 0 || refused_run.exit_code == 3) << refused_run.err;
  const std::string refused = CommittedUuid(refused_run.out);
  const ProcessResult good_run = Station(RunArgs("expert", data, dir_ / "out-2", false));
  ASSERT_TRUE(good_run.exit_code == 0 || good_run.exit_code == 3) << good_run.err;
  const std::string good = CommittedUuid(good_run.out);
  ASSERT_FALSE(refused.empty() || good.empty());

  const ProcessResult sync = Station(
      {"sync", "--server", address_, "--token", station_token_, "--data-dir", data.string()});
  EXPECT_EQ(sync.exit_code, 0) << sync.out << sync.err;
  EXPECT_NE(sync.out.find("uploaded 1 session(s), 1 refused, 0 pending"), std::string::npos)
      << sync.out;
  EXPECT_TRUE(SessionOnServer(good));
  const ProcessResult status = Station({"status", "--data-dir", data.string()});
  EXPECT_EQ(PendingUploads(status.out), 0) << status.out;
  EXPECT_NE(status.out.find("set aside: 1\n  " + refused), std::string::npos) << status.out;
  EXPECT_NE(status.out.find("no such case visible to institution 'north'"), std::string::npos)
      << status.out;
  // Later syncs neither retry it nor stop on it.
  const ProcessResult again = Station(
      {"sync", "--server", address_, "--token", station_token_, "--data-dir", data.string()});
  EXPECT_NE(again.out.find("uploaded 0 session(s), 0 refused, 0 pending"), std::string::npos)
      << again.out;
}

}  // namespace
}  // namespace ves::station::testing
