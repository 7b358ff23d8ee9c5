#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

// The storage contract of the server (DESIGN.md §6): one interface, an
// embedded SQLite implementation and (later) PostgreSQL. Every method returns
// a StoreStatus; the gRPC handlers map it to grpc::Status. Implementations are
// safe to call from many threads. docs/server.md describes the schema.
namespace ves::patient_db {

enum class StoreCode { kOk, kNotFound, kAlreadyExists, kInvalidArgument, kInternal };

struct StoreStatus {
  StoreCode code = StoreCode::kOk;
  std::string message;

  bool ok() const { return code == StoreCode::kOk; }
  static StoreStatus Ok() { return {}; }
  static StoreStatus Error(StoreCode code, std::string message) {
    return {code, std::move(message)};
  }
};

// A value or the status saying why there is none.
template <typename T>
struct StoreResult {
  StoreStatus status;
  T value{};

  bool ok() const { return status.ok(); }
  StoreResult() = default;
  StoreResult(T v) : value(std::move(v)) {}  // NOLINT: implicit on purpose
  StoreResult(StoreStatus s) : status(std::move(s)) {}  // NOLINT
};

// Role names are stored as text ("admin", ...), see RoleName().
enum class StoreRole { kAdmin = 1, kSupervisor = 2, kStation = 3, kTrainee = 4 };
const char* RoleName(StoreRole role);
bool ParseRoleName(const std::string& name, StoreRole* role);

struct TokenRow {
  std::string token_sha256_hex;  // the token itself is never stored
  StoreRole role = StoreRole::kTrainee;
  std::string institution;
  std::string trainee_id;  // ROLE_TRAINEE only
  std::string label;
  int64_t created_unix_ms = 0;
  bool operator==(const TokenRow&) const = default;
};

// A person's account for the web pages (docs/web.md, "Accounts"): an admin
// or supervisor who signs in with a password or through the hospital's
// identity provider. Stations and scripts keep their tokens.
struct AccountRow {
  std::string username;  // 1..64 of [a-z0-9._@-]
  StoreRole role = StoreRole::kSupervisor;  // admin or supervisor
  std::string institution;
  std::string password_hash;  // scrypt, server/accounts.h; "" : no password sign-in
  std::string idp_identity;   // the IdP's `sub` or verified email mapped here; "" : none
  int64_t created_unix_ms = 0;
  int64_t expires_unix_ms = 0;  // 0: never
  int64_t revoked_unix_ms = 0;  // 0: not revoked
  bool operator==(const AccountRow&) const = default;
};

struct TraineeRow {
  std::string trainee_id;
  std::string institution;
  std::string display_name;
  int64_t created_unix_ms = 0;
  bool operator==(const TraineeRow&) const = default;
};

// One stored version of a case; the payload lives in a content-addressed blob.
struct CaseRow {
  std::string case_id;
  uint32_t version = 0;
  std::string title;
  int difficulty = 0;        // ves.v1.Difficulty
  uint64_t region_mask = 0;  // bit r set when the case has ves.v1.Region r
  std::string institution;   // owner
  std::string sha256_hex;    // of the stored bytes (the bundle): the blob's address
  std::string payload_sha256_hex;  // CasePayloadSha256Hex, as SessionRecord.case_sha256_hex
  uint64_t size_bytes = 0;
  std::string uploaded_by;   // token id
  int64_t stored_unix_ms = 0;
  std::vector<std::string> shared_with;  // sorted
  bool operator==(const CaseRow&) const = default;
};

// Where a page of a listing starts (docs/server.md, "Limits"): after the row
// whose sort key is (after_text, after_number) — the previous page's last
// row — and at most `limit` rows (0: all, for the server's own use). Which
// part of the key a listing uses is said at the listing.
struct ListPage {
  bool has_after = false;
  std::string after_text;
  int64_t after_number = 0;
  int limit = 0;
};

struct CaseFilter {
  int region = 0;             // 0: any
  int difficulty = 0;         // 0: any
  std::string institution;    // owner; empty: any
  std::string visible_to;     // owner or shared with this institution; empty: no restriction
  bool all_versions = false;  // false: the latest version of each case only
  // Key (case_id, version) with all_versions, else case_id; limit counts cases.
  ListPage page;
};

struct PutCaseResult {
  CaseRow row;
  bool already_stored = false;
};

// What a station reported of its haptic side with a session
// (ves.v1.StationHealth; docs/server.md, "Stations").
struct StationHealthRow {
  std::string device;  // "sim", "can:IFACE"
  uint64_t loop_cycles = 0;
  double loop_cycle_p99_us = 0;
  double loop_budget_us = 0;
  uint64_t loop_overruns = 0;
  uint64_t hard_faults = 0;
  uint64_t transient_faults = 0;
  uint64_t can_bus_errors = 0;
  uint64_t can_lost_frames = 0;
  uint64_t can_send_failures = 0;
  uint64_t can_malformed_frames = 0;
  bool operator==(const StationHealthRow&) const = default;
};

// A station of an institution as its uploads reported it (table stations,
// keyed by institution and station id).
struct StationRow {
  std::string institution;
  std::string station_id;
  int64_t last_seen_unix_ms = 0;  // the server's clock at the latest upload
  std::string software_version;   // of the newest session (by end_unix_ms)
  int64_t version_session_end_unix_ms = 0;
  bool has_health = false;
  StationHealthRow health;  // of the newest session that carried health
  std::string health_session_uuid;
  int64_t health_session_end_unix_ms = 0;
  bool operator==(const StationRow&) const = default;
};

// The row after a report: last seen only moves forward; the version and the
// health follow the newest session (by end_unix_ms), so an outbox delivering
// old sessions late does not overwrite what a newer one said. `report` is one
// upload's row (has_health when it carried health). Pure.
StationRow MergeStationReport(const StationRow* stored, const StationRow& report);

// The institutions of `requested` that a re-upload of `stored` adds to its
// shares (sorted, unique; neither the owner nor one already shared), and in
// *refusal why they cannot be added when `requested_owner` is not the owner
// (empty when they can, or when there are none). Pure; both stores use it.
std::vector<std::string> NewCaseShares(const CaseRow& stored, const std::string& requested_owner,
                                       const std::vector<std::string>& requested,
                                       std::string* refusal);

// "case 'ID' version N", as the stores' messages name a case version.
std::string CaseVersionName(const CaseRow& row);

// What Store::PutCase does with `row` (its payload `size_bytes` long) given
// the row already stored under its id and version (`stored`, with its shares;
// null when none): the rule of case sharing, for every store. The status is
// kAlreadyExists when `stored` has other content or when an institution
// other than the owner asks for new shares; otherwise the store writes the
// case (only when `stored` is null) and `new_shares`, and answers `result`.
struct CasePutPlan {
  StoreStatus status;
  std::vector<std::string> new_shares;  // rows to add to case_shares, sorted
  PutCaseResult result;                 // shared_with sorted, new shares included
};
CasePutPlan PlanCasePut(const CaseRow* stored, const CaseRow& row, uint64_t size_bytes);

// `ids` as a JSON array of strings: how the stores pass a list of keys to one
// query (SQLite json_each, PostgreSQL json_array_elements_text). Pure.
std::string JsonStringArray(const std::vector<std::string>& ids);

// A batched read's results, `found` by key, in the order of `keys`: a key
// with no rows gets T{}, a key listed twice the same value twice. Pure.
template <typename T>
std::vector<T> InKeyOrder(const std::vector<std::string>& keys, std::map<std::string, T> found) {
  std::vector<T> out(keys.size());
  std::map<std::string, size_t> first;  // key -> its first position in `keys`
  for (size_t i = 0; i < keys.size(); ++i) {
    auto [at, fresh] = first.emplace(keys[i], i);
    if (!fresh) {
      out[i] = out[at->second];
      continue;
    }
    auto it = found.find(keys[i]);
    if (it != found.end()) out[i] = std::move(it->second);
  }
  return out;
}

// A session record as stored: the searchable columns plus the serialized body.
struct SessionRow {
  std::string uuid;
  std::string trainee_id;
  std::string institution;
  std::string case_id;
  uint32_t case_version = 0;
  std::string station_id;
  int64_t start_unix_ms = 0;
  int64_t end_unix_ms = 0;
  int outcome = 0;  // ves.v1.Outcome
  bool completed = false;
  double time_to_cecum_s = 0;
  double pain_s = 0;
  double score = 0;
  std::string operator_kind;  // "human", "novice", "expert"; "" for rows stored before it
  double max_tip_arc_m = 0;   // the deepest tip position; 0 for rows stored before it
  // Time in a loop and with fluoroscopy on (metrics loop_s, xray_s), for the
  // cohort page; -1: not known (rows stored before they were kept).
  double loop_s = -1;
  double xray_s = -1;
  std::string body_sha256_hex;
  int64_t stored_unix_ms = 0;
  std::string body;  // serialized ves.v1.SessionRecord; empty in listings
  // Non-empty: the record names a lesson; CommitBatch queues it for judging
  // (table lesson_sessions) in the same transaction. GetSession and
  // ListSessions read it back (learning curves per lesson are built from it).
  std::string lesson_id;
  // Set: the station's report that came with this upload; CommitBatch merges
  // it into table stations in the same transaction unless the session is a
  // conflict. Not read back.
  std::optional<StationRow> station;
  bool operator==(const SessionRow&) const = default;
};

// What a trainee list shows of each trainee's sessions.
struct TraineeActivity {
  int64_t sessions = 0;
  int64_t last_end_unix_ms = 0;
  bool operator==(const TraineeActivity&) const = default;
};

struct AuditRow {
  int64_t id = 0;  // assigned by the store
  int64_t at_unix_ms = 0;
  std::string actor;  // token id
  std::string actor_label;
  std::string role;
  std::string institution;
  std::string action;
  std::string target;
  std::string result;
  bool operator==(const AuditRow&) const = default;
};

// What the audit page asks for (docs/web.md): newest first, every filter
// optional.
struct AuditQuery {
  std::string actor;         // the token id or its label, exactly; empty: anyone
  std::string action;        // exactly; empty: any
  int64_t from_unix_ms = 0;  // at_unix_ms >= from_unix_ms
  int64_t to_unix_ms = 0;    // at_unix_ms < to_unix_ms; 0: no bound
  int64_t before_id = 0;     // ids below it (the last of the previous page); 0: from the newest
  int limit = 0;             // 0: all
};

// A curriculum (docs/lessons.md): searchable columns plus the serialized
// ves.v1.Curriculum. Curricula are immutable once stored.
struct CurriculumRow {
  std::string curriculum_id;
  std::string institution;  // owner
  std::string title;
  std::vector<std::string> lesson_ids;  // in order; each unique across curricula
  std::string created_by;  // token id
  int64_t created_unix_ms = 0;
  std::string body_sha256_hex;
  std::string body;  // serialized ves.v1.Curriculum
  bool operator==(const CurriculumRow&) const = default;
};

// A curriculum given to one trainee or to a group of an institution.
struct AssignmentRow {
  std::string curriculum_id;
  bool to_group = false;
  std::string assignee;     // trainee id, or group name
  std::string institution;  // the trainee's or the group's
  std::string assigned_by;  // token id
  int64_t assigned_unix_ms = 0;
  bool operator==(const AssignmentRow&) const = default;
};

// The server's judgement of one lesson session (one per session, never changed).
struct LessonVerdictRow {
  std::string session_uuid;
  std::string trainee_id;
  std::string curriculum_id;
  std::string lesson_id;
  bool passed = false;
  double score = 0;
  int64_t session_start_unix_ms = 0;
  int64_t judged_unix_ms = 0;
  std::string detail;  // one line per criterion
  bool rejected = false;  // refused unjudged (over a budget, an impossible log): final
  bool operator==(const LessonVerdictRow&) const = default;
};

// The web pages' series of one session (docs/web.md, "Session series"): the
// plots' data and a thinned replay track as JSON text, computed once from the
// input log. A newer `format_version` replaces an older one.
struct SessionSeriesRow {
  std::string session_uuid;
  int format_version = 0;
  int64_t computed_unix_ms = 0;
  std::string json;  // at most kMaxSessionSeriesBytes
  bool operator==(const SessionSeriesRow&) const = default;
};
inline constexpr size_t kMaxSessionSeriesBytes = 2u << 20;
// Ok, or kInvalidArgument naming what is wrong (no uuid, empty, over the bound).
StoreStatus CheckSessionSeries(const SessionSeriesRow& row);

// A supervisor's note on a session (docs/web.md, "Notes and sign-off"):
// free text, kept as written, never edited.
struct SessionNoteRow {
  std::string note_id;  // chosen by the server (random hex); unique
  std::string session_uuid;
  std::string author;  // token id
  std::string author_label;
  int64_t written_unix_ms = 0;
  std::string text;  // printable UTF-8, newlines allowed, 1..kMaxSessionNoteBytes
  bool operator==(const SessionNoteRow&) const = default;
};
inline constexpr size_t kMaxSessionNoteBytes = 2000;
// Notes a session may carry: a page shows them all, so they stay few.
inline constexpr int kMaxSessionNotes = 100;
// Ok, or kInvalidArgument naming what is wrong (no id or session, empty text,
// over the bound, not printable text).
StoreStatus CheckSessionNote(const SessionNoteRow& row);

// A supervisor's sign-off of a session: once per session, never changed.
struct SessionSignOffRow {
  std::string session_uuid;
  std::string signed_by;  // token id
  std::string signed_by_label;
  int64_t signed_unix_ms = 0;
  bool operator==(const SessionSignOffRow&) const = default;
};

// What one group commit writes, in one durable transaction.
struct WriteBatch {
  std::vector<SessionRow> sessions;
  // Empty, or one audit row per session whose result the store sets from the
  // outcome: "OK", "OK duplicate" or "ALREADY_EXISTS".
  std::vector<AuditRow> session_audit;
  std::vector<AuditRow> audit;  // written as given
};

// The fate of one session of a batch.
enum class SessionPut { kStored, kDuplicate, kConflict };
struct SessionPutResult {
  SessionPut outcome = SessionPut::kStored;
  SessionRow first;  // the row stored first under this uuid (without body)
};
const char* SessionPutAuditResult(SessionPut outcome);

class Store {
 public:
  virtual ~Store() = default;

  virtual StoreStatus AddInstitution(const std::string& name, int64_t now_unix_ms) = 0;
  virtual StoreResult<bool> HasInstitution(const std::string& name) = 0;

  virtual StoreStatus AddToken(const TokenRow& token) = 0;
  virtual StoreResult<TokenRow> FindToken(const std::string& token_sha256_hex) = 0;

  // ---- Accounts (docs/web.md, "Accounts") ----
  // kAlreadyExists when the username, or a non-empty idp_identity, is taken;
  // kInvalidArgument for an unknown institution.
  virtual StoreStatus AddAccount(const AccountRow& account) = 0;
  virtual StoreResult<AccountRow> GetAccount(const std::string& username) = 0;
  // The account whose idp_identity is `identity` (kNotFound when none).
  virtual StoreResult<AccountRow> FindAccountByIdentity(const std::string& identity) = 0;
  // By username; institution empty: all.
  virtual StoreResult<std::vector<AccountRow>> ListAccounts(const std::string& institution) = 0;
  // Sets revoked_unix_ms (a second revocation keeps the first time); kNotFound.
  virtual StoreStatus RevokeAccount(const std::string& username, int64_t now_unix_ms) = 0;
  virtual StoreStatus SetAccountPassword(const std::string& username,
                                         const std::string& password_hash) = 0;

  virtual StoreStatus AddTrainee(const TraineeRow& trainee) = 0;
  virtual StoreResult<TraineeRow> GetTrainee(const std::string& trainee_id) = 0;
  // By trainee id; page key: trainee_id.
  virtual StoreResult<std::vector<TraineeRow>> ListTrainees(const std::string& institution,
                                                            const ListPage& page = {}) = 0;

  // Stores the payload under its SHA-256 (once) and the (id, version) row. The
  // same id, version and hash again: already_stored, and the row's shared_with
  // institutions are added to the stored shares (never removed) when the row
  // names the stored owner; new shares asked by another institution:
  // kAlreadyExists (only the owner shares its case). Same id and version with
  // other content: kAlreadyExists.
  virtual StoreResult<PutCaseResult> PutCase(const CaseRow& row, const std::string& payload) = 0;
  virtual StoreResult<std::vector<CaseRow>> ListCases(const CaseFilter& filter) = 0;
  // version 0: the latest.
  virtual StoreResult<CaseRow> GetCase(const std::string& case_id, uint32_t version) = 0;
  virtual StoreResult<std::string> GetBlob(const std::string& sha256_hex) = 0;

  // One durable transaction: every session (in order; a uuid already present
  // gives kDuplicate when the body hash matches, kConflict when not) and every
  // audit row. The result has one entry per session.
  virtual StoreResult<std::vector<SessionPutResult>> CommitBatch(const WriteBatch& batch) = 0;
  virtual StoreResult<SessionRow> GetSession(const std::string& uuid) = 0;  // with body
  // Oldest first, without bodies; case_id empty: all. Page key:
  // (uuid, start_unix_ms).
  virtual StoreResult<std::vector<SessionRow>> ListSessions(const std::string& trainee_id,
                                                            const std::string& case_id,
                                                            const ListPage& page = {}) = 0;
  virtual StoreResult<int64_t> CountSessions() = 0;
  // For each of `trainee_ids`, in order, the sessions started in
  // [from_unix_ms, to_unix_ms) (to 0: no upper bound), oldest first, as
  // ListSessions lists them, at most `limit_each` + 1 each (so that a caller
  // can tell there were more): one read for the whole list (the group's
  // cohort page, docs/server.md).
  virtual StoreResult<std::vector<std::vector<SessionRow>>> ListSessionsOf(
      const std::vector<std::string>& trainee_ids, int64_t from_unix_ms, int64_t to_unix_ms,
      int limit_each) = 0;
  // The institution's sessions of a case run by `operator_kind` ("expert":
  // the scripted expert), newest first, at most `limit`, without bodies or
  // lesson ids: the expert band of a learning curve (docs/web.md).
  virtual StoreResult<std::vector<SessionRow>> ListOperatorSessions(
      const std::string& institution, const std::string& case_id,
      const std::string& operator_kind, int limit) = 0;
  // The trainee's session count and latest end_unix_ms (0, 0 with none), for
  // each of `trainee_ids` in order: one query, without listing the rows.
  virtual StoreResult<std::vector<TraineeActivity>> GetTraineeActivity(
      const std::vector<std::string>& trainee_ids) = 0;

  // The institution's stations by station id. Page key: station_id.
  virtual StoreResult<std::vector<StationRow>> ListStations(const std::string& institution,
                                                            const ListPage& page = {}) = 0;

  // Oldest first, at most `limit`, ids above `after_id`.
  virtual StoreResult<std::vector<AuditRow>> ListAudit(int64_t since_unix_ms, int limit,
                                                       int64_t after_id = 0) = 0;
  // Newest first (by id), as filtered by `query`.
  virtual StoreResult<std::vector<AuditRow>> ListAuditNewest(const AuditQuery& query) = 0;

  // ---- Lessons (docs/lessons.md) ----
  // Stores the curriculum and its lesson ids. The same id and body hash again:
  // true (already stored). The same id with another body, or a lesson id used
  // by another curriculum: kAlreadyExists.
  virtual StoreResult<bool> PutCurriculum(const CurriculumRow& row) = 0;
  virtual StoreResult<CurriculumRow> GetCurriculum(const std::string& curriculum_id) = 0;
  // By id; institution empty: all. Page key: curriculum_id.
  virtual StoreResult<std::vector<CurriculumRow>> ListCurricula(const std::string& institution,
                                                                const ListPage& page = {}) = 0;
  // The curriculum holding the lesson (kNotFound when none).
  virtual StoreResult<std::string> FindLessonCurriculum(const std::string& lesson_id) = 0;
  // One group per trainee; "" removes it.
  virtual StoreStatus SetTraineeGroup(const std::string& trainee_id, const std::string& group) = 0;
  virtual StoreResult<std::string> GetTraineeGroup(const std::string& trainee_id) = 0;
  // Trainee ids of the group, sorted.
  virtual StoreResult<std::vector<std::string>> ListGroupTrainees(const std::string& institution,
                                                                  const std::string& group) = 0;
  // For each of `trainee_ids`, in order, what GetTraineeGroup gives: one read
  // for the whole list (the trainee list's page, docs/server.md).
  virtual StoreResult<std::vector<std::string>> GetTraineeGroups(
      const std::vector<std::string>& trainee_ids) = 0;
  // Idempotent: the same assignment again keeps the first row.
  virtual StoreStatus AddAssignment(const AssignmentRow& row) = 0;
  // The trainee's assignments, direct and through their group, oldest first.
  virtual StoreResult<std::vector<AssignmentRow>> ListAssignments(
      const std::string& trainee_id) = 0;
  // For each of `trainee_ids`, in order, what ListAssignments gives: one read.
  virtual StoreResult<std::vector<std::vector<AssignmentRow>>> ListAssignmentsOf(
      const std::vector<std::string>& trainee_ids) = 0;
  // false when the session already had a verdict (the first one is kept).
  virtual StoreResult<bool> PutLessonVerdict(const LessonVerdictRow& row) = 0;
  virtual StoreResult<LessonVerdictRow> GetLessonVerdict(const std::string& session_uuid) = 0;
  // The trainee's verdicts, oldest session first.
  virtual StoreResult<std::vector<LessonVerdictRow>> ListLessonVerdicts(
      const std::string& trainee_id) = 0;
  // For each of `trainee_ids`, in order, what ListLessonVerdicts gives: one read.
  virtual StoreResult<std::vector<std::vector<LessonVerdictRow>>> ListLessonVerdictsOf(
      const std::vector<std::string>& trainee_ids) = 0;
  // Lesson sessions stored without a verdict yet (oldest first, at most `limit`);
  // trainee_id empty: everyone's.
  virtual StoreResult<std::vector<std::string>> ListUnjudgedLessonSessions(
      const std::string& trainee_id, int limit) = 0;
  // Adds `delta` to the times judging of this lesson session started and
  // returns the new count (durable before it returns); kNotFound when the
  // session is not queued for judging. The judge counts a start before each
  // replay and takes it back when it stops cleanly, so what remains counts
  // replays that never finished (a crash).
  virtual StoreResult<int> AddJudgeStarts(const std::string& session_uuid, int delta) = 0;

  // ---- Session series (docs/web.md) ----
  // Stores (or replaces) the session's series; kNotFound when no such
  // session, kInvalidArgument when the JSON is empty or over
  // kMaxSessionSeriesBytes.
  virtual StoreStatus PutSessionSeries(const SessionSeriesRow& row) = 0;
  // kNotFound when none was stored.
  virtual StoreResult<SessionSeriesRow> GetSessionSeries(const std::string& session_uuid) = 0;

  // ---- Session notes and sign-offs (docs/web.md, "Notes and sign-off") ----
  // kNotFound when no such session; kInvalidArgument as CheckSessionNote;
  // kAlreadyExists when the note id is taken.
  virtual StoreStatus AddSessionNote(const SessionNoteRow& row) = 0;
  // The session's notes, oldest first (at most `limit`).
  virtual StoreResult<std::vector<SessionNoteRow>> ListSessionNotes(
      const std::string& session_uuid, int limit) = 0;
  // false when the session was already signed off (the first is kept);
  // kNotFound when no such session.
  virtual StoreResult<bool> SignOffSession(const SessionSignOffRow& row) = 0;
  // kNotFound when the session is not signed off.
  virtual StoreResult<SessionSignOffRow> GetSessionSignOff(const std::string& session_uuid) = 0;
  // The sign-offs of the trainee's sessions, in no particular order.
  virtual StoreResult<std::vector<SessionSignOffRow>> ListTraineeSignOffs(
      const std::string& trainee_id) = 0;
};

// Opens the store named by `url`: "sqlite:PATH" (created and migrated when
// needed). Throws std::invalid_argument for an unknown scheme and
// std::runtime_error when the database cannot be opened or migrated.
std::unique_ptr<Store> OpenStore(const std::string& url);

}  // namespace ves::patient_db
