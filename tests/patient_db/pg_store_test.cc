// PostgreSQL specifics of PgStore: migrations under concurrent start, durable
// commit settings, the pool bound, races between two stores on one database
// (two server replicas) and which errors are retried. The shared contract is
// in pg_store_contract_test.cc. Skipped unless VES_TEST_POSTGRES_URL is set.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <map>
#include <pqxx/pqxx>
#include <random>
#include <set>
#include <thread>

#include "patient_db/migrations/postgres/pg_migrations.h"
#include "patient_db/pg_store.h"
#include "patient_db/store_factory.h"
#include "tests/patient_db/pg_test_util.h"

namespace ves::patient_db {
namespace {

using pg_testing::FreshSchema;
using pg_testing::TestPostgresUrl;
using pg_testing::UniqueSchemaName;

class PgStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    base_url_ = TestPostgresUrl();
    if (base_url_.empty()) GTEST_SKIP() << pg_testing::kNoPostgresMessage;
    url_ = FreshSchema(base_url_, UniqueSchemaName(
        ::testing::UnitTest::GetInstance()->current_test_info()->name()));
  }
  std::unique_ptr<PgStore> Open(size_t pool_size = 4) {
    PgStoreOptions o;
    o.url = url_;
    o.pool_size = pool_size;
    return std::make_unique<PgStore>(o);
  }
  static void Seed(Store& store) {
    ASSERT_TRUE(store.AddInstitution("north", 1).ok());
    ASSERT_TRUE(store.AddTrainee({"t1", "north", "One", 1}).ok());
  }
  static SessionRow Session(const std::string& uuid, const std::string& body) {
    SessionRow r;
    r.uuid = uuid;
    r.trainee_id = "t1";
    r.institution = "north";
    r.case_id = "standard-adult";
    r.case_version = 1;
    r.station_id = "st";
    r.start_unix_ms = 1000;
    r.end_unix_ms = 2000;
    r.body = body;
    r.body_sha256_hex = "h-" + body;
    r.stored_unix_ms = 3000;
    return r;
  }
  std::string base_url_;
  std::string url_;
};

TEST_F(PgStoreTest, MigrationsRunOnceEvenWhenStoresStartTogether) {
  // Four "replicas" opening an empty schema at once: the advisory lock lets one
  // migrate, the others find the versions recorded.
  std::vector<std::thread> threads;
  std::atomic<int> opened{0};
  for (int i = 0; i < 4; ++i) {
    threads.emplace_back([&] {
      auto s = Open(1);
      if (s->schema_version() == PgMigrations().back().version) ++opened;
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(opened, 4);
  pqxx::connection conn(url_);
  pqxx::nontransaction q(conn);
  auto r = q.exec("SELECT version, COUNT(*) FROM schema_migrations GROUP BY version ORDER BY 1");
  ASSERT_EQ(r.size(), PgMigrations().size());
  for (const auto& row : r) EXPECT_EQ(row[1].as<int>(), 1) << "version " << row[0].c_str();
}

TEST_F(PgStoreTest, MigrationsAreTheSqliteVersionsWithByteaForBlob) {
  ASSERT_EQ(PgMigrations().size(), SqlMigrations().size());
  for (size_t i = 0; i < PgMigrations().size(); ++i) {
    EXPECT_EQ(PgMigrations()[i].version, SqlMigrations()[i].version);
    EXPECT_EQ(PgMigrations()[i].sql.find("BLOB"), std::string::npos);
  }
  Open();
  pqxx::connection conn(url_);
  pqxx::nontransaction q(conn);
  auto r = q.exec(
      "SELECT data_type FROM information_schema.columns WHERE table_schema = current_schema() "
      "AND table_name = 'sessions' AND column_name = 'body'");
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0][0].as<std::string>(), "bytea");
}

TEST_F(PgStoreTest, PooledConnectionsCommitSynchronouslyWhateverTheUrlSays) {
  // The URL asks for synchronous_commit=off; the pool must override it.
  PgPool pool(url_ + "%20-csynchronous_commit%3Doff", 2);
  {
    pqxx::connection raw(url_ + "%20-csynchronous_commit%3Doff");
    pqxx::nontransaction q(raw);
    ASSERT_EQ(q.exec("SHOW synchronous_commit")[0][0].as<std::string>(), "off");
  }
  auto lease = pool.Acquire();
  pqxx::nontransaction q(lease.conn());
  EXPECT_EQ(q.exec("SHOW synchronous_commit")[0][0].as<std::string>(), "on");
}

TEST_F(PgStoreTest, PoolLendsAtMostItsSizeAndReusesConnections) {
  PgPool pool(url_, 2);
  auto a = std::make_unique<PgPool::Lease>(pool.Acquire());
  auto b = std::make_unique<PgPool::Lease>(pool.Acquire());
  const int backend_a = a->conn().backendpid();
  std::atomic<bool> third_acquired{false};
  std::thread t([&] {
    auto c = pool.Acquire();
    third_acquired = true;
    // The connection handed back by `a`, not a new one.
    EXPECT_EQ(c.conn().backendpid(), backend_a);
  });
  // Polled until the third caller is inside Acquire, waiting: only then does
  // "not acquired yet" say anything (a fixed sleep could pass before the
  // thread even ran).
  for (int i = 0; i < 5000 && pool.waiting() == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  EXPECT_EQ(pool.waiting(), 1u);
  EXPECT_FALSE(third_acquired) << "a third lease while two were out";
  a.reset();
  t.join();
  EXPECT_TRUE(third_acquired);
}

TEST_F(PgStoreTest, TwoStoresStoreEachUuidOnceUnderConcurrentOverlappingBatches) {
  // Two stores = two replicas. 8 writers each commit batches of 10 uuids drawn
  // from 60, so the same uuid is in flight on both at once, in any order.
  auto first = Open(4);
  auto second = Open(4);
  Seed(*first);
  constexpr int kUuids = 60;
  std::mutex mutex;
  std::map<std::string, int> stored;  // uuid -> kStored answers
  std::atomic<int> failures{0};
  std::vector<std::thread> writers;
  for (int w = 0; w < 8; ++w) {
    writers.emplace_back([&, w] {
      Store& store = w % 2 == 0 ? *first : *second;
      std::mt19937 rng(w);
      for (int b = 0; b < 10; ++b) {
        WriteBatch batch;
        for (int i = 0; i < 10; ++i) {
          const std::string uuid = "u" + std::to_string(rng() % kUuids);
          batch.sessions.push_back(Session(uuid, "body-" + uuid));
        }
        auto r = store.CommitBatch(batch);
        if (!r.ok()) {
          ++failures;
          continue;
        }
        std::lock_guard lock(mutex);
        for (size_t i = 0; i < r.value.size(); ++i) {
          if (r.value[i].outcome == SessionPut::kStored) ++stored[batch.sessions[i].uuid];
          if (r.value[i].outcome == SessionPut::kConflict) ++failures;
        }
      }
    });
  }
  for (auto& t : writers) t.join();
  EXPECT_EQ(failures, 0);
  for (const auto& [uuid, n] : stored) EXPECT_EQ(n, 1) << uuid << " stored " << n << " times";
  EXPECT_EQ(first->CountSessions().value, static_cast<int64_t>(stored.size()));
  EXPECT_EQ(second->CountSessions().value, static_cast<int64_t>(stored.size()));
}

TEST_F(PgStoreTest, SameUuidOtherBodyOnTwoStoresAtOnceOneWinsOneConflicts) {
  auto first = Open();
  auto second = Open();
  Seed(*first);
  for (int round = 0; round < 10; ++round) {
    const std::string uuid = "race-" + std::to_string(round);
    StoreResult<std::vector<SessionPutResult>> a, b;
    std::thread ta([&] { a = first->CommitBatch({{Session(uuid, "a")}, {}, {}}); });
    std::thread tb([&] { b = second->CommitBatch({{Session(uuid, "b")}, {}, {}}); });
    ta.join();
    tb.join();
    ASSERT_TRUE(a.ok() && b.ok()) << a.status.message << b.status.message;
    std::multiset<SessionPut> outcomes{a.value[0].outcome, b.value[0].outcome};
    EXPECT_EQ(outcomes, (std::multiset<SessionPut>{SessionPut::kStored, SessionPut::kConflict}));
    const std::string winner = a.value[0].outcome == SessionPut::kStored ? "h-a" : "h-b";
    EXPECT_EQ(first->GetSession(uuid).value.body_sha256_hex, winner);
    // The loser is told which body won.
    EXPECT_EQ((a.value[0].outcome == SessionPut::kConflict ? a : b).value[0].first.body_sha256_hex,
              winner);
  }
}

TEST_F(PgStoreTest, CaseUploadRaceOnTwoStoresResolvesToOneVersion) {
  auto first = Open();
  auto second = Open();
  Seed(*first);
  CaseRow c;
  c.case_id = "c";
  c.version = 1;
  c.institution = "north";
  for (int round = 0; round < 5; ++round) {
    c.version = static_cast<uint32_t>(round + 1);
    // Same content from both: one stores, the other is told already_stored.
    CaseRow same = c;
    same.sha256_hex = "same" + std::to_string(round);
    StoreResult<PutCaseResult> a, b;
    std::thread ta([&] { a = first->PutCase(same, "payload"); });
    std::thread tb([&] { b = second->PutCase(same, "payload"); });
    ta.join();
    tb.join();
    ASSERT_TRUE(a.ok() && b.ok()) << a.status.message << " / " << b.status.message;
    EXPECT_NE(a.value.already_stored, b.value.already_stored);
  }
  // Other content under one version: exactly one wins, the other kAlreadyExists,
  // and the loser's blob is not left behind.
  c.version = 100;
  CaseRow x = c, y = c;
  x.sha256_hex = "hx";
  y.sha256_hex = "hy";
  StoreResult<PutCaseResult> a, b;
  std::thread ta([&] { a = first->PutCase(x, "xx"); });
  std::thread tb([&] { b = second->PutCase(y, "yy"); });
  ta.join();
  tb.join();
  EXPECT_NE(a.ok(), b.ok());
  const StoreStatus& lost = a.ok() ? b.status : a.status;
  EXPECT_EQ(lost.code, StoreCode::kAlreadyExists);
  const std::string loser_sha = a.ok() ? "hy" : "hx";
  EXPECT_EQ(first->GetBlob(loser_sha).status.code, StoreCode::kNotFound);
}

TEST_F(PgStoreTest, AuditIdsFromTwoStoresAreUniqueAndIncreasing) {
  auto first = Open();
  auto second = Open();
  AuditRow row{0, 10, "tok", "l", "station", "north", "case.download", "c@1", "OK"};
  std::vector<std::thread> threads;
  for (int i = 0; i < 4; ++i) {
    threads.emplace_back([&, i] {
      Store& s = i % 2 ? *first : *second;
      for (int j = 0; j < 25; ++j) ASSERT_TRUE(s.CommitBatch({{}, {}, {row}}).ok());
    });
  }
  for (auto& t : threads) t.join();
  auto rows = first->ListAudit(0, 1000);
  ASSERT_TRUE(rows.ok());
  ASSERT_EQ(rows.value.size(), 100u);
  for (size_t i = 1; i < rows.value.size(); ++i) EXPECT_LT(rows.value[i - 1].id, rows.value[i].id);
}

TEST_F(PgStoreTest, ReadsAndWritesCarryOnAfterTheServerDropsTheConnections) {
  // The application_name lets this test terminate only its own connections.
  const std::string tagged = url_ + "&application_name=" + UniqueSchemaName("drop");
  PgStoreOptions o;
  o.url = tagged;
  o.pool_size = 2;
  PgStore store(o);
  Seed(store);
  ASSERT_TRUE(store.CommitBatch({{Session("before", "b")}, {}, {}}).ok());
  {
    pqxx::connection admin(base_url_);
    pqxx::nontransaction q(admin);
    auto r = q.exec_params(
        "SELECT COUNT(pg_terminate_backend(pid)) FROM pg_stat_activity "
        "WHERE application_name = $1",
        UniqueSchemaName("drop"));
    ASSERT_GE(r[0][0].as<int>(), 1);
  }
  // Both pooled connections are dead; each call must reconnect, not fail.
  EXPECT_TRUE(store.GetSession("before").ok());
  auto w = store.CommitBatch({{Session("after", "a")}, {}, {}});
  ASSERT_TRUE(w.ok()) << w.status.message;
  EXPECT_EQ(w.value[0].outcome, SessionPut::kStored);
  EXPECT_EQ(store.CountSessions().value, 2);
  EXPECT_GE(store.stats().retries, 1u);
}

TEST(PgStoreRetry, OnlyRollbacksAndLostConnectionsAreRetried) {
  EXPECT_TRUE(PgStore::IsRetryableBeforeCommit(pqxx::serialization_failure("40001")));
  EXPECT_TRUE(PgStore::IsRetryableBeforeCommit(pqxx::deadlock_detected("40P01")));
  EXPECT_TRUE(PgStore::IsRetryableBeforeCommit(pqxx::broken_connection("gone")));
  EXPECT_FALSE(PgStore::IsRetryableBeforeCommit(pqxx::unique_violation("23505")));
  EXPECT_FALSE(PgStore::IsRetryableBeforeCommit(pqxx::syntax_error("42601")));
  // An in-doubt commit is never re-run blindly (it is looked up by txid).
  EXPECT_FALSE(PgStore::IsRetryableBeforeCommit(pqxx::in_doubt_error("commit?")));
}

TEST(StoreFactory, ChoosesTheBackendByScheme) {
  EXPECT_TRUE(IsPostgresUrl("postgresql://ves@db/ves"));
  EXPECT_TRUE(IsPostgresUrl("postgres://ves@db/ves"));
  EXPECT_FALSE(IsPostgresUrl("sqlite:/var/lib/ves/ves.db"));
  EXPECT_THROW(OpenStoreFromUrl("mysql://x"), std::invalid_argument);
  // An unreachable server is an open failure, not a bad URL.
  EXPECT_THROW(OpenStoreFromUrl("postgresql://nobody@127.0.0.1:1/none?connect_timeout=2"),
               std::runtime_error);
  const auto path = std::filesystem::temp_directory_path() /
                    ("ves_factory_" + std::to_string(::getpid()) + ".db");
  EXPECT_NE(OpenStoreFromUrl("sqlite:" + path.string()), nullptr);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace ves::patient_db
