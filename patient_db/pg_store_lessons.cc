// PgStore: curricula, groups, assignments and lesson verdicts
// (docs/lessons.md). Schema: migration 2, the same SQL as SQLite.
#include <map>
#include <optional>
#include <pqxx/pqxx>

#include "patient_db/pg_store.h"
#include "patient_db/pg_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {
namespace {

// Reads one curriculum with its lesson ids; kNotFound when absent.
StoreStatus ReadCurriculum(pqxx::transaction_base& tx, const std::string& id, CurriculumRow* out) {
  pqxx::result r = tx.exec_params(
      "SELECT curriculum_id, institution, title, created_by, created_unix_ms, body_sha256_hex, "
      "body FROM curricula WHERE curriculum_id = $1",
      id);
  if (r.empty()) return StoreStatus::Error(StoreCode::kNotFound, "no curriculum '" + id + "'");
  CurriculumRow row = CurriculumRowFrom(PgColumns(r[0]));
  for (const auto& l : tx.exec_params(
           "SELECT lesson_id FROM lessons WHERE curriculum_id = $1 ORDER BY position", id)) {
    row.lesson_ids.push_back(l[0].as<std::string>());
  }
  *out = std::move(row);
  return StoreStatus::Ok();
}

}  // namespace

StoreResult<bool> PgStore::PutCurriculum(const CurriculumRow& row) {
  const std::string name = "curriculum '" + row.curriculum_id + "'";
  bool already = false;
  StoreStatus st = Transact("put " + name, TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    already = false;
    pqxx::result inserted = tx.exec_params(
        "INSERT INTO curricula (curriculum_id, institution, title, created_by, created_unix_ms, "
        "body_sha256_hex, body) VALUES ($1, $2, $3, $4, $5, $6, $7) "
        "ON CONFLICT (curriculum_id) DO NOTHING RETURNING 1",
        row.curriculum_id, row.institution, row.title, row.created_by, row.created_unix_ms,
        row.body_sha256_hex, pqxx::binarystring(row.body));
    if (inserted.empty()) {
      CurriculumRow existing;
      StoreStatus read = ReadCurriculum(tx, row.curriculum_id, &existing);
      if (!read.ok()) return read;
      if (existing.body_sha256_hex != row.body_sha256_hex) {
        return StoreStatus::Error(StoreCode::kAlreadyExists,
                                  name + " is already stored with other content; curricula are "
                                         "immutable, give the new one another id");
      }
      already = true;
      return StoreStatus::Ok();
    }
    for (size_t i = 0; i < row.lesson_ids.size(); ++i) {
      pqxx::result lesson = tx.exec_params(
          "INSERT INTO lessons (lesson_id, curriculum_id, position) VALUES ($1, $2, $3) "
          "ON CONFLICT (lesson_id) DO NOTHING RETURNING 1",
          row.lesson_ids[i], row.curriculum_id, static_cast<int64_t>(i));
      if (lesson.empty()) {
        return StoreStatus::Error(
            StoreCode::kAlreadyExists,
            "lesson id '" + row.lesson_ids[i] + "' is already used by another curriculum");
      }
    }
    return StoreStatus::Ok();
  });
  if (st.code == StoreCode::kInvalidArgument) {
    return StoreStatus::Error(StoreCode::kInvalidArgument,
                              name + ": unknown institution '" + row.institution + "'");
  }
  if (!st.ok()) return st;
  return already;
}

StoreResult<CurriculumRow> PgStore::GetCurriculum(const std::string& curriculum_id) {
  CurriculumRow out;
  StoreStatus st = Transact("get curriculum", TxMode::kRead, [&](pqxx::transaction_base& tx) {
    return ReadCurriculum(tx, curriculum_id, &out);
  });
  if (!st.ok()) return st;
  return out;
}

StoreResult<std::vector<CurriculumRow>> PgStore::ListCurricula(const std::string& institution,
                                                               const ListPage& page) {
  return Query<std::vector<CurriculumRow>>(
      "list curricula", [&](pqxx::transaction_base& tx) -> StoreResult<std::vector<CurriculumRow>> {
        pqxx::result ids = tx.exec_params(
            "SELECT curriculum_id FROM curricula WHERE ($1 = '' OR institution = $1) "
            "AND ($2 = 0 OR curriculum_id COLLATE \"C\" > $3) "
            "ORDER BY curriculum_id COLLATE \"C\" LIMIT $4",
            institution, page.has_after ? 1 : 0, page.after_text,
            page.limit > 0 ? int64_t{page.limit} : int64_t{1} << 62);
        std::vector<CurriculumRow> out;
        for (const auto& id : ids) {
          CurriculumRow row;
          StoreStatus read = ReadCurriculum(tx, id[0].as<std::string>(), &row);
          if (!read.ok()) return read;
          out.push_back(std::move(row));
        }
        return out;
      });
}

StoreResult<std::string> PgStore::FindLessonCurriculum(const std::string& lesson_id) {
  return Query<std::string>(
      "find lesson", [&](pqxx::transaction_base& tx) -> StoreResult<std::string> {
        pqxx::result r =
            tx.exec_params("SELECT curriculum_id FROM lessons WHERE lesson_id = $1", lesson_id);
        if (r.empty())
          return StoreStatus::Error(StoreCode::kNotFound, "no lesson '" + lesson_id + "'");
        return r[0][0].as<std::string>();
      });
}

StoreStatus PgStore::SetTraineeGroup(const std::string& trainee_id, const std::string& group) {
  StoreStatus st = Transact("set trainee group", TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    if (group.empty()) {
      tx.exec_params("DELETE FROM trainee_groups WHERE trainee_id = $1", trainee_id);
    } else {
      tx.exec_params(
          "INSERT INTO trainee_groups (trainee_id, group_name) VALUES ($1, $2) "
          "ON CONFLICT (trainee_id) DO UPDATE SET group_name = excluded.group_name",
          trainee_id, group);
    }
    return StoreStatus::Ok();
  });
  if (st.code == StoreCode::kInvalidArgument) {
    return StoreStatus::Error(StoreCode::kNotFound, "no trainee '" + trainee_id + "'");
  }
  return st;
}

StoreResult<std::string> PgStore::GetTraineeGroup(const std::string& trainee_id) {
  return Query<std::string>("get trainee group", [&](pqxx::transaction_base& tx) {
    pqxx::result r = tx.exec_params(
        "SELECT group_name FROM trainee_groups WHERE trainee_id = $1", trainee_id);
    return StoreResult<std::string>(r.empty() ? std::string() : r[0][0].as<std::string>());
  });
}

StoreResult<std::vector<std::string>> PgStore::GetTraineeGroups(
    const std::vector<std::string>& trainee_ids) {
  return Query<std::vector<std::string>>("get trainee groups", [&](pqxx::transaction_base& tx) {
    std::map<std::string, std::string> group_of;
    for (const auto& r : tx.exec_params(
             "SELECT trainee_id, group_name FROM trainee_groups "
             "WHERE trainee_id IN (SELECT json_array_elements_text($1::json))",
             JsonStringArray(trainee_ids))) {
      group_of[r[0].as<std::string>()] = r[1].as<std::string>();
    }
    return InKeyOrder(trainee_ids, std::move(group_of));
  });
}

StoreResult<std::vector<std::string>> PgStore::ListGroupTrainees(const std::string& institution,
                                                                 const std::string& group) {
  return Query<std::vector<std::string>>("list group", [&](pqxx::transaction_base& tx) {
    return RowsOf(tx.exec_params(
                      "SELECT g.trainee_id FROM trainee_groups g JOIN trainees t ON t.trainee_id = "
                      "g.trainee_id WHERE t.institution = $1 AND g.group_name = $2 "
                      "ORDER BY g.trainee_id COLLATE \"C\"",
                      institution, group),
                  [](const PgColumns& c) { return c.Text(0); });
  });
}

StoreStatus PgStore::AddAssignment(const AssignmentRow& a) {
  StoreStatus st = Transact("assign curriculum", TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    tx.exec_params(
        "INSERT INTO curriculum_assignments (curriculum_id, assignee_kind, assignee, "
        "institution, assigned_by, assigned_unix_ms) VALUES ($1, $2, $3, $4, $5, $6) "
        "ON CONFLICT DO NOTHING",
        a.curriculum_id, std::string(a.to_group ? "group" : "trainee"), a.assignee,
        a.institution, a.assigned_by, a.assigned_unix_ms);
    return StoreStatus::Ok();
  });
  if (st.code == StoreCode::kInvalidArgument) {
    return StoreStatus::Error(StoreCode::kNotFound, "no curriculum '" + a.curriculum_id + "'");
  }
  return st;
}

StoreResult<std::vector<AssignmentRow>> PgStore::ListAssignments(const std::string& trainee_id) {
  return Query<std::vector<AssignmentRow>>("list assignments", [&](pqxx::transaction_base& tx) {
    return RowsOf(
        tx.exec_params("SELECT a.curriculum_id, a.assignee_kind, a.assignee, a.institution, "
                       "a.assigned_by, a.assigned_unix_ms FROM curriculum_assignments a "
                       "JOIN trainees t ON t.trainee_id = $1 "
                       "LEFT JOIN trainee_groups g ON g.trainee_id = t.trainee_id "
                       "WHERE (a.assignee_kind = 'trainee' AND a.assignee = t.trainee_id) "
                       "OR (a.assignee_kind = 'group' AND a.assignee = g.group_name "
                       "AND a.institution = t.institution) "
                       "ORDER BY a.assigned_unix_ms, a.curriculum_id COLLATE \"C\"",
                       trainee_id),
        [](const PgColumns& c) { return AssignmentRowFrom(c); });
  });
}

StoreResult<std::vector<std::vector<AssignmentRow>>> PgStore::ListAssignmentsOf(
    const std::vector<std::string>& trainee_ids) {
  return Query<std::vector<std::vector<AssignmentRow>>>(
      "list assignments of trainees", [&](pqxx::transaction_base& tx) {
        std::map<std::string, std::vector<AssignmentRow>> of;
        // ListAssignments' query for every listed trainee at once, in its order per trainee.
        for (const auto& r : tx.exec_params(
                 "SELECT t.trainee_id, a.curriculum_id, a.assignee_kind, a.assignee, "
                 "a.institution, a.assigned_by, a.assigned_unix_ms FROM trainees t "
                 "LEFT JOIN trainee_groups g ON g.trainee_id = t.trainee_id "
                 "JOIN curriculum_assignments a ON (a.assignee_kind = 'trainee' AND a.assignee = "
                 "t.trainee_id) OR (a.assignee_kind = 'group' AND a.assignee = g.group_name "
                 "AND a.institution = t.institution) "
                 "WHERE t.trainee_id IN (SELECT json_array_elements_text($1::json)) "
                 "ORDER BY a.assigned_unix_ms, a.curriculum_id COLLATE \"C\"",
                 JsonStringArray(trainee_ids))) {
          const PgColumns c(r);
          of[c.Text(0)].push_back(AssignmentRowFrom(c, 1));
        }
        return InKeyOrder(trainee_ids, std::move(of));
      });
}

StoreResult<bool> PgStore::PutLessonVerdict(const LessonVerdictRow& v) {
  return InsertOncePerSession(
      "put verdict", v.session_uuid,
      std::string("INSERT INTO lesson_verdicts (") + kVerdictColumns +
          ") VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10) "
          "ON CONFLICT (session_uuid) DO NOTHING RETURNING 1",
      v.session_uuid, v.trainee_id, v.curriculum_id, v.lesson_id, v.passed ? 1 : 0, v.score,
      v.session_start_unix_ms, v.judged_unix_ms, v.detail, v.rejected ? 1 : 0);
}

StoreResult<LessonVerdictRow> PgStore::GetLessonVerdict(const std::string& session_uuid) {
  return Query<LessonVerdictRow>(
      "get verdict", [&](pqxx::transaction_base& tx) -> StoreResult<LessonVerdictRow> {
        pqxx::result r = tx.exec_params(std::string("SELECT ") + kVerdictColumns +
                                            " FROM lesson_verdicts WHERE session_uuid = $1",
                                        session_uuid);
        if (r.empty()) {
          return StoreStatus::Error(StoreCode::kNotFound, "no verdict for '" + session_uuid + "'");
        }
        return VerdictRowFrom(PgColumns(r[0]));
      });
}

StoreResult<std::vector<LessonVerdictRow>> PgStore::ListLessonVerdicts(
    const std::string& trainee_id) {
  return Query<std::vector<LessonVerdictRow>>("list verdicts", [&](pqxx::transaction_base& tx) {
    return RowsOf(tx.exec_params(std::string("SELECT ") + kVerdictColumns +
                                     " FROM lesson_verdicts WHERE trainee_id = $1 "
                                     "ORDER BY session_start_unix_ms, session_uuid COLLATE \"C\"",
                                 trainee_id),
                  VerdictRowFrom<PgColumns>);
  });
}

StoreResult<std::vector<std::vector<LessonVerdictRow>>> PgStore::ListLessonVerdictsOf(
    const std::vector<std::string>& trainee_ids) {
  return Query<std::vector<std::vector<LessonVerdictRow>>>(
      "list verdicts of trainees", [&](pqxx::transaction_base& tx) {
        std::map<std::string, std::vector<LessonVerdictRow>> of;
        for (const auto& r :
             tx.exec_params(std::string("SELECT ") + kVerdictColumns +
                                " FROM lesson_verdicts WHERE trainee_id IN "
                                "(SELECT json_array_elements_text($1::json)) "
                                "ORDER BY session_start_unix_ms, session_uuid COLLATE \"C\"",
                            JsonStringArray(trainee_ids))) {
          LessonVerdictRow v = VerdictRowFrom(PgColumns(r));
          of[v.trainee_id].push_back(std::move(v));
        }
        return InKeyOrder(trainee_ids, std::move(of));
      });
}

StoreResult<std::vector<std::string>> PgStore::ListUnjudgedLessonSessions(
    const std::string& trainee_id, int limit) {
  return Query<std::vector<std::string>>("list unjudged", [&](pqxx::transaction_base& tx) {
    return RowsOf(
        tx.exec_params("SELECT l.session_uuid FROM lesson_sessions l JOIN sessions s ON s.uuid = "
                       "l.session_uuid LEFT JOIN lesson_verdicts v ON v.session_uuid = "
                       "l.session_uuid WHERE v.session_uuid IS NULL AND ($1 = '' OR l.trainee_id "
                       "= $1) ORDER BY s.stored_unix_ms, l.session_uuid COLLATE \"C\" LIMIT $2",
                       trainee_id, int64_t{limit}),
        [](const PgColumns& c) { return c.Text(0); });
  });
}

StoreResult<int> PgStore::AddJudgeStarts(const std::string& session_uuid, int delta) {
  std::optional<int> starts;
  StoreStatus st = Transact("add judge starts", TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    pqxx::result r = tx.exec_params(
        "UPDATE lesson_sessions SET judge_starts = judge_starts + $1 WHERE session_uuid = $2 "
        "RETURNING judge_starts",
        delta, session_uuid);
    starts.reset();
    if (!r.empty()) starts = r[0][0].as<int>();
    return StoreStatus::Ok();
  });
  if (!st.ok()) return st;
  if (!starts) {
    return StoreStatus::Error(StoreCode::kNotFound,
                              "no lesson session '" + session_uuid + "' to judge");
  }
  return *starts;
}

}  // namespace ves::patient_db
