#pragma once

#include <iosfwd>
#include <stdexcept>
#include <string>

#include "station/sync/case_cache.h"
#include "station/sync/station_paths.h"
#include "ves/v1/case.pb.h"

// `--case ID|FILE`, the same for every subcommand that takes a case (run,
// sim, snapshot): a path with a case file's extension is that file, anything
// else the id of a case in the station's offline cache, which holds the
// shipped cases from the first start (docs/station-run.md, "Shipped cases").
namespace ves::station {

// A case argument that is neither a case file nor a cached id: bad input
// (exit status 2). The message names what was looked for, where, and the
// ids that are there.
struct UnknownCaseError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The station's offline case cache, with every shipped case it lacks put in
// first (sync::SeedShippedCases); what was put in is said on `log`, once per
// data folder. Throws std::runtime_error when the cache cannot be written.
sync::CaseCache OpenCaseCache(const sync::StationPaths& paths, std::ostream& log);

// "case 'ARG' is neither a case file (.textproto, .vescase, .csv, .mrk.json)
// nor in the offline cache DIR; cached: a, b, c".
std::string UnknownCaseMessage(const std::string& arg, const sync::CaseCache& cache);

// The case `arg` names: the file read and validated (patient_db::CaseError
// when it is not a valid case), or the newest cached version of the id
// (UnknownCaseError when there is none).
ves::v1::ColonCase LoadCaseArgument(const std::string& arg, const sync::CaseCache& cache);
// The same, opening the cache (OpenCaseCache, notes on `log`) only for an id.
ves::v1::ColonCase LoadCaseArgument(const std::string& arg, const sync::StationPaths& paths,
                                    std::ostream& log);

}  // namespace ves::station
