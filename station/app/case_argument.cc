#include "station/app/case_argument.h"

#include <ostream>

#include "patient_db/case_format.h"
#include "patient_db/limits.h"
#include "station/app/run_sync.h"
#include "station/sync/shipped_cases.h"

namespace ves::station {

sync::CaseCache OpenCaseCache(const sync::StationPaths& paths, std::ostream& log) {
  sync::CaseCache cache(paths.cases());
  const std::vector<sync::CachedCase> seeded = sync::SeedShippedCases(cache);
  if (!seeded.empty()) {
    log << "shipped cases put into the offline cache " << cache.dir().string() << ":";
    for (const sync::CachedCase& entry : seeded) log << " " << entry.id << " v" << entry.version;
    log << "\n";
  }
  return cache;
}

std::string UnknownCaseMessage(const std::string& arg, const sync::CaseCache& cache) {
  std::string message = "case '" + patient_db::PrintableExcerpt(arg, 128) +
                        "' is neither a case file (.textproto, .vescase, .csv, .mrk.json) nor in "
                        "the offline cache " +
                        cache.dir().string() + "; cached:";
  std::string last_id;
  bool any = false;
  for (const sync::CachedCase& entry : cache.List()) {  // by id, then version
    if (entry.id == last_id) continue;
    message += (any ? ", " : " ") + entry.id;
    last_id = entry.id;
    any = true;
  }
  if (!any) message += " none";
  return message;
}

ves::v1::ColonCase LoadCaseArgument(const std::string& arg, const sync::CaseCache& cache) {
  if (IsCaseFileArgument(arg)) return patient_db::LoadCaseFile(arg);
  const auto entry = cache.FindLatest(arg);
  if (!entry) throw UnknownCaseError(UnknownCaseMessage(arg, cache));
  return cache.Load(entry->sha256_hex);
}

ves::v1::ColonCase LoadCaseArgument(const std::string& arg, const sync::StationPaths& paths,
                                    std::ostream& log) {
  if (IsCaseFileArgument(arg)) return patient_db::LoadCaseFile(arg);
  return LoadCaseArgument(arg, OpenCaseCache(paths, log));
}

}  // namespace ves::station
