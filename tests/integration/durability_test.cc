// The real ves-server binary as a child process: SIGKILL in the middle of an
// upload loop loses no acknowledged record; SIGTERM drains and exits 0.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <fstream>
#include <mutex>
#include <set>
#include <thread>

#include "tests/integration/test_server.h"

namespace ves::server::testing {
namespace {

using patient_db::StoreRole;

// ves-server on 127.0.0.1:0 over `db`; returns its pid and port.
pid_t StartServer(const std::filesystem::path& dir, int* port) {
  const std::string port_file = (dir / "port").string();
  std::filesystem::remove(port_file);
  const std::string db = "sqlite:" + (dir / "ves.db").string();
  const std::string log = (dir / "server.log").string();
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::execl(VES_SERVER_PATH, "ves-server", "--listen", "127.0.0.1:0", "--db", db.c_str(),
            "--insecure-loopback", "--quiet", "--port-file", port_file.c_str(), nullptr);
    ::_exit(127);
  }
  for (int i = 0; i < 200 && !std::filesystem::exists(port_file); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  std::ifstream(port_file) >> *port;
  return pid;
}

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
    store->AddToken({Sha256HexOf(token), StoreRole::kStation, "north", "", "station", 1});
  }
  int port = 0;
  pid_t pid = StartServer(dir, &port);
  ASSERT_GT(port, 0) << "ves-server did not start, see " << dir / "server.log";
  ClientOptions o;
  o.address = "127.0.0.1:" + std::to_string(port);
  o.token = token;
  o.deadline = std::chrono::seconds(5);

  Loop loop;
  std::vector<std::thread> clients;
  for (int c = 0; c < 4; ++c) clients.emplace_back(UploadLoop, o, &loop, 100 + c);
  for (int i = 0; i < 400 && Acknowledged(loop) < 300; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_EQ(::kill(pid, SIGKILL), 0);  // in the middle of the loop
  int wstatus = 0;
  ::waitpid(pid, &wstatus, 0);
  loop.stop = true;
  for (auto& t : clients) t.join();
  const std::set<std::string> acked = loop.acknowledged;
  ASSERT_GE(acked.size(), 300u);

  pid = StartServer(dir, &port);
  ASSERT_GT(port, 0);
  {
    auto store = patient_db::OpenStore("sqlite:" + (dir / "ves.db").string());
    size_t missing = 0;
    for (const auto& uuid : acked) missing += store->GetSession(uuid).ok() ? 0 : 1;
    EXPECT_EQ(missing, 0u) << "of " << acked.size() << " acknowledged records";
  }
  // SIGTERM while uploads are in flight: exit 0, every acknowledged record kept.
  o.address = "127.0.0.1:" + std::to_string(port);
  Loop second;
  std::thread client(UploadLoop, o, &second, 999);
  for (int i = 0; i < 400 && Acknowledged(second) < 50; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  ::waitpid(pid, &wstatus, 0);
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
