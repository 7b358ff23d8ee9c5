#pragma once

#include <string>
#include <vector>

// Versioned schema migrations (docs/server.md, "Schema"). Applied in order on
// start; each runs once, in a transaction, and is recorded in
// schema_migrations. Never edit a released migration: append a new one.
namespace ves::patient_db {

struct Migration {
  int version = 0;
  std::string description;
  std::string sql;  // portable SQL; the PostgreSQL store maps BLOB to BYTEA
};

const std::vector<Migration>& SqlMigrations();

}  // namespace ves::patient_db
