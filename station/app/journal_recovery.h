#pragma once

#include "station/sync/station_paths.h"

// The sessions a station process left unfinished (docs/station-run.md,
// "Journal", "Recovery"): `ves-station run` and `ves-station sync` call this
// first, so that what an interrupted run journaled reaches the outbox.
namespace ves::station {

// Each journal in DATA/journal/ that no running station holds is re-run into
// an aborted session's record and committed to the outbox, then deleted (one
// whose record is already in the outbox is deleted at once). One that cannot
// be recovered is moved to journal/unreadable/ with the reason said, never
// deleted. When the outbox cannot be opened the journals stay for the next
// run. Never throws.
void RecoverInterruptedSessions(const sync::StationPaths& paths);

}  // namespace ves::station
