#include "patient_db/migrations/postgres/pg_migrations.h"

#include <map>
#include <regex>
#include <string>

namespace ves::patient_db {
namespace {

// Statements PostgreSQL runs after the portable SQL of a version.
const std::map<int, std::string>& PgExtras() {
  static const std::map<int, std::string> kExtras = {
      {1, R"sql(
CREATE SEQUENCE audit_log_id_seq OWNED BY audit_log.id;
ALTER TABLE audit_log ALTER COLUMN id SET DEFAULT nextval('audit_log_id_seq');
)sql"},
  };
  return kExtras;
}

std::string ToPostgres(const std::string& sql) {
  // SQLite's BLOB is PostgreSQL's BYTEA; every other type in the portable SQL
  // (TEXT, INTEGER, BIGINT, DOUBLE PRECISION) means the same in both.
  static const std::regex kBlob("\\bBLOB\\b");
  return std::regex_replace(sql, kBlob, "BYTEA");
}

}  // namespace

const std::vector<Migration>& PgMigrations() {
  static const std::vector<Migration> kMigrations = [] {
    std::vector<Migration> out;
    for (const Migration& m : SqlMigrations()) {
      Migration pg = m;
      pg.sql = ToPostgres(m.sql);
      auto extra = PgExtras().find(m.version);
      if (extra != PgExtras().end()) pg.sql += extra->second;
      out.push_back(std::move(pg));
    }
    return out;
  }();
  return kMigrations;
}

}  // namespace ves::patient_db
