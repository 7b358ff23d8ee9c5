// PgStore's handling of a connection lost around COMMIT, made deterministic by
// a TCP proxy between the store and PostgreSQL that cuts the connection at the
// first simple-query "COMMIT" after it is armed:
//  - after forwarding it: the commit happened but the store never hears back
//    (pqxx::in_doubt_error); the store must look it up (txid_status ->
//    committed) and report success without re-running the batch;
//  - instead of forwarding it: PostgreSQL rolls back when the connection
//    drops; the lookup says aborted and the store re-runs the batch.
// Either way the session is stored exactly once and its audit row written once.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <pqxx/pqxx>
#include <regex>
#include <thread>

#include "patient_db/pg_store.h"
#include "tests/patient_db/pg_test_util.h"

namespace ves::patient_db {
namespace {

// The simple-query message libpqxx sends to commit: 'Q', length 11, "COMMIT\0".
const std::string kCommitMessage("Q\0\0\0\x0b" "COMMIT\0", 12);

class CommitCuttingProxy {
 public:
  enum class Cut { kNone, kAfterForwarding, kInsteadOfForwarding };

  CommitCuttingProxy(std::string upstream_host, int upstream_port)
      : host_(std::move(upstream_host)), upstream_port_(upstream_port) {
    listener_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (::bind(listener_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::listen(listener_, 16) != 0 ||
        ::getsockname(listener_, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
      throw std::runtime_error("proxy: cannot listen");
    }
    port_ = ntohs(a.sin_port);
    acceptor_ = std::thread([this] { Accept(); });
  }
  ~CommitCuttingProxy() {
    stopping_ = true;
    ::shutdown(listener_, SHUT_RDWR);
    ::close(listener_);
    acceptor_.join();
    for (auto& t : pipes_) t.join();
  }
  int port() const { return port_; }
  void Arm(Cut cut) { cut_ = cut; }
  int cuts() const { return cuts_; }

 private:
  void Accept() {
    for (;;) {
      const int client = ::accept(listener_, nullptr, nullptr);
      if (client < 0 || stopping_) {
        if (client >= 0) ::close(client);
        return;
      }
      const int server = ::socket(AF_INET, SOCK_STREAM, 0);
      sockaddr_in a{};
      a.sin_family = AF_INET;
      a.sin_port = htons(static_cast<uint16_t>(upstream_port_));
      ::inet_pton(AF_INET, host_.c_str(), &a.sin_addr);
      if (::connect(server, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
        ::close(client);
        ::close(server);
        continue;
      }
      pipes_.emplace_back([this, client, server] { Pipe(client, server); });
    }
  }

  void Pipe(int client, int server) {
    char buf[65536];
    pollfd fds[2] = {{client, POLLIN, 0}, {server, POLLIN, 0}};
    while (!stopping_) {
      if (::poll(fds, 2, 100) <= 0) continue;
      if (fds[0].revents) {
        const ssize_t n = ::read(client, buf, sizeof buf);
        if (n <= 0) break;
        const std::string chunk(buf, static_cast<size_t>(n));
        Cut cut = Cut::kNone;
        if (chunk.find(kCommitMessage) != std::string::npos) cut = cut_.exchange(Cut::kNone);
        if (cut != Cut::kInsteadOfForwarding) WriteAll(server, chunk);
        if (cut != Cut::kNone) {
          ++cuts_;
          // The client loses its connection now; the server gets an orderly
          // EOF after whatever was forwarded, so it still runs a sent COMMIT.
          ::close(client);
          ::shutdown(server, SHUT_WR);
          while (::read(server, buf, sizeof buf) > 0) {
          }
          ::close(server);
          return;
        }
      }
      if (fds[1].revents) {
        const ssize_t n = ::read(server, buf, sizeof buf);
        if (n <= 0) break;
        WriteAll(client, std::string(buf, static_cast<size_t>(n)));
      }
    }
    ::close(client);
    ::close(server);
  }

  static void WriteAll(int fd, const std::string& data) {
    size_t done = 0;
    while (done < data.size()) {
      const ssize_t n = ::write(fd, data.data() + done, data.size() - done);
      if (n <= 0) return;
      done += static_cast<size_t>(n);
    }
  }

  std::string host_;
  int upstream_port_;
  int listener_ = -1;
  int port_ = 0;
  std::atomic<bool> stopping_{false};
  std::atomic<Cut> cut_{Cut::kNone};
  std::atomic<int> cuts_{0};
  std::thread acceptor_;
  std::vector<std::thread> pipes_;  // touched by the acceptor thread only, until joined
};

class PgInDoubt : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string base = pg_testing::TestPostgresUrl();
    if (base.empty()) GTEST_SKIP() << pg_testing::kNoPostgresMessage;
    std::smatch m;
    static const std::regex kHostPort(R"(^(postgres(?:ql)?://[^@/]*@)([0-9.]+):([0-9]+)(/.*)$)");
    if (!std::regex_match(base, m, kHostPort)) {
      GTEST_SKIP() << "VES_TEST_POSTGRES_URL is not user@IPv4:port/db; proxy test not run";
    }
    const std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    const std::string url = pg_testing::FreshSchema(base, pg_testing::UniqueSchemaName(name));
    proxy_ = std::make_unique<CommitCuttingProxy>(m[2].str(), std::stoi(m[3].str()));
    PgStoreOptions o;
    // FreshSchema appended the search_path option to `base`; keep it.
    o.url = m[1].str() + m[2].str() + ":" + std::to_string(proxy_->port()) + m[4].str() +
            url.substr(base.size()) + "&sslmode=disable";
    o.pool_size = 1;
    store_ = std::make_unique<PgStore>(o);
    ASSERT_TRUE(store_->AddInstitution("north", 1).ok());
    ASSERT_TRUE(store_->AddTrainee({"t1", "north", "One", 1}).ok());
  }
  void TearDown() override {
    store_.reset();
    proxy_.reset();
  }

  static WriteBatch OneSession() {
    SessionRow r;
    r.uuid = "in-doubt";
    r.trainee_id = "t1";
    r.institution = "north";
    r.body = "body";
    r.body_sha256_hex = "h";
    AuditRow a{0, 5, "tok", "l", "station", "north", "session.upload", "in-doubt", ""};
    return {{r}, {a}, {}};
  }

  std::unique_ptr<CommitCuttingProxy> proxy_;
  std::unique_ptr<PgStore> store_;
};

TEST_F(PgInDoubt, CommitThatHappenedIsLookedUpNotRerun) {
  proxy_->Arm(CommitCuttingProxy::Cut::kAfterForwarding);
  auto r = store_->CommitBatch(OneSession());
  ASSERT_TRUE(r.ok()) << r.status.message;
  EXPECT_EQ(proxy_->cuts(), 1);
  EXPECT_EQ(r.value[0].outcome, SessionPut::kStored);  // not "duplicate": it was not re-run
  EXPECT_EQ(store_->stats().in_doubt_resolved, 1u);
  EXPECT_EQ(store_->stats().retries, 0u);
  EXPECT_EQ(store_->CountSessions().value, 1);
  EXPECT_EQ(store_->ListAudit(0, 10).value.size(), 1u);
}

TEST_F(PgInDoubt, CommitThatNeverArrivedIsRerun) {
  proxy_->Arm(CommitCuttingProxy::Cut::kInsteadOfForwarding);
  auto r = store_->CommitBatch(OneSession());
  ASSERT_TRUE(r.ok()) << r.status.message;
  EXPECT_EQ(proxy_->cuts(), 1);
  EXPECT_EQ(r.value[0].outcome, SessionPut::kStored);
  EXPECT_EQ(store_->stats().in_doubt_resolved, 1u);
  EXPECT_EQ(store_->stats().retries, 1u);
  EXPECT_EQ(store_->CountSessions().value, 1);
  EXPECT_EQ(store_->ListAudit(0, 10).value.size(), 1u);
}

}  // namespace
}  // namespace ves::patient_db
