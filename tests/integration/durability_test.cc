// The real ves-server binary as a child process: SIGKILL in the middle of an
// upload loop loses no acknowledged record; SIGTERM drains and exits 0.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <mutex>
#include <set>
#include <thread>

#include "tests/integration/server_process.h"
#include "tests/integration/test_server.h"

namespace ves::server::testing {
namespace {

using patient_db::StoreRole;

struct Loop {
  std::mutex mutex;
  std::set<std::string> acknowledged;
  std::atomic<bool> stop{false};
};

// Uploads until stopped or the server stops answering.
void UploadLoop(const ClientOptions& o, Loop* loop, uint64_t seed) {
  std::mt19937_64 rng(seed);
  auto stub = ves::v1::Sessions::NewStub(MakeClientChannel(o));
  for (int i = 0; !loop->stop; ++i) {
    grpc::ClientContext ctx;
    PrepareContext(&ctx, o);
    ves::v1::UploadSessionRequest q;
    *q.mutable_record() = MakeRecord(NewUuid(rng), "t1", i);
    ves::v1::UploadSessionResponse r;
    if (!stub->UploadSession(&ctx, q, &r).ok()) return;
    std::lock_guard lock(loop->mutex);
    loop->acknowledged.insert(r.uuid());
  }
}

size_t Acknowledged(Loop& loop) {
  std::lock_guard lock(loop.mutex);
  return loop.acknowledged.size();
}

TEST(Durability, SigkillMidLoopLosesNoAcknowledgedRecordAndSigtermDrains) {
  const auto dir = MakeTempDir("durability");
  std::string token;
  {
    auto store = patient_db::OpenStore("sqlite:" + (dir / "ves.db").string());
    store->AddInstitution("north", 1);
    store->AddTrainee({"t1", "north", "One", 1});
    PutSampleCase(*store, "north");
    token = NewToken();
    store->AddToken({Sha256Hex(token), StoreRole::kStation, "north", "", "station", 1});
  }
  const std::string db = "sqlite:" + (dir / "ves.db").string();
  ServerProcess server = StartServerProcess(db, dir, "");
  ASSERT_GT(server.port, 0) << "ves-server did not start, see " << server.log;
  ClientOptions o;
  o.address = server.address();
  o.token = token;
  o.deadline = std::chrono::seconds(5);

  Loop loop;
  std::vector<std::thread> clients;
  for (int c = 0; c < 4; ++c) clients.emplace_back(UploadLoop, o, &loop, 100 + c);
  for (int i = 0; i < 400 && Acknowledged(loop) < 300; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_NE(StopServerProcess(&server, SIGKILL), -1);  // in the middle of the loop
  loop.stop = true;
  for (auto& t : clients) t.join();
  const std::set<std::string> acked = loop.acknowledged;
  ASSERT_GE(acked.size(), 300u);

  server = StartServerProcess(db, dir, "");
  ASSERT_GT(server.port, 0) << "ves-server did not restart, see " << server.log;
  {
    auto store = patient_db::OpenStore("sqlite:" + (dir / "ves.db").string());
    size_t missing = 0;
    for (const auto& uuid : acked) missing += store->GetSession(uuid).ok() ? 0 : 1;
    EXPECT_EQ(missing, 0u) << "of " << acked.size() << " acknowledged records";
  }
  // SIGTERM while uploads are in flight: exit 0, every acknowledged record kept.
  o.address = server.address();
  Loop second;
  std::thread client(UploadLoop, o, &second, 999);
  for (int i = 0; i < 400 && Acknowledged(second) < 50; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const int wstatus = StopServerProcess(&server, SIGTERM);
  ASSERT_NE(wstatus, -1);
  second.stop = true;
  client.join();
  EXPECT_TRUE(WIFEXITED(wstatus) && WEXITSTATUS(wstatus) == 0) << "status " << wstatus;
  auto store = patient_db::OpenStore("sqlite:" + (dir / "ves.db").string());
  size_t missing = 0;
  for (const auto& uuid : second.acknowledged) missing += store->GetSession(uuid).ok() ? 0 : 1;
  EXPECT_EQ(missing, 0u);
  store.reset();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace ves::server::testing
