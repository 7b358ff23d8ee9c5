// Group commit: every submission is answered once its batch committed, with
// the outcome of its own row; audit rows go into the same transactions.
#include "server/session_writer.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <future>
#include <thread>

namespace ves::server {
namespace {

using patient_db::SessionPut;

class SessionWriterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("ves_writer_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    store_ = patient_db::OpenStore("sqlite:" + (dir_ / "ves.db").string());
    store_->AddInstitution("north", 1);
    store_->AddTrainee({"t1", "north", "", 1});
  }
  void TearDown() override {
    store_.reset();
    std::filesystem::remove_all(dir_);
  }
  static patient_db::SessionRow Row(const std::string& uuid, const std::string& body) {
    patient_db::SessionRow r;
    r.uuid = uuid;
    r.trainee_id = "t1";
    r.institution = "north";
    r.case_id = "c";
    r.body = body;
    r.body_sha256_hex = "h" + body;
    return r;
  }
  std::filesystem::path dir_;
  std::unique_ptr<patient_db::Store> store_;
};

TEST_F(SessionWriterTest, ConcurrentSubmissionsGetTheirOwnOutcomes) {
  SessionWriter writer(store_.get());
  constexpr int kThreads = 8, kPerThread = 50;
  std::atomic<int> stored{0}, duplicate{0}, conflict{0}, failed{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < kPerThread; ++i) {
        // Every thread submits the same 50 uuids; odd threads with other bodies.
        std::promise<void> done;
        writer.Submit(Row("u" + std::to_string(i), t % 2 ? "odd" : "even"), {},
                      [&](const patient_db::StoreStatus& s, const patient_db::SessionPutResult& r) {
                        if (!s.ok()) ++failed;
                        else if (r.outcome == SessionPut::kStored) ++stored;
                        else if (r.outcome == SessionPut::kDuplicate) ++duplicate;
                        else ++conflict;
                        done.set_value();
                      });
        done.get_future().wait();
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(failed.load(), 0);
  EXPECT_EQ(stored.load(), kPerThread);  // exactly one first write per uuid
  // Per uuid, 4 threads send "even" and 4 "odd". Whichever body wins, the 3
  // others of its group are duplicates and the 4 of the other group conflicts.
  EXPECT_EQ(duplicate.load(), 3 * kPerThread);
  EXPECT_EQ(conflict.load(), 4 * kPerThread);
  EXPECT_EQ(store_->CountSessions().value, kPerThread);
  EXPECT_GT(writer.batches(), 0u);
}

TEST_F(SessionWriterTest, StopWritesPendingAuditRows) {
  {
    SessionWriter writer(store_.get());
    for (int i = 0; i < 20; ++i) {
      writer.SubmitAudit({0, i, "tok", "", "admin", "north", "case.list", "", "OK"});
    }
  }  // destructor: Stop() drains
  EXPECT_EQ(store_->ListAudit(0, 100).value.size(), 20u);
}

TEST_F(SessionWriterTest, SessionAuditRowCarriesTheOutcome) {
  SessionWriter writer(store_.get());
  for (const char* body : {"a", "a", "b"}) {
    std::promise<void> done;
    writer.Submit(Row("u1", body),
                  {0, 1, "tok", "", "station", "north", "session.upload", "u1", ""},
                  [&](const auto&, const auto&) { done.set_value(); });
    done.get_future().wait();
  }
  auto rows = store_->ListAudit(0, 10).value;
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].result, "OK");
  EXPECT_EQ(rows[1].result, "OK duplicate");
  EXPECT_EQ(rows[2].result, "ALREADY_EXISTS");
}

}  // namespace
}  // namespace ves::server
