#include "station/sync/outbox.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <random>

namespace ves::sync {
namespace {

std::filesystem::path FreshDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("ves_outbox_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
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
