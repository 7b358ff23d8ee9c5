// SqliteStore: curricula, groups, assignments and lesson verdicts
// (docs/lessons.md). Schema: migration 2.
#include <algorithm>
#include <map>
#include <optional>
#include <tuple>

#include "patient_db/sqlite_store.h"
#include "patient_db/sqlite_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {
StoreResult<CurriculumRow> SqliteStore::ReadCurriculum(SqliteDb& db, const std::string& id) {
  auto row = ReadFirst(
      db, "get curriculum", "no curriculum '" + id + "'",
      "SELECT curriculum_id, institution, title, created_by, created_unix_ms, body_sha256_hex, "
      "body FROM curricula WHERE curriculum_id = ?",
      CurriculumRowFrom<SqliteStatement>,
      id);
  if (!row.ok()) return row;
  auto lessons = ReadRows(
      db, "get curriculum lessons",
      "SELECT lesson_id FROM lessons WHERE curriculum_id = ? ORDER BY position",
      [](const SqliteStatement& s) { return s.Text(0); }, id);
  if (!lessons.ok()) return lessons.status;
  row.value.lesson_ids = std::move(lessons.value);
  return row;
}

StoreResult<bool> SqliteStore::PutCurriculum(const CurriculumRow& row) {
  std::lock_guard lock(write_mutex_);
  SqliteDb& db = *writer_;
  std::string error;
  if (!db.Exec("BEGIN IMMEDIATE", &error)) {
    return StoreStatus::Error(StoreCode::kInternal, "put curriculum: " + error);
  }
  auto fail = [&](StoreStatus status) {
    db.Exec("ROLLBACK", nullptr);
    return status;
  };
  const std::string name = "curriculum '" + row.curriculum_id + "'";
  auto existing = ReadCurriculum(db, row.curriculum_id);
  if (existing.ok()) {
    db.Exec("ROLLBACK", nullptr);
    if (existing.value.body_sha256_hex == row.body_sha256_hex) return true;
    return StoreStatus::Error(StoreCode::kAlreadyExists,
                              name + " is already stored with other content; curricula are "
                                     "immutable, give the new one another id");
  }
  if (existing.status.code != StoreCode::kNotFound) return fail(existing.status);
  SqliteStatement* s = db.Prepare(
      "INSERT INTO curricula (curriculum_id, institution, title, created_by, created_unix_ms, "
      "body_sha256_hex, body) VALUES (?, ?, ?, ?, ?, ?, ?)",
      nullptr);
  if (!s) return fail(Internal(db, "put " + name));
  s->Bind(1, row.curriculum_id).Bind(2, row.institution).Bind(3, row.title);
  s->Bind(4, row.created_by).Bind(5, row.created_unix_ms).Bind(6, row.body_sha256_hex);
  s->BindBlob(7, row.body);
  int rc = SQLITE_OK;
  if (!Run(s, &rc)) {
    if (IsConstraint(rc)) {
      return fail(StoreStatus::Error(StoreCode::kInvalidArgument,
                                     name + ": unknown institution '" + row.institution + "'"));
    }
    return fail(Internal(db, "put " + name));
  }
  for (size_t i = 0; i < row.lesson_ids.size(); ++i) {
    s = db.Prepare("INSERT INTO lessons (lesson_id, curriculum_id, position) VALUES (?, ?, ?)",
                   nullptr);
    if (!s) return fail(Internal(db, "put lesson"));
    s->Bind(1, row.lesson_ids[i]).Bind(2, row.curriculum_id).Bind(3, static_cast<int64_t>(i));
    if (!Run(s, &rc)) {
      if (IsConstraint(rc)) {
        return fail(StoreStatus::Error(
            StoreCode::kAlreadyExists,
            "lesson id '" + row.lesson_ids[i] + "' is already used by another curriculum"));
      }
      return fail(Internal(db, "put lesson"));
    }
  }
  if (!db.Exec("COMMIT", &error)) {
    return fail(StoreStatus::Error(StoreCode::kInternal, "commit " + name + ": " + error));
  }
  return false;
}

StoreResult<CurriculumRow> SqliteStore::GetCurriculum(const std::string& curriculum_id) {
  Reader r = Read();
  return ReadCurriculum(r.db(), curriculum_id);
}

StoreResult<std::vector<CurriculumRow>> SqliteStore::ListCurricula(
    const std::string& institution, const ListPage& page) {
  Reader r = Read();
  auto ids = ReadRows(
      r.db(), "list curricula",
      "SELECT curriculum_id FROM curricula WHERE (? = '' OR institution = ?) "
      "AND (? = 0 OR curriculum_id > ?) ORDER BY curriculum_id LIMIT ?",
      [](const SqliteStatement& s) { return s.Text(0); }, institution, institution,
      int64_t{page.has_after}, page.after_text, int64_t{page.limit > 0 ? page.limit : -1});
  if (!ids.ok()) return ids.status;
  std::vector<CurriculumRow> out;
  for (const std::string& id : ids.value) {
    auto row = ReadCurriculum(r.db(), id);
    if (!row.ok()) return row.status;
    out.push_back(std::move(row.value));
  }
  return out;
}

StoreResult<std::string> SqliteStore::FindLessonCurriculum(const std::string& lesson_id) {
  Reader r = Read();
  return ReadFirst(
      r.db(), "find lesson", "no lesson '" + lesson_id + "'",
      "SELECT curriculum_id FROM lessons WHERE lesson_id = ?",
      [](const SqliteStatement& s) { return s.Text(0); }, lesson_id);
}

StoreStatus SqliteStore::SetTraineeGroup(const std::string& trainee_id, const std::string& group) {
  std::lock_guard lock(write_mutex_);
  SqliteStatement* s =
      group.empty()
          ? writer_->Prepare("DELETE FROM trainee_groups WHERE trainee_id = ?", nullptr)
          : writer_->Prepare(
                "INSERT INTO trainee_groups (trainee_id, group_name) VALUES (?, ?) "
                "ON CONFLICT (trainee_id) DO UPDATE SET group_name = excluded.group_name",
                nullptr);
  if (!s) return Internal(*writer_, "set trainee group");
  s->Bind(1, trainee_id);
  if (!group.empty()) s->Bind(2, group);
  int rc = SQLITE_OK;
  if (!Run(s, &rc)) {
    if (IsConstraint(rc)) {
      return StoreStatus::Error(StoreCode::kNotFound, "no trainee '" + trainee_id + "'");
    }
    return Internal(*writer_, "set trainee group");
  }
  return StoreStatus::Ok();
}

StoreResult<std::string> SqliteStore::GetTraineeGroup(const std::string& trainee_id) {
  Reader r = Read();
  auto group = ReadRows(
      r.db(), "get trainee group", "SELECT group_name FROM trainee_groups WHERE trainee_id = ?",
      [](const SqliteStatement& s) { return s.Text(0); }, trainee_id);
  if (!group.ok()) return group.status;
  return group.value.empty() ? std::string() : group.value.front();
}

StoreResult<std::vector<std::string>> SqliteStore::GetTraineeGroups(
    const std::vector<std::string>& trainee_ids) {
  Reader r = Read();
  std::map<std::string, std::string> group_of;
  StoreStatus st = ForEachRow(
      r.db(), "get trainee groups",
      "SELECT trainee_id, group_name FROM trainee_groups "
      "WHERE trainee_id IN (SELECT value FROM json_each(?))",
      [&](const SqliteStatement& s) { group_of[s.Text(0)] = s.Text(1); },
      JsonStringArray(trainee_ids));
  if (!st.ok()) return st;
  return InKeyOrder(trainee_ids, std::move(group_of));
}

StoreResult<std::vector<std::string>> SqliteStore::ListGroupTrainees(
    const std::string& institution, const std::string& group) {
  Reader r = Read();
  return ReadRows(
      r.db(), "list group",
      "SELECT g.trainee_id FROM trainee_groups g JOIN trainees t ON t.trainee_id = g.trainee_id "
      "WHERE t.institution = ? AND g.group_name = ? ORDER BY g.trainee_id",
      [](const SqliteStatement& s) { return s.Text(0); }, institution, group);
}

StoreStatus SqliteStore::AddAssignment(const AssignmentRow& a) {
  std::lock_guard lock(write_mutex_);
  int rc = SQLITE_OK;
  if (Execute(*writer_,
              "INSERT INTO curriculum_assignments (curriculum_id, assignee_kind, assignee, "
              "institution, assigned_by, assigned_unix_ms) VALUES (?, ?, ?, ?, ?, ?) "
              "ON CONFLICT DO NOTHING",
              &rc, a.curriculum_id, a.to_group ? "group" : "trainee", a.assignee, a.institution,
              a.assigned_by, a.assigned_unix_ms)) {
    return StoreStatus::Ok();
  }
  if (IsConstraint(rc)) {
    return StoreStatus::Error(StoreCode::kNotFound, "no curriculum '" + a.curriculum_id + "'");
  }
  return Internal(*writer_, "assign curriculum");
}

StoreResult<std::vector<AssignmentRow>> SqliteStore::ListAssignments(
    const std::string& trainee_id) {
  Reader r = Read();
  return ReadRows(
      r.db(), "list assignments",
      "SELECT a.curriculum_id, a.assignee_kind, a.assignee, a.institution, a.assigned_by, "
      "a.assigned_unix_ms FROM curriculum_assignments a JOIN trainees t ON t.trainee_id = ? "
      "LEFT JOIN trainee_groups g ON g.trainee_id = t.trainee_id "
      "WHERE (a.assignee_kind = 'trainee' AND a.assignee = t.trainee_id) "
      "OR (a.assignee_kind = 'group' AND a.assignee = g.group_name "
      "AND a.institution = t.institution) "
      "ORDER BY a.assigned_unix_ms, a.curriculum_id",
      [](const SqliteStatement& s) { return AssignmentRowFrom(s); },
      trainee_id);
}

StoreResult<std::vector<std::vector<AssignmentRow>>> SqliteStore::ListAssignmentsOf(
    const std::vector<std::string>& trainee_ids) {
  Reader r = Read();
  std::map<std::string, std::vector<AssignmentRow>> of;
  // ListAssignments' query for every listed trainee at once, in its order per trainee.
  StoreStatus st = ForEachRow(
      r.db(), "list assignments of trainees",
      "SELECT t.trainee_id, a.curriculum_id, a.assignee_kind, a.assignee, a.institution, "
      "a.assigned_by, a.assigned_unix_ms FROM trainees t "
      "LEFT JOIN trainee_groups g ON g.trainee_id = t.trainee_id "
      "JOIN curriculum_assignments a ON (a.assignee_kind = 'trainee' AND a.assignee = "
      "t.trainee_id) OR (a.assignee_kind = 'group' AND a.assignee = g.group_name "
      "AND a.institution = t.institution) "
      "WHERE t.trainee_id IN (SELECT value FROM json_each(?)) "
      "ORDER BY t.trainee_id, a.assigned_unix_ms, a.curriculum_id",
      [&](const SqliteStatement& s) {
        of[s.Text(0)].push_back(AssignmentRowFrom(s, 1));
      },
      JsonStringArray(trainee_ids));
  if (!st.ok()) return st;
  return InKeyOrder(trainee_ids, std::move(of));
}

StoreResult<bool> SqliteStore::PutLessonVerdict(const LessonVerdictRow& v) {
  std::lock_guard lock(write_mutex_);
  return InsertOncePerSession(
      *writer_, "put verdict", v.session_uuid,
      std::string("INSERT INTO lesson_verdicts (") + kVerdictColumns +
          ") VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?) ON CONFLICT (session_uuid) DO NOTHING",
      v.session_uuid, v.trainee_id, v.curriculum_id, v.lesson_id, int64_t{v.passed}, v.score,
      v.session_start_unix_ms, v.judged_unix_ms, v.detail, int64_t{v.rejected});
}

StoreResult<LessonVerdictRow> SqliteStore::GetLessonVerdict(const std::string& session_uuid) {
  Reader r = Read();
  return ReadFirst(
      r.db(), "get verdict", "no verdict for '" + session_uuid + "'",
      std::string("SELECT ") + kVerdictColumns + " FROM lesson_verdicts WHERE session_uuid = ?",
      VerdictRowFrom<SqliteStatement>, session_uuid);
}

StoreResult<std::vector<LessonVerdictRow>> SqliteStore::ListLessonVerdicts(
    const std::string& trainee_id) {
  Reader r = Read();
  return ReadRows(r.db(), "list verdicts",
                  std::string("SELECT ") + kVerdictColumns +
                      " FROM lesson_verdicts WHERE trainee_id = ? ORDER BY "
                      "session_start_unix_ms, session_uuid",
                  VerdictRowFrom<SqliteStatement>, trainee_id);
}

StoreResult<std::vector<std::vector<LessonVerdictRow>>> SqliteStore::ListLessonVerdictsOf(
    const std::vector<std::string>& trainee_ids) {
  Reader r = Read();
  std::map<std::string, std::vector<LessonVerdictRow>> of;
  StoreStatus st = ForEachRow(
      r.db(), "list verdicts of trainees",
      std::string("SELECT ") + kVerdictColumns +
          " FROM lesson_verdicts WHERE trainee_id IN (SELECT value FROM json_each(?))",
      [&](const SqliteStatement& s) {
        LessonVerdictRow v = VerdictRowFrom(s);
        of[v.trainee_id].push_back(std::move(v));
      },
      JsonStringArray(trainee_ids));
  if (!st.ok()) return st;
  // ListLessonVerdicts' order, sorted here: SQLite sorting the whole page's
  // rows took ~8 times as long as reading them (2,400 verdicts: 20 ms, 2.6 ms).
  for (auto& [trainee, verdicts] : of) {
    std::sort(verdicts.begin(), verdicts.end(), [](const auto& a, const auto& b) {
      return std::tie(a.session_start_unix_ms, a.session_uuid) <
             std::tie(b.session_start_unix_ms, b.session_uuid);
    });
  }
  return InKeyOrder(trainee_ids, std::move(of));
}

StoreResult<std::vector<std::string>> SqliteStore::ListUnjudgedLessonSessions(
    const std::string& trainee_id, int limit) {
  Reader r = Read();
  return ReadRows(
      r.db(), "list unjudged",
      "SELECT l.session_uuid FROM lesson_sessions l JOIN sessions s ON s.uuid = l.session_uuid "
      "LEFT JOIN lesson_verdicts v ON v.session_uuid = l.session_uuid "
      "WHERE v.session_uuid IS NULL AND (? = '' OR l.trainee_id = ?) "
      "ORDER BY s.stored_unix_ms, l.session_uuid LIMIT ?",
      [](const SqliteStatement& s) { return s.Text(0); }, trainee_id, trainee_id, int64_t{limit});
}

StoreResult<int> SqliteStore::AddJudgeStarts(const std::string& session_uuid, int delta) {
  std::lock_guard lock(write_mutex_);
  SqliteStatement* s = writer_->Prepare(
      "UPDATE lesson_sessions SET judge_starts = judge_starts + ? WHERE session_uuid = ? "
      "RETURNING judge_starts",
      nullptr);
  if (!s) return Internal(*writer_, "add judge starts");
  s->Bind(1, int64_t{delta}).Bind(2, session_uuid);
  int rc = SQLITE_OK;
  std::optional<int> starts;
  if (s->Step(&rc)) starts = static_cast<int>(s->Int(0));
  s->Reset();
  if (rc != SQLITE_OK) return Internal(*writer_, "add judge starts");
  if (!starts) {
    return StoreStatus::Error(StoreCode::kNotFound,
                              "no lesson session '" + session_uuid + "' to judge");
  }
  return *starts;
}

}  // namespace ves::patient_db
