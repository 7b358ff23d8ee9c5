#include "station/sync/outbox.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace ves::sync {
namespace {

std::filesystem::path FreshDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("ves_outbox_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

std::string ReadLog(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

ves::v1::SessionRecord MakeRecord(const std::string& uuid, double score) {
  ves::v1::SessionRecord record;
  record.set_uuid(uuid);
  record.set_trainee_id("trainee-1");
  record.set_case_id("standard-adult");
  record.set_score(score);
  return record;
}

TEST(Outbox, CommittedRecordIsPendingUntilAcknowledged) {
  Outbox outbox(FreshDir("ack") / "outbox.db");
  outbox.Commit(MakeRecord("a", 50));
  outbox.Commit(MakeRecord("b", 60));
  ASSERT_EQ(outbox.PendingCount(), 2u);
  EXPECT_EQ(outbox.Pending()[0].uuid, "a");  // oldest first
  outbox.MarkAcknowledged("a", 1000);
  ASSERT_EQ(outbox.PendingCount(), 1u);
  EXPECT_EQ(outbox.Pending()[0].uuid, "b");
  EXPECT_TRUE(outbox.Find("a").has_value());  // acknowledged records stay as history
}

TEST(Outbox, SameUuidSameBodyIsStoredOnce) {
  Outbox outbox(FreshDir("dup") / "outbox.db");
  outbox.Commit(MakeRecord("a", 50));
  outbox.Commit(MakeRecord("a", 50));
  EXPECT_EQ(outbox.PendingCount(), 1u);
}

TEST(Outbox, SameUuidOtherBodyIsRefused) {
  Outbox outbox(FreshDir("conflict") / "outbox.db");
  outbox.Commit(MakeRecord("a", 50));
  EXPECT_THROW(outbox.Commit(MakeRecord("a", 51)), std::invalid_argument);
  EXPECT_DOUBLE_EQ(outbox.Find("a")->score(), 50);
}

TEST(Outbox, RecordWithoutUuidIsRefused) {
  Outbox outbox(FreshDir("nouuid") / "outbox.db");
  EXPECT_THROW(outbox.Commit(MakeRecord("", 1)), std::invalid_argument);
}

TEST(Outbox, RejectedRecordLeavesPendingButIsKept) {
  Outbox outbox(FreshDir("reject") / "outbox.db");
  outbox.Commit(MakeRecord("a", 50));
  outbox.MarkRejected("a", "metrics.pain_s is NaN");
  EXPECT_EQ(outbox.PendingCount(), 0u);
  EXPECT_TRUE(outbox.Find("a").has_value());
  ASSERT_EQ(outbox.SetAside().size(), 1u);  // what `ves-station status` lists
  EXPECT_EQ(outbox.SetAside()[0].reason, "metrics.pain_s is NaN");
}

// Issue #20: a record with a station id that is not UTF-8 was committed, could
// not be read back, and every later run, status and sync failed on it.
// `ves-station status` lists the station's sessions (issue #48): pending,
// delivered and set aside alike, oldest first, the newest `limit` of them.
TEST(Outbox, StoredListsEverySessionWhateverItsStateOldestFirstNewestLimit) {
  Outbox outbox(FreshDir("stored") / "outbox.db");
  for (const char* uuid : {"a", "b", "c", "d"}) outbox.Commit(MakeRecord(uuid, 10));
  outbox.MarkAcknowledged("a", 1000);
  outbox.MarkRejected("c", "refused");
  EXPECT_EQ(outbox.StoredCount(), 4u);
  const auto all = outbox.Stored(10);
  ASSERT_EQ(all.size(), 4u);
  const std::vector<std::pair<std::string, std::string>> expected = {
      {"a", "delivered"}, {"b", "pending"}, {"c", "set aside"}, {"d", "pending"}};
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(all[i].uuid, expected[i].first);
    EXPECT_EQ(all[i].state, expected[i].second) << all[i].uuid;
    EXPECT_TRUE(all[i].readable);
    EXPECT_EQ(all[i].record.uuid(), expected[i].first);
    EXPECT_EQ(all[i].record.case_id(), "standard-adult");
  }
  const auto newest = outbox.Stored(2);
  ASSERT_EQ(newest.size(), 2u);
  EXPECT_EQ(newest[0].uuid, "c");
  EXPECT_EQ(newest[1].uuid, "d");
}

TEST(Outbox, ARecordThatWouldNotReadBackIsRefusedAtCommit) {
  Outbox outbox(FreshDir("notutf8") / "outbox.db");
  auto record = MakeRecord("a", 50);
  record.set_station_id("st\xff\xfe");
  EXPECT_THROW(outbox.Commit(record), std::invalid_argument);
  EXPECT_EQ(outbox.PendingCount(), 0u);
}

// One stored just so (an outbox written before that check, or a damaged
// row) is set aside, with its reason, and the others go on.
TEST(Outbox, AnUnreadableStoredRecordIsSetAsideAndBlocksNothing) {
  const auto path = FreshDir("unreadable") / "outbox.db";
  {
    Outbox outbox(path);
    outbox.Commit(MakeRecord("a", 50));
    outbox.Commit(MakeRecord("b", 60));
    outbox.Commit(MakeRecord("c", 70));
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "UPDATE outbox SET record = x'0aff' WHERE uuid = 'b'", nullptr,
                         nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  Outbox outbox(path);
  const auto pending = outbox.Pending();
  ASSERT_EQ(pending.size(), 2u);
  EXPECT_EQ(pending[0].uuid, "a");
  EXPECT_EQ(pending[1].uuid, "c");
  const auto aside = outbox.SetAside();
  ASSERT_EQ(aside.size(), 1u);
  EXPECT_EQ(aside[0].uuid, "b");
  EXPECT_NE(aside[0].reason.find("does not parse"), std::string::npos) << aside[0].reason;
  EXPECT_EQ(outbox.PendingCount(), 2u);
}

TEST(Outbox, FailuresAreCountedWithTheirError) {
  Outbox outbox(FreshDir("fail") / "outbox.db");
  outbox.Commit(MakeRecord("a", 50));
  outbox.RecordFailure("a", "server unreachable");
  outbox.RecordFailure("a", "deadline exceeded");
  const auto pending = outbox.Pending();
  ASSERT_EQ(pending.size(), 1u);
  EXPECT_EQ(pending[0].attempts, 2);
  EXPECT_EQ(pending[0].last_error, "deadline exceeded");
}

TEST(Outbox, RecordsSurviveReopening) {
  const auto path = FreshDir("reopen") / "outbox.db";
  {
    Outbox outbox(path);
    outbox.Commit(MakeRecord("a", 50));
  }
  Outbox reopened(path);
  ASSERT_EQ(reopened.PendingCount(), 1u);
  EXPECT_DOUBLE_EQ(reopened.Pending()[0].record.score(), 50);
}

// A station killed with SIGKILL right after Commit returned still has the
// record: Commit returns only once the record is durable.
TEST(Outbox, CommitSurvivesSigkillOfTheStation) {
  const auto path = FreshDir("kill") / "outbox.db";
  int ready_pipe[2];
  ASSERT_EQ(::pipe(ready_pipe), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    Outbox outbox(path);
    for (int i = 0; i < 20; ++i) outbox.Commit(MakeRecord("s" + std::to_string(i), i));
    const char done = 'x';
    (void)!::write(ready_pipe[1], &done, 1);
    ::pause();  // killed here, with the database still open
    ::_exit(0);
  }
  char done = 0;
  ASSERT_EQ(::read(ready_pipe[0], &done, 1), 1);
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  Outbox reopened(path);
  EXPECT_EQ(reopened.PendingCount(), 20u);
}

// SIGKILL (above) only shows the write reached the OS. Power loss needs it
// on disk: between "commit begins" and "commit returned" the WAL holding the
// commit is synced, and the folder holding the files' names was synced after
// the WAL came to be. Observed with an LD_PRELOAD spy on fsync/fdatasync; with
// synchronous=NORMAL the first would fail.
TEST(Outbox, ACommitIsOnDiskFileAndFolderBeforeItReturns) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "a sanitizer runtime must come first: no LD_PRELOAD spy";
#endif
  const auto dir = std::filesystem::canonical(FreshDir("fsync"));
  const auto db = dir / "outbox.db";
  const auto log = dir / "spy.log";
  const std::string command = "VES_FSYNC_SPY_LOG='" + log.string() + "' LD_PRELOAD='" +
                              VES_FSYNC_SPY_PATH + "' '" + VES_OUTBOX_COMMIT_PROBE_PATH +
                              "' '" + db.string() + "' '" + log.string() + "'";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  std::ifstream in(log);
  bool in_commit = false, done = false, wal_seen = false;
  bool wal_synced_in_commit = false, folder_synced_after_wal = false;
  for (std::string line; std::getline(in, line);) {
    if (line == "commit begins") in_commit = true;
    if (line == "commit returned") done = true;
    if (done) break;
    const std::string path = line.substr(line.find(' ') + 1);
    if (path == db.string() + "-wal") {
      wal_seen = true;
      if (in_commit) wal_synced_in_commit = true;
    }
    if (path == dir.string() && wal_seen) folder_synced_after_wal = true;
  }
  EXPECT_TRUE(done) << ReadLog(log);
  EXPECT_TRUE(wal_synced_in_commit) << ReadLog(log);  // synchronous=FULL, not NORMAL
  EXPECT_TRUE(folder_synced_after_wal) << ReadLog(log);
}

TEST(Outbox, UnopenablePathGivesAnErrorNamingIt) {
  try {
    Outbox outbox("/proc/ves-no-such-dir/outbox.db");
    FAIL() << "expected an exception";
  } catch (const std::exception& error) {
    EXPECT_NE(std::string(error.what()).find("/proc/ves-no-such-dir"), std::string::npos)
        << error.what();
  }
}

}  // namespace
}  // namespace ves::sync
