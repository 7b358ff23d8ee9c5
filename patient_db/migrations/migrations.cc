#include "patient_db/migrations/migrations.h"

namespace ves::patient_db {
namespace {

// One schema version: its number, what it adds, and its portable SQL.
struct MigrationText {
  int version;
  const char* description;
  const char* sql;
};

constexpr MigrationText kMigrationTexts[] = {
    {1, "institutions, tokens, trainees, cases, sessions, audit log", R"sql(
CREATE TABLE institutions (
  name TEXT PRIMARY KEY,
  created_unix_ms BIGINT NOT NULL
);
CREATE TABLE tokens (
  token_sha256_hex TEXT PRIMARY KEY,
  role TEXT NOT NULL CHECK (role IN ('admin', 'supervisor', 'station', 'trainee')),
  institution TEXT NOT NULL REFERENCES institutions(name),
  trainee_id TEXT NOT NULL,
  label TEXT NOT NULL,
  created_unix_ms BIGINT NOT NULL
);
CREATE TABLE trainees (
  trainee_id TEXT PRIMARY KEY,
  institution TEXT NOT NULL REFERENCES institutions(name),
  display_name TEXT NOT NULL,
  created_unix_ms BIGINT NOT NULL
);
CREATE INDEX trainees_by_institution ON trainees(institution, trainee_id);
CREATE TABLE case_blobs (
  sha256_hex TEXT PRIMARY KEY,
  size_bytes BIGINT NOT NULL,
  payload BLOB NOT NULL
);
CREATE TABLE cases (
  case_id TEXT NOT NULL,
  version INTEGER NOT NULL,
  title TEXT NOT NULL,
  difficulty INTEGER NOT NULL,
  region_mask BIGINT NOT NULL,
  institution TEXT NOT NULL REFERENCES institutions(name),
  sha256_hex TEXT NOT NULL REFERENCES case_blobs(sha256_hex),
  payload_sha256_hex TEXT NOT NULL,
  size_bytes BIGINT NOT NULL,
  uploaded_by TEXT NOT NULL,
  stored_unix_ms BIGINT NOT NULL,
  PRIMARY KEY (case_id, version)
);
CREATE TABLE case_shares (
  case_id TEXT NOT NULL,
  version INTEGER NOT NULL,
  institution TEXT NOT NULL,
  PRIMARY KEY (case_id, version, institution),
  FOREIGN KEY (case_id, version) REFERENCES cases(case_id, version)
);
CREATE TABLE sessions (
  uuid TEXT PRIMARY KEY,
  trainee_id TEXT NOT NULL REFERENCES trainees(trainee_id),
  institution TEXT NOT NULL,
  case_id TEXT NOT NULL,
  case_version INTEGER NOT NULL,
  station_id TEXT NOT NULL,
  start_unix_ms BIGINT NOT NULL,
  end_unix_ms BIGINT NOT NULL,
  outcome INTEGER NOT NULL,
  completed INTEGER NOT NULL,
  time_to_cecum_s DOUBLE PRECISION NOT NULL,
  pain_s DOUBLE PRECISION NOT NULL,
  score DOUBLE PRECISION NOT NULL,
  body_sha256_hex TEXT NOT NULL,
  stored_unix_ms BIGINT NOT NULL,
  body BLOB NOT NULL
);
CREATE INDEX sessions_by_trainee ON sessions(trainee_id, start_unix_ms);
CREATE TABLE audit_log (
  id BIGINT PRIMARY KEY,
  at_unix_ms BIGINT NOT NULL,
  actor TEXT NOT NULL,
  actor_label TEXT NOT NULL,
  role TEXT NOT NULL,
  institution TEXT NOT NULL,
  action TEXT NOT NULL,
  target TEXT NOT NULL,
  result TEXT NOT NULL
);
CREATE INDEX audit_by_time ON audit_log(at_unix_ms);
)sql"},
    {2, "lessons: curricula, groups, assignments, lesson sessions, verdicts", R"sql(
CREATE TABLE curricula (
  curriculum_id TEXT PRIMARY KEY,
  institution TEXT NOT NULL REFERENCES institutions(name),
  title TEXT NOT NULL,
  created_by TEXT NOT NULL,
  created_unix_ms BIGINT NOT NULL,
  body_sha256_hex TEXT NOT NULL,
  body BLOB NOT NULL
);
CREATE TABLE lessons (
  lesson_id TEXT PRIMARY KEY,
  curriculum_id TEXT NOT NULL REFERENCES curricula(curriculum_id),
  position INTEGER NOT NULL
);
CREATE TABLE trainee_groups (
  trainee_id TEXT PRIMARY KEY REFERENCES trainees(trainee_id),
  group_name TEXT NOT NULL
);
CREATE TABLE curriculum_assignments (
  curriculum_id TEXT NOT NULL REFERENCES curricula(curriculum_id),
  assignee_kind TEXT NOT NULL CHECK (assignee_kind IN ('trainee', 'group')),
  assignee TEXT NOT NULL,
  institution TEXT NOT NULL,
  assigned_by TEXT NOT NULL,
  assigned_unix_ms BIGINT NOT NULL,
  PRIMARY KEY (curriculum_id, assignee_kind, assignee, institution)
);
CREATE TABLE lesson_sessions (
  session_uuid TEXT PRIMARY KEY REFERENCES sessions(uuid),
  lesson_id TEXT NOT NULL,
  trainee_id TEXT NOT NULL
);
CREATE TABLE lesson_verdicts (
  session_uuid TEXT PRIMARY KEY REFERENCES sessions(uuid),
  trainee_id TEXT NOT NULL,
  curriculum_id TEXT NOT NULL,
  lesson_id TEXT NOT NULL,
  passed INTEGER NOT NULL,
  score DOUBLE PRECISION NOT NULL,
  session_start_unix_ms BIGINT NOT NULL,
  judged_unix_ms BIGINT NOT NULL,
  detail TEXT NOT NULL
);
CREATE INDEX lesson_verdicts_by_trainee ON lesson_verdicts(trainee_id, session_start_unix_ms);
)sql"},
    {3, "hardening: rejected lesson verdicts, judge starts", R"sql(
ALTER TABLE lesson_verdicts ADD COLUMN rejected INTEGER NOT NULL DEFAULT 0;
ALTER TABLE lesson_sessions ADD COLUMN judge_starts INTEGER NOT NULL DEFAULT 0;
)sql"},
    {4, "sessions: who operated and how deep the tip got, for listings", R"sql(
ALTER TABLE sessions ADD COLUMN operator_kind TEXT NOT NULL DEFAULT '';
ALTER TABLE sessions ADD COLUMN max_tip_arc_m DOUBLE PRECISION NOT NULL DEFAULT 0;
)sql"},
    {5, "stations: last seen, software version and health, reported with uploads", R"sql(
CREATE TABLE stations (
  institution TEXT NOT NULL REFERENCES institutions(name),
  station_id TEXT NOT NULL,
  last_seen_unix_ms BIGINT NOT NULL,
  software_version TEXT NOT NULL,
  version_session_end_unix_ms BIGINT NOT NULL,
  has_health INTEGER NOT NULL,
  health_session_uuid TEXT NOT NULL,
  health_session_end_unix_ms BIGINT NOT NULL,
  device TEXT NOT NULL,
  loop_cycles BIGINT NOT NULL,
  loop_cycle_p99_us DOUBLE PRECISION NOT NULL,
  loop_budget_us DOUBLE PRECISION NOT NULL,
  loop_overruns BIGINT NOT NULL,
  safe_state_entries BIGINT NOT NULL,
  force_pauses BIGINT NOT NULL,
  can_bus_errors BIGINT NOT NULL,
  can_lost_frames BIGINT NOT NULL,
  can_send_failures BIGINT NOT NULL,
  can_malformed_frames BIGINT NOT NULL,
  PRIMARY KEY (institution, station_id)
);
)sql"},
    {6, "session series: the web pages' plots and replay track, computed once", R"sql(
CREATE TABLE session_series (
  session_uuid TEXT PRIMARY KEY REFERENCES sessions(uuid),
  format_version INTEGER NOT NULL,
  computed_unix_ms BIGINT NOT NULL,
  series BLOB NOT NULL
);
)sql"},
    // -1: not known (stored before version 7; the record's body has it).
    {7, "sessions: loop and X-ray time for cohort listings; scripted runs by case", R"sql(
ALTER TABLE sessions ADD COLUMN loop_s DOUBLE PRECISION NOT NULL DEFAULT -1;
ALTER TABLE sessions ADD COLUMN xray_s DOUBLE PRECISION NOT NULL DEFAULT -1;
CREATE INDEX sessions_by_case_operator ON sessions(institution, case_id, operator_kind, start_unix_ms);
)sql"},
    {8, "accounts: people who sign in to the web pages (password or identity provider)", R"sql(
CREATE TABLE accounts (
  username TEXT PRIMARY KEY,
  role TEXT NOT NULL,
  institution TEXT NOT NULL REFERENCES institutions(name),
  password_hash TEXT NOT NULL,
  idp_identity TEXT NOT NULL,
  created_unix_ms BIGINT NOT NULL,
  expires_unix_ms BIGINT NOT NULL,
  revoked_unix_ms BIGINT NOT NULL
);
CREATE UNIQUE INDEX accounts_by_idp_identity ON accounts(idp_identity) WHERE idp_identity <> '';
CREATE INDEX accounts_by_institution ON accounts(institution, username);
)sql"},
    {9, "session notes and sign-offs: supervisors' workflow on the web pages", R"sql(
CREATE TABLE session_notes (
  note_id TEXT PRIMARY KEY,
  session_uuid TEXT NOT NULL REFERENCES sessions(uuid),
  author TEXT NOT NULL,
  author_label TEXT NOT NULL,
  written_unix_ms BIGINT NOT NULL,
  text TEXT NOT NULL
);
CREATE INDEX session_notes_by_session ON session_notes(session_uuid, written_unix_ms, note_id);
CREATE TABLE session_sign_offs (
  session_uuid TEXT PRIMARY KEY REFERENCES sessions(uuid),
  signed_by TEXT NOT NULL,
  signed_by_label TEXT NOT NULL,
  signed_unix_ms BIGINT NOT NULL
);
)sql"},
    // The trainee list's count and latest end per trainee read from the
    // index alone (GetTraineeActivity; 10,000 sessions: 16 ms -> 1 ms).
    {10, "sessions: each trainee's sessions by end time, for the trainee list", R"sql(
CREATE INDEX sessions_by_trainee_end ON sessions(trainee_id, end_unix_ms);
)sql"},
    // The safety monitor's counts under the names they have everywhere else
    // (docs/architecture.md, "One name per quantity").
    {11, "stations: the safety monitor's hard and transient faults", R"sql(
ALTER TABLE stations RENAME COLUMN safe_state_entries TO hard_faults;
ALTER TABLE stations RENAME COLUMN force_pauses TO transient_faults;
)sql"},
};

}  // namespace

const std::vector<Migration>& SqlMigrations() {
  static const std::vector<Migration> kMigrations = [] {
    std::vector<Migration> out;
    for (const MigrationText& m : kMigrationTexts) out.push_back({m.version, m.description, m.sql});
    return out;
  }();
  return kMigrations;
}

}  // namespace ves::patient_db
