#include "patient_db/pg_store.h"

#include <chrono>
#include <pqxx/pqxx>
#include <stdexcept>
#include <thread>

#include "patient_db/clock.h"
#include "patient_db/migrations/postgres/pg_migrations.h"
#include "patient_db/pg_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {
namespace {

// Any constant works: it only has to be the same in every replica.
constexpr int64_t kMigrationLockKey = 0x7665735f6d6967;  // "ves_mig"

StoreStatus Internal(const std::string& what, const std::string& error) {
  return StoreStatus::Error(StoreCode::kInternal, what + ": " + error);
}

}  // namespace

PgStore::PgStore(PgStoreOptions options)
    : options_(std::move(options)), pool_(options_.url, options_.pool_size) {
  if (options_.max_attempts < 1) {
    throw std::invalid_argument("PostgreSQL max_attempts must be >= 1, not " +
                                std::to_string(options_.max_attempts));
  }
  try {
    Migrate();
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot open PostgreSQL store: " + std::string(e.what()));
  }
}

PgStore::~PgStore() = default;

PgStore::Stats PgStore::stats() const {
  std::lock_guard lock(stats_mutex_);
  return stats_;
}

void PgStore::Migrate() {
  auto conn = pool_.Connect();
  pqxx::work tx(*conn);
  // Replicas starting together queue here; DDL is transactional in PostgreSQL,
  // so a failed migration leaves nothing behind.
  tx.exec_params("SELECT pg_advisory_xact_lock($1)", kMigrationLockKey);
  tx.exec(
      "CREATE TABLE IF NOT EXISTS schema_migrations (version INTEGER PRIMARY KEY, "
      "description TEXT NOT NULL, applied_unix_ms BIGINT NOT NULL)");
  for (const Migration& m : PgMigrations()) {
    const bool applied =
        !tx.exec_params("SELECT 1 FROM schema_migrations WHERE version = $1", m.version).empty();
    if (!applied) {
      try {
        tx.exec(m.sql);
      } catch (const std::exception& e) {
        throw std::runtime_error("migration " + std::to_string(m.version) + " failed: " +
                                 e.what());
      }
      tx.exec_params(
          "INSERT INTO schema_migrations (version, description, applied_unix_ms) "
          "VALUES ($1, $2, $3)",
          m.version, m.description, NowUnixMs());
    }
    schema_version_ = m.version;
  }
  tx.commit();
}

bool PgStore::IsRetryableBeforeCommit(const std::exception& e) {
  // serialization_failure and deadlock_detected derive from transaction_rollback.
  return dynamic_cast<const pqxx::transaction_rollback*>(&e) != nullptr ||
         dynamic_cast<const pqxx::broken_connection*>(&e) != nullptr;
}

PgStore::InDoubt PgStore::ResolveInDoubt(int64_t txid) {
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(options_.in_doubt_wait_ms);
  {
    std::lock_guard lock(stats_mutex_);
    ++stats_.in_doubt_resolved;
  }
  while (std::chrono::steady_clock::now() < deadline) {
    try {
      auto conn = pool_.Connect();
      pqxx::nontransaction q(*conn);
      pqxx::result r = q.exec_params("SELECT txid_status($1)", txid);
      if (!r.empty() && !r[0][0].is_null()) {
        const std::string status = r[0][0].as<std::string>();
        if (status == "committed") return InDoubt::kCommitted;
        if (status == "aborted") return InDoubt::kAborted;
      }
      // "in progress": the server has not finished the commit yet; NULL: too
      // old to know (cannot happen within seconds).
    } catch (const pqxx::broken_connection&) {
      // The server may be restarting; try again until the deadline.
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return InDoubt::kUnknown;
}

StoreStatus PgStore::Transact(const std::string& what, TxMode mode, const Body& body) {
  std::string last_error;
  for (int attempt = 1; attempt <= options_.max_attempts; ++attempt) {
    if (attempt > 1) {
      {
        std::lock_guard lock(stats_mutex_);
        ++stats_.retries;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10 << std::min(attempt, 6)));
    }
    int64_t txid = 0;
    bool commit_sent = false;
    try {
      PgPool::Lease lease = pool_.Acquire();
      try {
        // Reads run each statement on its own (READ COMMITTED gives every
        // statement its own snapshot either way): no BEGIN/COMMIT round trips.
        std::unique_ptr<pqxx::transaction_base> tx;
        if (mode == TxMode::kWrite) {
          tx = std::make_unique<pqxx::work>(lease.conn());
          // Known before COMMIT so an in-doubt commit can be looked up after.
          txid = tx->exec("SELECT txid_current()")[0][0].as<int64_t>();
        } else {
          tx = std::make_unique<pqxx::nontransaction>(lease.conn());
        }
        StoreStatus status = body(*tx);
        if (!status.ok()) {
          tx->abort();
          return status;
        }
        commit_sent = mode == TxMode::kWrite;
        tx->commit();
        return StoreStatus::Ok();
      } catch (const pqxx::broken_connection&) {
        lease.Discard();
        if (!commit_sent) throw;
        // Lost while committing: fall through to the in-doubt lookup below.
      } catch (const pqxx::in_doubt_error&) {
        lease.Discard();
      }
      switch (ResolveInDoubt(txid)) {
        case InDoubt::kCommitted: return StoreStatus::Ok();
        case InDoubt::kAborted: last_error = "commit lost with the connection"; continue;
        case InDoubt::kUnknown:
          return Internal(what, "outcome of commit (txid " + std::to_string(txid) +
                                    ") unknown: connection lost during COMMIT");
      }
    } catch (const pqxx::integrity_constraint_violation& e) {
      return StoreStatus::Error(StoreCode::kInvalidArgument, what + ": " + e.what());
    } catch (const std::exception& e) {
      if (!IsRetryableBeforeCommit(e)) return Internal(what, e.what());
      last_error = e.what();
    }
  }
  return Internal(what, "gave up after " + std::to_string(options_.max_attempts) +
                            " attempts: " + last_error);
}

StoreStatus PgStore::AddInstitution(const std::string& name, int64_t now_unix_ms) {
  return Transact("add institution", TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    tx.exec_params(
        "INSERT INTO institutions (name, created_unix_ms) VALUES ($1, $2) "
        "ON CONFLICT (name) DO NOTHING",
        name, now_unix_ms);
    return StoreStatus::Ok();
  });
}

StoreResult<bool> PgStore::HasInstitution(const std::string& name) {
  return Query<bool>("find institution", [&](pqxx::transaction_base& tx) {
    return StoreResult<bool>(
        !tx.exec_params("SELECT 1 FROM institutions WHERE name = $1", name).empty());
  });
}

StoreStatus PgStore::AddToken(const TokenRow& t) {
  return Transact("add token", TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    tx.exec_params(
        "INSERT INTO tokens (token_sha256_hex, role, institution, trainee_id, label, "
        "created_unix_ms) VALUES ($1, $2, $3, $4, $5, $6)",
        t.token_sha256_hex, std::string(RoleName(t.role)), t.institution, t.trainee_id, t.label,
        t.created_unix_ms);
    return StoreStatus::Ok();
  });
}

StoreResult<TokenRow> PgStore::FindToken(const std::string& token_sha256_hex) {
  return Query<TokenRow>("find token", [&](pqxx::transaction_base& tx) -> StoreResult<TokenRow> {
    pqxx::result r = tx.exec_params(
        "SELECT role, institution, trainee_id, label, created_unix_ms FROM tokens "
        "WHERE token_sha256_hex = $1",
        token_sha256_hex);
    if (r.empty()) return StoreStatus::Error(StoreCode::kNotFound, "no such token");
    return TokenRowFrom(PgColumns(r[0]), token_sha256_hex);
  });
}

StoreStatus PgStore::AddTrainee(const TraineeRow& t) {
  return Transact("add trainee '" + t.trainee_id + "'", TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    pqxx::result r = tx.exec_params(
        "INSERT INTO trainees (trainee_id, institution, display_name, created_unix_ms) "
        "VALUES ($1, $2, $3, $4) ON CONFLICT (trainee_id) DO NOTHING RETURNING 1",
        t.trainee_id, t.institution, t.display_name, t.created_unix_ms);
    if (r.empty()) {
      return StoreStatus::Error(StoreCode::kAlreadyExists,
                                "trainee '" + t.trainee_id + "' already exists");
    }
    return StoreStatus::Ok();
  });
}

StoreResult<TraineeRow> PgStore::GetTrainee(const std::string& trainee_id) {
  return Query<TraineeRow>(
      "get trainee", [&](pqxx::transaction_base& tx) -> StoreResult<TraineeRow> {
        pqxx::result r = tx.exec_params(
            "SELECT institution, display_name, created_unix_ms FROM trainees WHERE trainee_id = $1",
            trainee_id);
        if (r.empty()) {
          return StoreStatus::Error(StoreCode::kNotFound, "no trainee '" + trainee_id + "'");
        }
        const PgColumns c(r[0]);
        return TraineeRow{trainee_id, c.Text(0), c.Text(1), c.Int(2)};
      });
}

StoreResult<std::vector<TraineeRow>> PgStore::ListTrainees(const std::string& institution,
                                                           const ListPage& page) {
  return Query<std::vector<TraineeRow>>("list trainees", [&](pqxx::transaction_base& tx) {
    // COLLATE "C": byte order, as SQLite sorts, whatever the cluster's locale.
    return RowsOf(
        tx.exec_params("SELECT trainee_id, institution, display_name, created_unix_ms FROM "
                       "trainees WHERE institution = $1 AND ($2 = 0 OR trainee_id COLLATE \"C\" > "
                       "$3) ORDER BY trainee_id COLLATE \"C\" LIMIT $4",
                       institution, page.has_after ? 1 : 0, page.after_text,
                       page.limit > 0 ? int64_t{page.limit} : int64_t{1} << 62),
        TraineeRowFrom<PgColumns>);
  });
}

StoreResult<std::vector<AuditRow>> PgStore::ListAudit(int64_t since_unix_ms, int limit,
                                                     int64_t after_id) {
  return Query<std::vector<AuditRow>>("list audit", [&](pqxx::transaction_base& tx) {
    return RowsOf(
        tx.exec_params("SELECT id, at_unix_ms, actor, actor_label, role, institution, action, "
                       "target, result FROM audit_log WHERE at_unix_ms >= $1 AND id > $2 "
                       "ORDER BY id LIMIT $3",
                       since_unix_ms, after_id, limit),
        AuditRowFrom<PgColumns>);
  });
}

StoreResult<std::vector<AuditRow>> PgStore::ListAuditNewest(const AuditQuery& q) {
  return Query<std::vector<AuditRow>>("list audit", [&](pqxx::transaction_base& tx) {
    // An empty or zero filter matches every row: one statement serves all.
    return RowsOf(
        tx.exec_params(
            "SELECT id, at_unix_ms, actor, actor_label, role, institution, action, target, result "
            "FROM audit_log WHERE ($1::TEXT = '' OR actor = $1 OR actor_label = $1) "
            "AND ($2::TEXT = '' OR action = $2) AND at_unix_ms >= $3::BIGINT "
            "AND ($4::BIGINT = 0 OR at_unix_ms < $4::BIGINT) AND ($5::BIGINT = 0 OR id < "
            "$5::BIGINT) ORDER BY id DESC LIMIT $6::BIGINT",
            q.actor, q.action, q.from_unix_ms, q.to_unix_ms, q.before_id,
            q.limit > 0 ? int64_t{q.limit} : int64_t{1} << 62),
        AuditRowFrom<PgColumns>);
  });
}

}  // namespace ves::patient_db
