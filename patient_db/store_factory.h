#pragma once

#include <memory>
#include <string>

#include "patient_db/store.h"

// Opens a Store by URL, every backend the build has:
//   sqlite:PATH                      the embedded store (as OpenStore in store.h)
//   postgresql://... or postgres://  PgStore on that libpq URI, e.g.
//     postgresql://ves@db.example:5432/ves?sslmode=verify-full
//     (append &options=-csearch_path%3DNAME to use a schema other than public)
// Throws std::invalid_argument for an unknown scheme and std::runtime_error
// when the database cannot be opened or migrated.
namespace ves::patient_db {

std::unique_ptr<Store> OpenStoreFromUrl(const std::string& db_url);

bool IsPostgresUrl(const std::string& db_url);

}  // namespace ves::patient_db
