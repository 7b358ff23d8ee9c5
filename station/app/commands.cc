#include "station/app/commands.h"

namespace ves::station {

// Subcommands join this table as their parts are built.
const std::vector<Command>& AllCommands() {
  static const std::vector<Command> kCommands = {
      {"replay", "re-run a session file's input log and recompute its metrics", RunReplayCommand},
      {"import-case", "import case bundles (*.vescase) into the offline cache", RunImportCaseCommand},
      {"export-case", "write a cached case to a bundle file", RunExportCaseCommand},
      {"status", "list cached cases, stored sessions and pending uploads", RunStatusCommand},
      {"haptic-check", "run the haptic device's free/spring experiment", RunHapticCheckCommand},
      {"sim", "run the endoscope-colon model on a case, write a CSV", RunSimCommand},
      {"snapshot", "insert the scope into a case, write the endoscope and X-ray views",
       RunSnapshotCommand},
      {"run", "run a training session on a case; commit it, upload it", RunRunCommand},
      {"sync", "upload the outbox's pending sessions", RunSyncCommand},
  };
  return kCommands;
}

}  // namespace ves::station
