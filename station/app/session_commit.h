#pragma once

#include <string>
#include <vector>

#include "station/app/run_options.h"
#include "station/sync/station_paths.h"
#include "ves/v1/session.pb.h"

// A run's records into the outbox, then to the server (docs/station-run.md,
// "Outbox, then upload"): committed first, so a record is on disk before any
// upload is tried.
namespace ves::station {

// Commits one record to the outbox; false (said on stderr) when that failed.
bool CommitRecord(const sync::StationPaths& paths, const ves::v1::SessionRecord& record);

// With a server, tries to deliver the outbox (every pending record, oldest
// first) and says what became of `uuids`, the sessions this run committed.
// Returns false when the outbox could not be opened.
bool DeliverCommitted(const RunOptions& o, const sync::StationPaths& paths,
                      const std::vector<std::string>& uuids);

// Commits the records, then (with a server) tries to deliver the outbox.
// Returns false when a commit itself failed.
bool CommitAndDeliver(const RunOptions& o, const sync::StationPaths& paths,
                      const std::vector<ves::v1::SessionRecord>& records);

// For the crash tests: with VES_STATION_KILL_AFTER_COMMIT set, the process
// SIGKILLs itself here, right after the outbox commit and before any upload
// (docs/station-run.md, "Crash test hook").
void KillAfterCommitIfAsked();

}  // namespace ves::station
