#include "tests/patient_db/pg_test_util.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <functional>
#include <mutex>
#include <pqxx/pqxx>
#include <set>
#include <sstream>

#include "patient_db/pg_store.h"

namespace ves::patient_db::pg_testing {
namespace {

// Drops the schemas this program created when it exits.
class SchemaJanitor : public ::testing::Environment {
 public:
  void Add(const std::string& url, const std::string& schema) {
    std::lock_guard lock(mutex_);
    url_ = url;
    schemas_.insert(schema);
  }
  void TearDown() override {
    std::lock_guard lock(mutex_);
    if (schemas_.empty()) return;
    try {
      pqxx::connection conn(url_);
      pqxx::nontransaction q(conn);
      for (const auto& s : schemas_) q.exec("DROP SCHEMA IF EXISTS " + q.quote_name(s) + " CASCADE");
    } catch (const std::exception&) {
      // The throwaway cluster goes away anyway.
    }
  }

 private:
  std::mutex mutex_;
  std::string url_;
  std::set<std::string> schemas_;
};

SchemaJanitor* Janitor() {
  static SchemaJanitor* janitor = [] {
    auto* j = new SchemaJanitor;
    ::testing::AddGlobalTestEnvironment(j);  // gtest owns it
    return j;
  }();
  return janitor;
}

void MarkSkipped() { GTEST_SKIP() << kNoPostgresMessage; }

// Stands in after MarkSkipped(): the fixture's SetUp may still call it; the
// test body never runs.
class SkippedStore final : public Store {
 public:
  StoreStatus AddInstitution(const std::string&, int64_t) override { return {}; }
  StoreResult<bool> HasInstitution(const std::string&) override { return false; }
  StoreStatus AddToken(const TokenRow&) override { return {}; }
  StoreResult<TokenRow> FindToken(const std::string&) override { return Skipped(); }
  StoreStatus AddAccount(const AccountRow&) override { return {}; }
  StoreResult<AccountRow> GetAccount(const std::string&) override { return Skipped(); }
  StoreResult<AccountRow> FindAccountByIdentity(const std::string&) override { return Skipped(); }
  StoreResult<std::vector<AccountRow>> ListAccounts(const std::string&) override { return {}; }
  StoreStatus RevokeAccount(const std::string&, int64_t) override { return {}; }
  StoreStatus SetAccountPassword(const std::string&, const std::string&) override { return {}; }
  StoreStatus AddTrainee(const TraineeRow&) override { return {}; }
  StoreResult<TraineeRow> GetTrainee(const std::string&) override { return Skipped(); }
  StoreResult<std::vector<TraineeRow>> ListTrainees(const std::string&,
                                                    const ListPage&) override {
    return {};
  }
  StoreResult<PutCaseResult> PutCase(const CaseRow&, const std::string&) override {
    return Skipped();
  }
  StoreResult<std::vector<CaseRow>> ListCases(const CaseFilter&) override { return {}; }
  StoreResult<CaseRow> GetCase(const std::string&, uint32_t) override { return Skipped(); }
  StoreResult<std::string> GetBlob(const std::string&) override { return Skipped(); }
  StoreResult<std::vector<SessionPutResult>> CommitBatch(const WriteBatch&) override {
    return Skipped();
  }
  StoreResult<SessionRow> GetSession(const std::string&) override { return Skipped(); }
  StoreResult<std::vector<SessionRow>> ListSessions(const std::string&, const std::string&,
                                                    const ListPage&) override {
    return {};
  }
  StoreResult<int64_t> CountSessions() override { return Skipped(); }
  StoreResult<std::vector<std::vector<SessionRow>>> ListSessionsOf(const std::vector<std::string>&,
                                                                   int64_t, int64_t,
                                                                   int) override {
    return Skipped();
  }
  StoreResult<std::vector<SessionRow>> ListOperatorSessions(const std::string&, const std::string&,
                                                            const std::string&, int) override {
    return Skipped();
  }
  StoreResult<std::vector<TraineeActivity>> GetTraineeActivity(
      const std::vector<std::string>&) override {
    return Skipped();
  }
  StoreResult<std::vector<StationRow>> ListStations(const std::string&, const ListPage&) override {
    return {};
  }
  StoreResult<std::vector<AuditRow>> ListAudit(int64_t, int, int64_t) override { return {}; }
  StoreResult<std::vector<AuditRow>> ListAuditNewest(const AuditQuery&) override { return {}; }
  StoreResult<bool> PutCurriculum(const CurriculumRow&) override { return Skipped(); }
  StoreResult<CurriculumRow> GetCurriculum(const std::string&) override { return Skipped(); }
  StoreResult<std::vector<CurriculumRow>> ListCurricula(const std::string&,
                                                        const ListPage&) override {
    return {};
  }
  StoreResult<std::string> FindLessonCurriculum(const std::string&) override { return Skipped(); }
  StoreStatus SetTraineeGroup(const std::string&, const std::string&) override { return {}; }
  StoreResult<std::string> GetTraineeGroup(const std::string&) override { return Skipped(); }
  StoreResult<std::vector<std::string>> GetTraineeGroups(
      const std::vector<std::string>&) override {
    return Skipped();
  }
  StoreResult<std::vector<std::vector<AssignmentRow>>> ListAssignmentsOf(
      const std::vector<std::string>&) override {
    return Skipped();
  }
  StoreResult<std::vector<std::vector<LessonVerdictRow>>> ListLessonVerdictsOf(
      const std::vector<std::string>&) override {
    return Skipped();
  }
  StoreResult<std::vector<std::string>> ListGroupTrainees(const std::string&,
                                                          const std::string&) override {
    return {};
  }
  StoreStatus AddAssignment(const AssignmentRow&) override { return {}; }
  StoreResult<std::vector<AssignmentRow>> ListAssignments(const std::string&) override {
    return {};
  }
  StoreResult<bool> PutLessonVerdict(const LessonVerdictRow&) override { return Skipped(); }
  StoreResult<LessonVerdictRow> GetLessonVerdict(const std::string&) override {
    return Skipped();
  }
  StoreResult<std::vector<LessonVerdictRow>> ListLessonVerdicts(const std::string&) override {
    return {};
  }
  StoreResult<std::vector<std::string>> ListUnjudgedLessonSessions(const std::string&,
                                                                   int) override {
    return {};
  }
  StoreResult<int> AddJudgeStarts(const std::string&, int) override { return {}; }
  StoreStatus PutSessionSeries(const SessionSeriesRow&) override { return Skipped(); }
  StoreResult<SessionSeriesRow> GetSessionSeries(const std::string&) override { return Skipped(); }
  StoreStatus AddSessionNote(const SessionNoteRow&) override { return Skipped(); }
  StoreResult<std::vector<SessionNoteRow>> ListSessionNotes(const std::string&, int) override {
    return {};
  }
  StoreResult<bool> SignOffSession(const SessionSignOffRow&) override { return Skipped(); }
  StoreResult<SessionSignOffRow> GetSessionSignOff(const std::string&) override {
    return Skipped();
  }
  StoreResult<std::vector<SessionSignOffRow>> ListTraineeSignOffs(const std::string&) override {
    return {};
  }

 private:
  static StoreStatus Skipped() {
    return StoreStatus::Error(StoreCode::kInternal, kNoPostgresMessage);
  }
};

}  // namespace

std::string TestPostgresUrl() {
  const char* url = std::getenv("VES_TEST_POSTGRES_URL");
  return url ? url : "";
}

std::string UniqueSchemaName(const std::string& hint) {
  std::ostringstream name;
  name << "vt_" << ::getpid() << "_" << std::hex << std::hash<std::string>{}(hint);
  return name.str();
}

std::string UrlWithSchema(const std::string& url, const std::string& schema) {
  // %3D is '=': libpq passes "-c search_path=SCHEMA" to the server.
  return url + (url.find('?') == std::string::npos ? "?" : "&") +
         "options=-csearch_path%3D" + schema;
}

std::string FreshSchema(const std::string& base_url, const std::string& schema) {
  pqxx::connection conn(base_url);
  pqxx::nontransaction q(conn);
  q.exec("DROP SCHEMA IF EXISTS " + q.quote_name(schema) + " CASCADE");
  q.exec("CREATE SCHEMA " + q.quote_name(schema));
  Janitor()->Add(base_url, schema);
  return UrlWithSchema(base_url, schema);
}

std::unique_ptr<Store> OpenPostgresTestStore(const std::filesystem::path& dir) {
  const std::string base = TestPostgresUrl();
  if (base.empty()) {
    MarkSkipped();
    return std::make_unique<SkippedStore>();
  }
  const std::string schema = UniqueSchemaName(dir.string());
  const auto marker = dir / "postgres-schema";
  std::string url;
  if (std::filesystem::exists(marker)) {
    url = UrlWithSchema(base, schema);  // a reopen: the same schema, rows kept
  } else {
    url = FreshSchema(base, schema);
    std::ofstream(marker) << schema << "\n";
  }
  PgStoreOptions options;
  options.url = url;
  options.pool_size = 4;
  return std::make_unique<PgStore>(options);
}

}  // namespace ves::patient_db::pg_testing
