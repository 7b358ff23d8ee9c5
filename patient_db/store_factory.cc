#include "patient_db/store_factory.h"

#include <stdexcept>

#include "patient_db/pg_store.h"

namespace ves::patient_db {

bool IsPostgresUrl(const std::string& db_url) {
  return db_url.rfind("postgresql://", 0) == 0 || db_url.rfind("postgres://", 0) == 0;
}

std::unique_ptr<Store> OpenStoreFromUrl(const std::string& db_url) {
  if (IsPostgresUrl(db_url)) {
    PgStoreOptions options;
    options.url = db_url;
    return std::make_unique<PgStore>(options);
  }
  if (db_url.rfind("sqlite:", 0) != 0) {
    throw std::invalid_argument("unknown database URL '" + db_url +
                                "' (expected sqlite:PATH or postgresql://...)");
  }
  return OpenStore(db_url);
}

}  // namespace ves::patient_db
