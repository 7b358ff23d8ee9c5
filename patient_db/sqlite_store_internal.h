#pragma once

#include <string>

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

}  // namespace ves::patient_db
