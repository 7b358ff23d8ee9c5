#pragma once

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>

#include <filesystem>

#include "patient_db/case_import.h"
#include "station/sync/case_cache.h"
#include "station/sync/outbox.h"
#include "station/sync/server_client.h"

// The station's side of a run that talks to the server: getting the case
// (server first, offline cache as the fallback) and delivering the outbox
// with bounded retries. Shared by `ves-station run` and `ves-station sync`.
namespace ves::station {

// Wall-clock time in Unix milliseconds (session start/end, acknowledgements).
int64_t NowUnixMs();

// What the station could obtain for a case id.
struct ObtainedCase {
  sync::CachedCase entry;
  ves::v1::ColonCase colon_case;  // loaded and verified from the cache
  bool from_server{false};        // downloaded (or confirmed) just now
};

// Downloads the latest version of `case_id` into the cache when `endpoint`
// is given and answers; otherwise (or when it fails) uses the newest cached
// version. Notes go to `log`. Returns nullopt when neither has the case.
// Throws patient_db::CaseError when the cached file is damaged.
std::optional<ObtainedCase> ObtainCase(const std::optional<sync::ServerEndpoint>& endpoint,
                                       const std::string& case_id, sync::CaseCache& cache,
                                       std::ostream& log);

// `--case ARG` of run and sim: a path with a case file's extension
// (.textproto, .vescase, .csv, .mrk.json: patient_db::CaseFileKindOf) is a
// case file, anything else a case id.
bool IsCaseFileArgument(const std::string& arg);

// A case file (any format patient_db::LoadCaseFile reads, with `import` for
// CSV and markups) loaded, validated and put into the offline cache, so the
// session records it like a cached case. Throws patient_db::CaseError.
ObtainedCase ObtainCaseFile(const std::filesystem::path& path, sync::CaseCache& cache,
                            const patient_db::ImportOptions& import = {});

struct DeliveryReport {
  int acknowledged{0};
  int rejected{0};
  std::size_t still_pending{0};
  std::string last_error;  // why the last pass stopped, when it did
};

// Up to `attempts` passes of DrainOutbox over gRPC, waiting CalcBackoff
// between passes that hit a transient failure. Never throws for an
// unreachable server: what was not delivered stays pending.
DeliveryReport DeliverOutbox(const sync::ServerEndpoint& endpoint, sync::Outbox& outbox,
                             int attempts);

}  // namespace ves::station
