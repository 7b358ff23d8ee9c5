#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "patient_db/store.h"

// Helpers for tests against the PostgreSQL cluster that deploy/with-postgres.sh
// starts (VES_TEST_POSTGRES_URL). Every test works in its own schema, so
// parallel ctest runs on one cluster never see each other's rows.
namespace ves::patient_db::pg_testing {

inline constexpr char kNoPostgresMessage[] =
    "VES_TEST_POSTGRES_URL not set: PostgreSQL backend not tested";

// VES_TEST_POSTGRES_URL, or empty when unset.
std::string TestPostgresUrl();

// A schema name unique to this process and `hint` (lower case, <= 63 bytes).
std::string UniqueSchemaName(const std::string& hint);

// `url` with every connection's search_path set to `schema` (libpq options).
std::string UrlWithSchema(const std::string& url, const std::string& schema);

// Drops `schema` if present, creates it empty and returns UrlWithSchema(base,
// schema). The schema is dropped again when the test program exits.
std::string FreshSchema(const std::string& base_url, const std::string& schema);

// The storage contract suite's factory for PostgreSQL: a store in a schema
// named after `dir` (fresh the first time a dir is seen, the same one after;
// a marker file in dir records it). When VES_TEST_POSTGRES_URL is unset it
// marks the running test skipped (kNoPostgresMessage) and returns a store that
// accepts the fixture's setup calls; the test body is then not run.
std::unique_ptr<Store> OpenPostgresTestStore(const std::filesystem::path& dir);

}  // namespace ves::patient_db::pg_testing
