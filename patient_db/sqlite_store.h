#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "patient_db/sqlite_db.h"
#include "patient_db/store.h"

// The embedded Store: one SQLite file in WAL mode, synchronous=FULL, foreign
// keys on. Writes go through one connection under a mutex (SQLite has one
// writer anyway); reads take a connection from a small pool so they run beside
// a commit. Migrations are applied when it opens.
namespace ves::patient_db {

class SqliteStore final : public Store {
 public:
  // Throws std::runtime_error when the file cannot be opened or migrated.
  explicit SqliteStore(const std::string& path);
  ~SqliteStore() override;

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

  // The schema version after migration.
  int schema_version() const { return schema_version_; }

 private:
  // A pooled read connection, returned on destruction.
  class Reader;
  Reader Read();
  void Migrate();
  StoreStatus WriteSession(const SessionRow& row, SessionPutResult* result);
  StoreStatus WriteAudit(const AuditRow& row);
  StoreStatus WriteStation(const StationRow& report);
  StoreResult<CurriculumRow> ReadCurriculum(SqliteDb& db, const std::string& curriculum_id);
  StoreResult<std::vector<std::string>> ReadShares(SqliteDb& db, const std::string& case_id,
                                                   uint32_t version);

  std::string path_;
  std::mutex write_mutex_;
  std::unique_ptr<SqliteDb> writer_;  // guarded by write_mutex_
  int64_t next_audit_id_ = 1;         // guarded by write_mutex_
  std::mutex pool_mutex_;
  std::vector<std::unique_ptr<SqliteDb>> readers_;  // idle; guarded by pool_mutex_
  int schema_version_ = 0;
};

// A pooled read connection, handed back to the pool when it goes out of scope.
class SqliteStore::Reader {
 public:
  Reader(SqliteStore* store, std::unique_ptr<SqliteDb> db) : store_(store), db_(std::move(db)) {}
  ~Reader() {
    std::lock_guard lock(store_->pool_mutex_);
    store_->readers_.push_back(std::move(db_));
  }
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;
  SqliteDb& db() { return *db_; }

 private:
  SqliteStore* store_;
  std::unique_ptr<SqliteDb> db_;
};

}  // namespace ves::patient_db
