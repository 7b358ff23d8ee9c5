#pragma once

#include <vector>

#include "patient_db/migrations/migrations.h"

// The PostgreSQL form of the versioned migrations: the same versions, in the
// same order, as SqlMigrations() (one source of truth for the schema), with
// the types mapped (BLOB -> BYTEA) and, per version, what PostgreSQL needs on
// top: the audit log takes its ids from a sequence so several server replicas
// can append without an in-process counter.
namespace ves::patient_db {

const std::vector<Migration>& PgMigrations();

}  // namespace ves::patient_db
