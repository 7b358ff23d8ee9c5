#include "station/sync/shipped_cases.h"

#include <set>
#include <string>

#include "patient_db/case_textproto.h"

namespace ves::sync {

std::vector<CachedCase> SeedShippedCases(CaseCache& cache) {
  std::set<std::string> cached_ids;
  for (const CachedCase& entry : cache.List()) cached_ids.insert(entry.id);
  std::vector<CachedCase> seeded;
  for (const ShippedCaseText& shipped : ShippedCaseTexts()) {
    // The files are the tested ones of patient_db/cases: they parse and validate.
    const ves::v1::ColonCase colon_case =
        patient_db::ParseCaseTextproto(shipped.textproto, shipped.file_name);
    if (cached_ids.count(colon_case.id()) > 0) continue;
    seeded.push_back(cache.Put(colon_case));
    cached_ids.insert(colon_case.id());
  }
  return seeded;
}

}  // namespace ves::sync
