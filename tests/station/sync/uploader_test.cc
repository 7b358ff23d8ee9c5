#include "station/sync/uploader.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <map>

namespace ves::sync {
namespace {

std::filesystem::path FreshDb(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("ves_uploader_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir / "outbox.db";
}

ves::v1::SessionRecord MakeRecord(const std::string& uuid) {
  ves::v1::SessionRecord record;
  record.set_uuid(uuid);
  record.set_trainee_id("trainee-1");
  return record;
}

// A server that is down for its first `down_for` calls, then stores each
// UUID once (idempotent upload) and counts deliveries.
class FakeServer : public SessionUploader {
 public:
  explicit FakeServer(int down_for) : down_for_(down_for) {}
  UploadResult Upload(const ves::v1::SessionRecord& record) override {
    ++calls;
    if (calls <= down_for_) return {UploadVerdict::kRetryLater, "connection refused"};
    if (record.uuid() == reject_uuid) return {UploadVerdict::kRejected, "invalid"};
    ++stored[record.uuid()];
    return {UploadVerdict::kAcknowledged, ""};
  }
  int calls{0};
  std::string reject_uuid;
  std::map<std::string, int> stored;

 private:
  int down_for_;
};

int64_t Now() { return 42; }

TEST(CalcBackoff, DoublesFromInitialAndCapsAtMax) {
  const BackoffPolicy policy{std::chrono::milliseconds(100), std::chrono::milliseconds(1000), 2.0};
  EXPECT_EQ(CalcBackoff(policy, 0).count(), 0);
  EXPECT_EQ(CalcBackoff(policy, 1).count(), 100);
  EXPECT_EQ(CalcBackoff(policy, 2).count(), 200);
  EXPECT_EQ(CalcBackoff(policy, 4).count(), 800);
  EXPECT_EQ(CalcBackoff(policy, 5).count(), 1000);
  EXPECT_EQ(CalcBackoff(policy, 50).count(), 1000);
}

TEST(DrainOutbox, StopsAtFirstRetryAndKeepsEverythingPending) {
  Outbox outbox(FreshDb("down"));
  outbox.Commit(MakeRecord("a"));
  outbox.Commit(MakeRecord("b"));
  FakeServer server(/*down_for=*/100);
  const DrainResult result = DrainOutbox(outbox, server, Now);
  EXPECT_TRUE(result.stopped_on_retry);
  EXPECT_EQ(server.calls, 1);  // did not hammer a dead server with "b"
  EXPECT_EQ(outbox.PendingCount(), 2u);
}

TEST(DrainOutbox, DeliversEveryRecordExactlyOnceWhenServerIsUp) {
  Outbox outbox(FreshDb("up"));
  for (const char* uuid : {"a", "b", "c"}) outbox.Commit(MakeRecord(uuid));
  FakeServer server(/*down_for=*/0);
  const DrainResult result = DrainOutbox(outbox, server, Now);
  EXPECT_EQ(result, (DrainResult{3, 0, false}));
  EXPECT_EQ(outbox.PendingCount(), 0u);
  // A second pass sends nothing again.
  EXPECT_EQ(DrainOutbox(outbox, server, Now), (DrainResult{0, 0, false}));
  for (const auto& [uuid, count] : server.stored) EXPECT_EQ(count, 1) << uuid;
}

TEST(DrainOutbox, RejectedRecordDoesNotBlockTheRest) {
  Outbox outbox(FreshDb("reject"));
  outbox.Commit(MakeRecord("bad"));
  outbox.Commit(MakeRecord("good"));
  FakeServer server(0);
  server.reject_uuid = "bad";
  EXPECT_EQ(DrainOutbox(outbox, server, Now), (DrainResult{1, 1, false}));
  EXPECT_EQ(server.stored.count("good"), 1u);
  EXPECT_TRUE(outbox.Find("bad").has_value());
}

// As the station's upload does: passes until one is not cut short by the
// server; each refused pass counts one failed attempt on the record.
TEST(DrainOutbox, LaterPassesDeliverOnceTheServerComesBack) {
  Outbox outbox(FreshDb("passes"));
  outbox.Commit(MakeRecord("a"));
  FakeServer server(/*down_for=*/3);
  int passes = 0;
  DrainResult result;
  do {
    result = DrainOutbox(outbox, server, Now);
    ++passes;
  } while (result.stopped_on_retry && passes < 10);
  EXPECT_EQ(passes, 4);
  EXPECT_EQ(result, (DrainResult{1, 0, false}));
  EXPECT_EQ(outbox.PendingCount(), 0u);
  EXPECT_EQ(server.calls, 4);  // three refusals, then the delivery
  EXPECT_EQ(server.stored["a"], 1);
}

}  // namespace
}  // namespace ves::sync
