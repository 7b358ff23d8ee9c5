#pragma once

#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "patient_db/sqlite_db.h"
#include "patient_db/store.h"

// Helpers of the SqliteStore's source files (sqlite_store*.cc); not for
// other code.
namespace ves::patient_db {

// kInternal naming the step and SQLite's own message.
inline StoreStatus Internal(SqliteDb& db, const std::string& what) {
  return StoreStatus::Error(StoreCode::kInternal, what + ": " + db.LastError());
}

// Runs `s` (already bound) to completion; false on error, with the code in *rc.
inline bool Run(SqliteStatement* s, int* rc) {
  *rc = SQLITE_OK;
  s->Step(rc);
  s->Reset();
  return *rc == SQLITE_OK;
}

// A constraint failure (a key taken, a reference to nothing).
inline bool IsConstraint(int rc) { return (rc & 0xff) == SQLITE_CONSTRAINT; }

// Binds `args` to the ?s of `s` in order (integers as int64_t, reals as
// double, text as anything a std::string_view takes).
template <typename... Args>
void BindAll(SqliteStatement* s, const Args&... args) {
  int i = 0;
  (s->Bind(++i, args), ...);
}

// Runs the statement `sql` (one that returns no rows) with `args` bound.
// False when it failed: *rc then holds SQLite's code (SQLITE_OK when the
// statement could not even be prepared).
template <typename... Args>
bool Execute(SqliteDb& db, const std::string& sql, int* rc, const Args&... args) {
  *rc = SQLITE_OK;
  SqliteStatement* s = db.Prepare(sql, nullptr);
  if (!s) return false;
  BindAll(s, args...);
  return Run(s, rc);
}

// Inserts a row a session has at most once (`sql` ends ON CONFLICT DO
// NOTHING): true when this one was stored, false when the session already
// had one (the first is kept); kNotFound when there is no such session.
template <typename... Args>
StoreResult<bool> InsertOncePerSession(SqliteDb& db, const std::string& what,
                                       const std::string& session_uuid, const std::string& sql,
                                       const Args&... args) {
  int rc = SQLITE_OK;
  if (Execute(db, sql, &rc, args...)) return sqlite3_changes(db.raw()) > 0;
  if (IsConstraint(rc)) {  // the foreign key
    return StoreStatus::Error(StoreCode::kNotFound, "no session '" + session_uuid + "'");
  }
  return Internal(db, what);
}

// Runs the query `sql` with `args` bound and calls `each(row)` on every row
// (an `each` that returns bool stops at false); kInternal naming `what` when
// SQLite fails.
template <typename Each, typename... Args>
StoreStatus ForEachRow(SqliteDb& db, const std::string& what, const std::string& sql, Each each,
                       const Args&... args) {
  SqliteStatement* s = db.Prepare(sql, nullptr);
  if (!s) return Internal(db, what);
  BindAll(s, args...);
  int rc = SQLITE_OK;
  while (s->Step(&rc)) {
    if constexpr (std::is_same_v<decltype(each(*s)), bool>) {
      if (!each(*s)) break;
    } else {
      each(*s);
    }
  }
  s->Reset();
  if (rc != SQLITE_OK) return Internal(db, what);
  return StoreStatus::Ok();
}

// What `read` makes of one row.
template <typename Read>
using RowOf = std::decay_t<decltype(std::declval<Read>()(std::declval<const SqliteStatement&>()))>;

// The rows of the query (as ForEachRow runs it), each as `read(row)` makes it.
template <typename Read, typename... Args>
StoreResult<std::vector<RowOf<Read>>> ReadRows(SqliteDb& db, const std::string& what,
                                               const std::string& sql, Read read,
                                               const Args&... args) {
  std::vector<RowOf<Read>> out;
  StoreStatus st = ForEachRow(
      db, what, sql, [&](const SqliteStatement& row) { out.push_back(read(row)); }, args...);
  if (!st.ok()) return st;
  return out;
}

// The first row of the query as `read(row)` makes it; kNotFound saying
// `not_found` when there is none.
template <typename Read, typename... Args>
StoreResult<RowOf<Read>> ReadFirst(SqliteDb& db, const std::string& what,
                                   const std::string& not_found, const std::string& sql, Read read,
                                   const Args&... args) {
  std::optional<RowOf<Read>> first;
  StoreStatus st = ForEachRow(
      db, what, sql,
      [&](const SqliteStatement& row) {
        first = read(row);
        return false;
      },
      args...);
  if (!st.ok()) return st;
  if (!first) return StoreStatus::Error(StoreCode::kNotFound, not_found);
  return std::move(*first);
}

}  // namespace ves::patient_db
