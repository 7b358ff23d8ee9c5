// Two real ves-server processes (the binary, children on 127.0.0.1:0) on one
// PostgreSQL database, as in a scaled-out deployment (docs/operations.md):
// idempotent session upload holds across replicas, case upload races resolve
// cleanly, SIGKILL of a replica loses no acknowledged record, and a pg_dump
// taken during uploads restores to a consistent database.
// Skipped unless VES_TEST_POSTGRES_URL is set (deploy/with-postgres.sh).
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <barrier>
#include <deque>
#include <fstream>
#include <map>
#include <mutex>
#include <pqxx/pqxx>
#include <set>
#include <thread>

#include "patient_db/case_bundle.h"
#include "patient_db/pg_store.h"
#include "server/auth.h"
#include "tests/integration/server_process.h"
#include "tests/integration/test_server.h"
#include "tests/patient_db/pg_test_util.h"

namespace ves::server::testing {
namespace {

using patient_db::PgStore;
using patient_db::PgStoreOptions;
using patient_db::StoreRole;
namespace pg = patient_db::pg_testing;

using Replica = ServerProcess;

// The PostgreSQL tool `name` (pg_dump, pg_restore): on PATH (with-postgres.sh
// puts the server's bin dir first) or in Debian's versioned directory.
std::string PgTool(const std::string& name) {
  for (const char* dir : {"/usr/lib/postgresql/17/bin", "/usr/lib/postgresql/16/bin",
                          "/usr/lib/postgresql/15/bin"}) {
    if (std::filesystem::exists(std::string(dir) + "/" + name)) return std::string(dir) + "/" + name;
  }
  return name;
}

class Replicas : public ::testing::Test {
 protected:
  void SetUp() override {
    base_url_ = pg::TestPostgresUrl();
    if (base_url_.empty()) GTEST_SKIP() << pg::kNoPostgresMessage;
    schema_ = pg::UniqueSchemaName(::testing::UnitTest::GetInstance()->current_test_info()->name());
    url_ = pg::FreshSchema(base_url_, schema_);
    dir_ = MakeTempDir("replicas");
    store_ = Open(url_);  // migrates before the servers start
    store_->AddInstitution("north", 1);
    for (int t = 0; t < 4; ++t) store_->AddTrainee({Trainee(t), "north", "T", 1});
    PutSampleCase(*store_, "north");
    station_ = NewToken();
    admin_ = NewToken();
    ASSERT_TRUE(store_->AddToken({Sha256Hex(station_), StoreRole::kStation, "north", "", "st", 1}).ok());
    ASSERT_TRUE(store_->AddToken({Sha256Hex(admin_), StoreRole::kAdmin, "north", "", "ad", 1}).ok());
  }
  void TearDown() override {
    for (Replica& r : replicas_) Stop(&r, SIGKILL);
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }

  static std::string Trainee(int i) { return "t" + std::to_string(i); }
  static std::unique_ptr<PgStore> Open(const std::string& url) {
    PgStoreOptions o;
    o.url = url;
    o.pool_size = 2;
    return std::make_unique<PgStore>(o);
  }

  Replica& Start() {
    replicas_.push_back(StartServerProcess(url_, dir_, std::to_string(replicas_.size())));
    EXPECT_GT(replicas_.back().port, 0) << "ves-server did not start, see " << replicas_.back().log;
    return replicas_.back();
  }
  static void Stop(Replica* r, int signal) { StopServerProcess(r, signal); }
  ClientOptions Client(const Replica& r, const std::string& token) const {
    ClientOptions o;
    o.address = r.address();
    o.token = token;
    o.deadline = std::chrono::seconds(10);
    return o;
  }

  std::string base_url_, schema_, url_;
  std::filesystem::path dir_;
  std::unique_ptr<PgStore> store_;
  std::string station_, admin_;
  std::deque<Replica> replicas_;  // references stay valid as replicas start
};

TEST_F(Replicas, ThirtyTwoClientsWithRepeatedUuidsStoreExactlyTheDistinctRecords) {
  Replica& a = Start();
  Replica& b = Start();
  ASSERT_TRUE(a.port > 0 && b.port > 0);
  // 150 records; 32 clients send 25 uploads each, drawn from them at random
  // and sent to either replica, so each uuid arrives ~5 times on both.
  std::mt19937_64 uuid_rng(7);
  std::vector<ves::v1::SessionRecord> records;
  for (int i = 0; i < 150; ++i) records.push_back(MakeRecord(NewUuid(uuid_rng), Trainee(i % 4), i));
  std::mutex mutex;
  std::map<std::string, std::set<std::pair<std::string, int64_t>>> answers;  // uuid -> (sha, ms)
  std::set<std::string> sent;
  std::atomic<int> errors{0};
  std::vector<std::thread> clients;
  const ClientOptions to[2] = {Client(a, station_), Client(b, station_)};
  for (int c = 0; c < 32; ++c) {
    clients.emplace_back([&, c] {
      std::mt19937 rng(c);
      for (int i = 0; i < 25; ++i) {
        const auto& rec = records[rng() % records.size()];
        ves::v1::UploadSessionResponse resp;
        grpc::Status st = UploadSession(to[rng() % 2], rec, &resp);
        std::lock_guard lock(mutex);
        sent.insert(rec.uuid());
        if (!st.ok()) {
          ++errors;
          ADD_FAILURE() << st.error_message();
          continue;
        }
        answers[rec.uuid()].insert({resp.body_sha256_hex(), resp.stored_unix_ms()});
      }
    });
  }
  for (auto& t : clients) t.join();
  EXPECT_EQ(errors, 0);
  // Every answer for a uuid is the same (the first durable upload's).
  for (const auto& [uuid, set] : answers) EXPECT_EQ(set.size(), 1u) << uuid;
  EXPECT_EQ(store_->CountSessions().value, static_cast<int64_t>(sent.size()));
  for (const auto& uuid : sent) EXPECT_TRUE(store_->GetSession(uuid).ok()) << uuid;
}

// Four stations upload through both replicas at once: the station rows are
// merged under row locks without a deadlock, and each ends with the health of
// its newest session whatever order the uploads committed in.
TEST_F(Replicas, StationRowsFromBothReplicasEndWithTheNewestSessionsHealth) {
  Replica& a = Start();
  Replica& b = Start();
  ASSERT_TRUE(a.port > 0 && b.port > 0);
  std::mt19937_64 uuid_rng(11);
  std::vector<ves::v1::SessionRecord> records;
  for (int i = 0; i < 80; ++i) {
    auto rec = MakeRecord(NewUuid(uuid_rng), Trainee(i % 4), i);  // seed i starts i minutes in
    rec.set_station_id("st-" + std::to_string(i % 4));
    rec.set_software_version("0.1." + std::to_string(i));
    auto* h = rec.mutable_station_health();
    h->set_device("sim");
    h->set_hard_faults(static_cast<uint64_t>(i));
    records.push_back(rec);
  }
  std::atomic<int> errors{0};
  std::vector<std::thread> clients;
  const ClientOptions to[2] = {Client(a, station_), Client(b, station_)};
  for (int c = 0; c < 16; ++c) {
    clients.emplace_back([&, c] {
      for (size_t i = static_cast<size_t>(c); i < records.size(); i += 16) {
        ves::v1::UploadSessionResponse resp;
        const grpc::Status st = UploadSession(to[(i / 16) % 2], records[i], &resp);
        if (!st.ok()) {
          ++errors;
          ADD_FAILURE() << st.error_message();
        }
      }
    });
  }
  for (auto& t : clients) t.join();
  EXPECT_EQ(errors, 0);
  auto rows = store_->ListStations("north");
  ASSERT_TRUE(rows.ok()) << rows.status.message;
  ASSERT_EQ(rows.value.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    const auto& newest = records[76 + k];  // the last session of station k
    EXPECT_EQ(rows.value[k].station_id, "st-" + std::to_string(k));
    EXPECT_EQ(rows.value[k].software_version, newest.software_version());
    EXPECT_EQ(rows.value[k].health_session_uuid, newest.uuid());
    EXPECT_EQ(rows.value[k].health.hard_faults, static_cast<uint64_t>(76 + k));
  }
}

TEST_F(Replicas, SameUuidToBothReplicasAtOnceIsStoredOnce) {
  Replica& a = Start();
  Replica& b = Start();
  ASSERT_TRUE(a.port > 0 && b.port > 0);
  std::mt19937_64 rng(11);
  constexpr int kRounds = 40;
  std::vector<ves::v1::SessionRecord> records;
  for (int i = 0; i < kRounds; ++i) records.push_back(MakeRecord(NewUuid(rng), "t0", i));
  std::barrier sync(2);
  ves::v1::UploadSessionResponse ra[kRounds], rb[kRounds];
  grpc::Status sa[kRounds], sb[kRounds];
  std::thread ta([&] {
    for (int i = 0; i < kRounds; ++i) {
      sync.arrive_and_wait();
      sa[i] = UploadSession(Client(a, station_), records[i], &ra[i]);
    }
  });
  std::thread tb([&] {
    for (int i = 0; i < kRounds; ++i) {
      sync.arrive_and_wait();
      sb[i] = UploadSession(Client(b, station_), records[i], &rb[i]);
    }
  });
  ta.join();
  tb.join();
  for (int i = 0; i < kRounds; ++i) {
    ASSERT_TRUE(sa[i].ok() && sb[i].ok()) << sa[i].error_message() << sb[i].error_message();
    EXPECT_EQ(ra[i].stored_unix_ms(), rb[i].stored_unix_ms()) << "round " << i;
    EXPECT_EQ(ra[i].body_sha256_hex(), rb[i].body_sha256_hex());
  }
  EXPECT_EQ(store_->CountSessions().value, kRounds);
  // One "OK" and one "OK duplicate" audit row per uuid, whichever replica won.
  pqxx::connection conn(url_);
  pqxx::nontransaction q(conn);
  auto r = q.exec(
      "SELECT COUNT(*) FILTER (WHERE result = 'OK'), COUNT(*) FILTER (WHERE result = "
      "'OK duplicate') FROM audit_log WHERE action = 'session.upload'");
  EXPECT_EQ(r[0][0].as<int>(), kRounds);
  EXPECT_EQ(r[0][1].as<int>(), kRounds);
}

TEST_F(Replicas, CaseUploadRacesResolveToOneStoredVersion) {
  Replica& a = Start();
  Replica& b = Start();
  ASSERT_TRUE(a.port > 0 && b.port > 0);
  for (uint32_t version = 2; version <= 5; ++version) {  // version 1 is stored by SetUp
    // The same bundle to both: both succeed, exactly one stored it.
    auto c = SampleCase();
    c.set_version(version);
    const std::string bundle = patient_db::EncodeCaseBundle(c);
    ves::v1::UploadCaseResponse ua, ub;
    grpc::Status sa, sb;
    std::thread ta([&] { sa = UploadCase(Client(a, admin_), bundle, "a", &ua); });
    std::thread tb([&] { sb = UploadCase(Client(b, admin_), bundle, "b", &ub); });
    ta.join();
    tb.join();
    ASSERT_TRUE(sa.ok() && sb.ok()) << sa.error_message() << " / " << sb.error_message();
    EXPECT_NE(ua.already_stored(), ub.already_stored()) << "version " << version;
    EXPECT_EQ(ua.summary().sha256_hex(), ub.summary().sha256_hex());
  }
  // Two different bundles claiming one new version: one wins, the other is
  // told ALREADY_EXISTS, and the stored version is the winner's.
  auto x = SampleCase();
  x.set_version(10);
  auto y = x;
  y.set_title("the other one");
  const std::string bx = patient_db::EncodeCaseBundle(x), by = patient_db::EncodeCaseBundle(y);
  ves::v1::UploadCaseResponse ux, uy;
  grpc::Status sx, sy;
  std::thread tx([&] { sx = UploadCase(Client(a, admin_), bx, "x", &ux); });
  std::thread ty([&] { sy = UploadCase(Client(b, admin_), by, "y", &uy); });
  tx.join();
  ty.join();
  ASSERT_NE(sx.ok(), sy.ok()) << sx.error_message() << " / " << sy.error_message();
  EXPECT_EQ((sx.ok() ? sy : sx).error_code(), grpc::StatusCode::ALREADY_EXISTS);
  auto stored = store_->GetCase(x.id(), 10);
  ASSERT_TRUE(stored.ok());
  EXPECT_EQ(stored.value.sha256_hex, Sha256Hex(sx.ok() ? bx : by));
}

struct UploadRun {
  std::mutex mutex;
  std::set<std::string> acknowledged;
  std::set<std::string> attempted;
  std::atomic<bool> stop{false};
  size_t Acked() {
    std::lock_guard lock(mutex);
    return acknowledged.size();
  }
};

// Uploads fresh records to `first`; when it stops answering, sends the same
// record (same uuid) to `second` and carries on there, as a station would.
void UploadWithFailover(ClientOptions first, ClientOptions second, UploadRun* run, int seed) {
  std::mt19937_64 rng(1000 + seed);
  ClientOptions target = first;
  target.deadline = std::chrono::seconds(3);
  second.deadline = std::chrono::seconds(10);
  for (int i = 0; !run->stop; ++i) {
    const auto rec = MakeRecord(NewUuid(rng), "t" + std::to_string(seed % 4), i);
    {
      std::lock_guard lock(run->mutex);
      run->attempted.insert(rec.uuid());
    }
    ves::v1::UploadSessionResponse resp;
    grpc::Status st = UploadSession(target, rec, &resp);
    if (!st.ok() && target.address != second.address) {
      target = second;
      st = UploadSession(target, rec, &resp);
    }
    if (!st.ok()) return;
    std::lock_guard lock(run->mutex);
    run->acknowledged.insert(resp.uuid());
  }
}

TEST_F(Replicas, SigkillOfOneReplicaMidRunLosesNoAcknowledgedRecord) {
  Replica& a = Start();
  Replica& b = Start();
  ASSERT_TRUE(a.port > 0 && b.port > 0);
  UploadRun run;
  std::vector<std::thread> clients;
  for (int c = 0; c < 32; ++c) {
    const bool on_a = c % 2 == 0;
    clients.emplace_back(UploadWithFailover, Client(on_a ? a : b, station_),
                         Client(b, station_), &run, c);
  }
  for (int i = 0; i < 1000 && run.Acked() < 400; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  Stop(&a, SIGKILL);  // in the middle of the uploads
  const size_t acked_at_kill = run.Acked();
  for (int i = 0; i < 1000 && run.Acked() < acked_at_kill + 300; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  run.stop = true;
  for (auto& t : clients) t.join();
  ASSERT_GE(acked_at_kill, 400u);
  ASSERT_GE(run.acknowledged.size(), acked_at_kill + 300) << "uploads did not go on on b";
  size_t missing = 0;
  for (const auto& uuid : run.acknowledged) missing += store_->GetSession(uuid).ok() ? 0 : 1;
  EXPECT_EQ(missing, 0u) << "of " << run.acknowledged.size() << " acknowledged records";
  // Nothing beyond what was sent, nothing twice (uuid is the primary key).
  EXPECT_LE(store_->CountSessions().value, static_cast<int64_t>(run.attempted.size()));
}

TEST_F(Replicas, BackupTakenDuringUploadsRestoresToAConsistentDatabase) {
  Replica& a = Start();
  Replica& b = Start();
  ASSERT_TRUE(a.port > 0 && b.port > 0);
  auto c = SampleCase();
  const std::string bundle = patient_db::EncodeCaseBundle(c);
  ves::v1::UploadCaseResponse up;
  ASSERT_TRUE(UploadCase(Client(a, admin_), bundle, "case", &up).ok());
  UploadRun run;
  std::vector<std::thread> clients;
  for (int i = 0; i < 8; ++i) {
    clients.emplace_back(UploadWithFailover, Client(i % 2 ? a : b, station_),
                         Client(i % 2 ? a : b, station_), &run, i);
  }
  for (int i = 0; i < 1000 && run.Acked() < 200; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const size_t acked_before = run.Acked();
  std::set<std::string> acked_before_dump;
  {
    std::lock_guard lock(run.mutex);
    acked_before_dump = run.acknowledged;
  }
  const std::string dump = (dir_ / "ves.dump").string();
  const std::string cmd = PgTool("pg_dump") + " -Fc -n " + schema_ + " -f " + dump + " '" +
                          base_url_ + "'";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  for (int i = 0; i < 1000 && run.Acked() < acked_before + 100; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  run.stop = true;
  for (auto& t : clients) t.join();

  // Restore into a new database.
  const std::string db = schema_ + "_restored";
  {
    pqxx::connection conn(base_url_);
    pqxx::nontransaction q(conn);
    q.exec("DROP DATABASE IF EXISTS " + q.quote_name(db));
    q.exec("CREATE DATABASE " + q.quote_name(db));
  }
  const std::string restored_base = base_url_.substr(0, base_url_.rfind('/') + 1) + db;
  const std::string restore = PgTool("pg_restore") + " --exit-on-error -d '" + restored_base +
                              "' " + dump;
  ASSERT_EQ(std::system(restore.c_str()), 0) << restore;
  {
    auto restored = Open(pg::UrlWithSchema(restored_base, schema_));  // migrations: no-op
    // Consistency: every record acknowledged before the dump began is there,
    // nothing more than was sent, bodies match their hashes, each stored
    // session has its one "OK" upload audit row (same transaction), and the
    // case's blob is there and matches its address.
    size_t missing = 0;
    for (const auto& uuid : acked_before_dump) missing += restored->GetSession(uuid).ok() ? 0 : 1;
    EXPECT_EQ(missing, 0u);
    const int64_t count = restored->CountSessions().value;
    EXPECT_GE(count, static_cast<int64_t>(acked_before_dump.size()));
    EXPECT_LE(count, static_cast<int64_t>(run.attempted.size()));
    pqxx::connection conn(pg::UrlWithSchema(restored_base, schema_));
    pqxx::nontransaction q(conn);
    int bad_hash = 0;
    for (const auto& row : q.exec("SELECT uuid, body, body_sha256_hex FROM sessions")) {
      if (Sha256Hex(pqxx::binarystring(row[1]).str()) != row[2].as<std::string>()) ++bad_hash;
      if (!run.attempted.count(row[0].as<std::string>())) ++bad_hash;
    }
    EXPECT_EQ(bad_hash, 0);
    auto audit = q.exec(
        "SELECT COUNT(*) FROM sessions s WHERE (SELECT COUNT(*) FROM audit_log a WHERE "
        "a.target = s.uuid AND a.action = 'session.upload' AND a.result = 'OK') <> 1");
    EXPECT_EQ(audit[0][0].as<int>(), 0);
    auto blob = restored->GetBlob(up.summary().sha256_hex());
    ASSERT_TRUE(blob.ok());
    EXPECT_EQ(Sha256Hex(blob.value), up.summary().sha256_hex());
    // The restored database takes new writes (sequences restored with it).
    patient_db::WriteBatch more;
    more.audit = {{0, 1, "x", "x", "admin", "north", "check", "", "OK"}};
    EXPECT_TRUE(restored->CommitBatch(more).ok());
  }
  pqxx::connection conn(base_url_);
  pqxx::nontransaction q(conn);
  q.exec("DROP DATABASE IF EXISTS " + q.quote_name(db) + " WITH (FORCE)");
}

}  // namespace
}  // namespace ves::server::testing
