#pragma once

#include <cstdint>
#include <string>

#include "patient_db/store.h"

// The column lists both stores select, and the rows read back from them, for
// any result type `Columns` with Text(i), Int(i), Real(i) and Blob(i)
// (SqliteStatement; PgColumns of pg_store_internal.h). Internal to the stores.
namespace ves::patient_db {

inline constexpr const char* kCaseColumns =
    "c.case_id, c.version, c.title, c.difficulty, c.region_mask, c.institution, c.sha256_hex, "
    "c.payload_sha256_hex, c.size_bytes, c.uploaded_by, c.stored_unix_ms";

inline constexpr const char* kSessionColumns =
    "uuid, trainee_id, institution, case_id, case_version, station_id, start_unix_ms, "
    "end_unix_ms, outcome, completed, time_to_cecum_s, pain_s, score, body_sha256_hex, "
    "stored_unix_ms, operator_kind, max_tip_arc_m, loop_s, xray_s";
inline constexpr int kSessionColumnCount = 19;

// Column 19 of a session read back: the lesson the record names ('' when
// none), kept in lesson_sessions rather than in sessions.
inline constexpr const char* kSessionLessonColumn =
    ", COALESCE((SELECT l.lesson_id FROM lesson_sessions l WHERE l.session_uuid = sessions.uuid), "
    "'')";

inline constexpr const char* kStationColumns =
    "institution, station_id, last_seen_unix_ms, software_version, version_session_end_unix_ms, "
    "has_health, health_session_uuid, health_session_end_unix_ms, device, loop_cycles, "
    "loop_cycle_p99_us, loop_budget_us, loop_overruns, hard_faults, transient_faults, "
    "can_bus_errors, can_lost_frames, can_send_failures, can_malformed_frames";
inline constexpr int kStationColumnCount = 19;

template <typename Columns>
CaseRow CaseRowFrom(const Columns& c) {
  CaseRow r;
  r.case_id = c.Text(0);
  r.version = static_cast<uint32_t>(c.Int(1));
  r.title = c.Text(2);
  r.difficulty = static_cast<int>(c.Int(3));
  r.region_mask = static_cast<uint64_t>(c.Int(4));
  r.institution = c.Text(5);
  r.sha256_hex = c.Text(6);
  r.payload_sha256_hex = c.Text(7);
  r.size_bytes = static_cast<uint64_t>(c.Int(8));
  r.uploaded_by = c.Text(9);
  r.stored_unix_ms = c.Int(10);
  return r;
}

template <typename Columns>
SessionRow SessionRowFrom(const Columns& c) {
  SessionRow r;
  r.uuid = c.Text(0);
  r.trainee_id = c.Text(1);
  r.institution = c.Text(2);
  r.case_id = c.Text(3);
  r.case_version = static_cast<uint32_t>(c.Int(4));
  r.station_id = c.Text(5);
  r.start_unix_ms = c.Int(6);
  r.end_unix_ms = c.Int(7);
  r.outcome = static_cast<int>(c.Int(8));
  r.completed = c.Int(9) != 0;
  r.time_to_cecum_s = c.Real(10);
  r.pain_s = c.Real(11);
  r.score = c.Real(12);
  r.body_sha256_hex = c.Text(13);
  r.stored_unix_ms = c.Int(14);
  r.operator_kind = c.Text(15);
  r.max_tip_arc_m = c.Real(16);
  r.loop_s = c.Real(17);
  r.xray_s = c.Real(18);
  return r;
}

// A session selected with kSessionLessonColumn after kSessionColumns.
template <typename Columns>
SessionRow SessionWithLessonFrom(const Columns& c) {
  SessionRow r = SessionRowFrom(c);
  r.lesson_id = c.Text(kSessionColumnCount);
  return r;
}

template <typename Columns>
StationRow StationRowFrom(const Columns& c) {
  StationRow r;
  r.institution = c.Text(0);
  r.station_id = c.Text(1);
  r.last_seen_unix_ms = c.Int(2);
  r.software_version = c.Text(3);
  r.version_session_end_unix_ms = c.Int(4);
  r.has_health = c.Int(5) != 0;
  r.health_session_uuid = c.Text(6);
  r.health_session_end_unix_ms = c.Int(7);
  StationHealthRow& h = r.health;
  h.device = c.Text(8);
  h.loop_cycles = static_cast<uint64_t>(c.Int(9));
  h.loop_cycle_p99_us = c.Real(10);
  h.loop_budget_us = c.Real(11);
  h.loop_overruns = static_cast<uint64_t>(c.Int(12));
  h.hard_faults = static_cast<uint64_t>(c.Int(13));
  h.transient_faults = static_cast<uint64_t>(c.Int(14));
  h.can_bus_errors = static_cast<uint64_t>(c.Int(15));
  h.can_lost_frames = static_cast<uint64_t>(c.Int(16));
  h.can_send_failures = static_cast<uint64_t>(c.Int(17));
  h.can_malformed_frames = static_cast<uint64_t>(c.Int(18));
  return r;
}

// An audit row of `SELECT id, at_unix_ms, actor, actor_label, role,
// institution, action, target, result`.
template <typename Columns>
AuditRow AuditRowFrom(const Columns& c) {
  return {c.Int(0),  c.Int(1),  c.Text(2), c.Text(3), c.Text(4),
          c.Text(5), c.Text(6), c.Text(7), c.Text(8)};
}

inline constexpr const char* kAccountColumns =
    "username, role, institution, password_hash, idp_identity, created_unix_ms, "
    "expires_unix_ms, revoked_unix_ms";

inline constexpr const char* kVerdictColumns =
    "session_uuid, trainee_id, curriculum_id, lesson_id, passed, score, session_start_unix_ms, "
    "judged_unix_ms, detail, rejected";

inline constexpr const char* kNoteColumns =
    "note_id, session_uuid, author, author_label, written_unix_ms, text";

inline constexpr const char* kSignOffColumns =
    "session_uuid, signed_by, signed_by_label, signed_unix_ms";

template <typename Columns>
AccountRow AccountRowFrom(const Columns& c) {
  AccountRow r;
  r.username = c.Text(0);
  ParseRoleName(c.Text(1), &r.role);
  r.institution = c.Text(2);
  r.password_hash = c.Text(3);
  r.idp_identity = c.Text(4);
  r.created_unix_ms = c.Int(5);
  r.expires_unix_ms = c.Int(6);
  r.revoked_unix_ms = c.Int(7);
  return r;
}

template <typename Columns>
LessonVerdictRow VerdictRowFrom(const Columns& c) {
  LessonVerdictRow r;
  r.session_uuid = c.Text(0);
  r.trainee_id = c.Text(1);
  r.curriculum_id = c.Text(2);
  r.lesson_id = c.Text(3);
  r.passed = c.Int(4) != 0;
  r.score = c.Real(5);
  r.session_start_unix_ms = c.Int(6);
  r.judged_unix_ms = c.Int(7);
  r.detail = c.Text(8);
  r.rejected = c.Int(9) != 0;
  return r;
}

template <typename Columns>
SessionSignOffRow SignOffRowFrom(const Columns& c) {
  return {c.Text(0), c.Text(1), c.Text(2), c.Int(3)};
}

// A token of `SELECT role, institution, trainee_id, label, created_unix_ms`
// (the hash it was found by is the caller's).
template <typename Columns>
TokenRow TokenRowFrom(const Columns& c, const std::string& token_sha256_hex) {
  TokenRow r;
  r.token_sha256_hex = token_sha256_hex;
  ParseRoleName(c.Text(0), &r.role);
  r.institution = c.Text(1);
  r.trainee_id = c.Text(2);
  r.label = c.Text(3);
  r.created_unix_ms = c.Int(4);
  return r;
}

// A trainee of `SELECT trainee_id, institution, display_name, created_unix_ms`.
template <typename Columns>
TraineeRow TraineeRowFrom(const Columns& c) {
  return {c.Text(0), c.Text(1), c.Text(2), c.Int(3)};
}

// A curriculum of `SELECT curriculum_id, institution, title, created_by,
// created_unix_ms, body_sha256_hex, body`, without its lesson ids (table
// lessons).
template <typename Columns>
CurriculumRow CurriculumRowFrom(const Columns& c) {
  CurriculumRow r;
  r.curriculum_id = c.Text(0);
  r.institution = c.Text(1);
  r.title = c.Text(2);
  r.created_by = c.Text(3);
  r.created_unix_ms = c.Int(4);
  r.body_sha256_hex = c.Text(5);
  r.body = c.Blob(6);
  return r;
}

// An assignment of `SELECT a.curriculum_id, a.assignee_kind, a.assignee,
// a.institution, a.assigned_by, a.assigned_unix_ms` from column `first` on.
template <typename Columns>
AssignmentRow AssignmentRowFrom(const Columns& c, int first = 0) {
  return {c.Text(first),     c.Text(first + 1) == "group", c.Text(first + 2),
          c.Text(first + 3), c.Text(first + 4),            c.Int(first + 5)};
}

// A note of kNoteColumns.
template <typename Columns>
SessionNoteRow NoteRowFrom(const Columns& c) {
  return {c.Text(0), c.Text(1), c.Text(2), c.Text(3), c.Int(4), c.Text(5)};
}

// A series of `SELECT session_uuid, format_version, computed_unix_ms, series`.
template <typename Columns>
SessionSeriesRow SeriesRowFrom(const Columns& c) {
  return {c.Text(0), static_cast<int>(c.Int(1)), c.Int(2), c.Blob(3)};
}

}  // namespace ves::patient_db
