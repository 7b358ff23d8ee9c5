#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <pqxx/transaction>

#include "patient_db/pg_pool.h"
#include "patient_db/store.h"

// The Store on PostgreSQL (libpqxx), for deployments with several ves-server
// replicas on one database (docs/operations.md). Same schema and migrations as
// SQLite (PgMigrations()), applied under an advisory lock so replicas starting
// together agree. Every record commits with synchronous_commit=on.
//
// Retries (Transact): a transaction is re-run from the start only when that is
// known to be safe:
//  - serialization failure / deadlock: PostgreSQL rolled it back; re-run.
//  - connection lost before COMMIT was sent: nothing was committed; re-run
//    on a fresh connection.
//  - connection lost during COMMIT (pqxx::in_doubt_error): the outcome is
//    unknown, so it is looked up with txid_status() on a new connection:
//    committed -> success (nothing re-run), aborted -> re-run, still unknown ->
//    kInternal "outcome unknown" (the caller retries; session uploads are
//    keyed by UUID, so the retry is answered as a duplicate, never stored twice).
//  - anything else (constraint violations, bad SQL): no retry.
namespace ves::patient_db {

struct PgStoreOptions {
  std::string url;          // libpq URI, e.g. postgresql://ves@db.example/ves
  size_t pool_size = 8;     // connections per store (per server process)
  int max_attempts = 5;     // per transaction, for the retryable errors above
  int in_doubt_wait_ms = 10000;  // how long to wait for an in-doubt commit's fate
};

class PgStore final : public Store {
 public:
  // Connects and migrates. Throws std::runtime_error when it cannot.
  explicit PgStore(PgStoreOptions options);
  ~PgStore() override;

  StoreStatus AddInstitution(const std::string& name, int64_t now_unix_ms) override;
  StoreResult<bool> HasInstitution(const std::string& name) override;
  StoreStatus AddToken(const TokenRow& token) override;
  StoreResult<TokenRow> FindToken(const std::string& token_sha256_hex) override;
  StoreStatus AddAccount(const AccountRow& account) override;
  StoreResult<AccountRow> GetAccount(const std::string& username) override;
  StoreResult<AccountRow> FindAccountByIdentity(const std::string& identity) override;
  StoreResult<std::vector<AccountRow>> ListAccounts(const std::string& institution) override;
  StoreStatus RevokeAccount(const std::string& username, int64_t now_unix_ms) override;
  StoreStatus SetAccountPassword(const std::string& username,
                                 const std::string& password_hash) override;
  StoreStatus AddTrainee(const TraineeRow& trainee) override;
  StoreResult<TraineeRow> GetTrainee(const std::string& trainee_id) override;
  StoreResult<std::vector<TraineeRow>> ListTrainees(const std::string& institution,
                                                    const ListPage& page = {}) override;
  StoreResult<PutCaseResult> PutCase(const CaseRow& row, const std::string& payload) override;
  StoreResult<std::vector<CaseRow>> ListCases(const CaseFilter& filter) override;
  StoreResult<CaseRow> GetCase(const std::string& case_id, uint32_t version) override;
  StoreResult<std::string> GetBlob(const std::string& sha256_hex) override;
  StoreResult<std::vector<SessionPutResult>> CommitBatch(const WriteBatch& batch) override;
  StoreResult<SessionRow> GetSession(const std::string& uuid) override;
  StoreResult<std::vector<SessionRow>> ListSessions(const std::string& trainee_id,
                                                    const std::string& case_id,
                                                    const ListPage& page = {}) override;
  StoreResult<int64_t> CountSessions() override;
  StoreResult<std::vector<std::vector<SessionRow>>> ListSessionsOf(
      const std::vector<std::string>& trainee_ids, int64_t from_unix_ms, int64_t to_unix_ms,
      int limit_each) override;
  StoreResult<std::vector<SessionRow>> ListOperatorSessions(const std::string& institution,
                                                            const std::string& case_id,
                                                            const std::string& operator_kind,
                                                            int limit) override;
  StoreResult<std::vector<TraineeActivity>> GetTraineeActivity(
      const std::vector<std::string>& trainee_ids) override;
  StoreResult<std::vector<StationRow>> ListStations(const std::string& institution,
                                                    const ListPage& page = {}) override;
  StoreResult<std::vector<AuditRow>> ListAudit(int64_t since_unix_ms, int limit,
                                               int64_t after_id = 0) override;
  StoreResult<std::vector<AuditRow>> ListAuditNewest(const AuditQuery& query) override;
  StoreResult<bool> PutCurriculum(const CurriculumRow& row) override;
  StoreResult<CurriculumRow> GetCurriculum(const std::string& curriculum_id) override;
  StoreResult<std::vector<CurriculumRow>> ListCurricula(const std::string& institution,
                                                        const ListPage& page = {}) override;
  StoreResult<std::string> FindLessonCurriculum(const std::string& lesson_id) override;
  StoreStatus SetTraineeGroup(const std::string& trainee_id, const std::string& group) override;
  StoreResult<std::string> GetTraineeGroup(const std::string& trainee_id) override;
  StoreResult<std::vector<std::string>> GetTraineeGroups(
      const std::vector<std::string>& trainee_ids) override;
  StoreResult<std::vector<std::string>> ListGroupTrainees(const std::string& institution,
                                                          const std::string& group) override;
  StoreStatus AddAssignment(const AssignmentRow& row) override;
  StoreResult<std::vector<AssignmentRow>> ListAssignments(const std::string& trainee_id) override;
  StoreResult<std::vector<std::vector<AssignmentRow>>> ListAssignmentsOf(
      const std::vector<std::string>& trainee_ids) override;
  StoreResult<bool> PutLessonVerdict(const LessonVerdictRow& row) override;
  StoreResult<LessonVerdictRow> GetLessonVerdict(const std::string& session_uuid) override;
  StoreResult<std::vector<LessonVerdictRow>> ListLessonVerdicts(
      const std::string& trainee_id) override;
  StoreResult<std::vector<std::vector<LessonVerdictRow>>> ListLessonVerdictsOf(
      const std::vector<std::string>& trainee_ids) override;
  StoreResult<std::vector<std::string>> ListUnjudgedLessonSessions(const std::string& trainee_id,
                                                                   int limit) override;
  StoreResult<int> AddJudgeStarts(const std::string& session_uuid, int delta) override;
  StoreStatus PutSessionSeries(const SessionSeriesRow& row) override;
  StoreResult<SessionSeriesRow> GetSessionSeries(const std::string& session_uuid) override;
  StoreStatus AddSessionNote(const SessionNoteRow& row) override;
  StoreResult<std::vector<SessionNoteRow>> ListSessionNotes(const std::string& session_uuid,
                                                            int limit) override;
  StoreResult<bool> SignOffSession(const SessionSignOffRow& row) override;
  StoreResult<SessionSignOffRow> GetSessionSignOff(const std::string& session_uuid) override;
  StoreResult<std::vector<SessionSignOffRow>> ListTraineeSignOffs(
      const std::string& trainee_id) override;

  int schema_version() const { return schema_version_; }

  // Counters for tests and logs.
  struct Stats {
    uint64_t retries = 0;           // transactions re-run
    uint64_t in_doubt_resolved = 0;  // in-doubt commits whose fate was looked up
  };
  Stats stats() const;

  // What Transact does with an error from a transaction that had not sent
  // COMMIT: true when re-running it is safe.
  static bool IsRetryableBeforeCommit(const std::exception& e);

 private:
  using Body = std::function<StoreStatus(pqxx::transaction_base&)>;
  enum class TxMode { kRead, kWrite };
  enum class InDoubt { kCommitted, kAborted, kUnknown };

  // Runs `body` in a transaction and commits it when it returns Ok (an error
  // status rolls back). Retries as described above.
  StoreStatus Transact(const std::string& what, TxMode mode, const Body& body);
  InDoubt ResolveInDoubt(int64_t txid);
  void Migrate();
  StoreStatus ReadShares(pqxx::transaction_base& tx, CaseRow* row);

  PgStoreOptions options_;
  PgPool pool_;
  int schema_version_ = 0;
  mutable std::mutex stats_mutex_;
  Stats stats_;  // guarded by stats_mutex_
};

}  // namespace ves::patient_db
