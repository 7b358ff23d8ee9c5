#pragma once

#include <vector>

#include "patient_db/cli/subcommands.h"

// The subcommands of ves-station. Each lives in its own <name>_command.cc,
// parses its own arguments (Boost.Program_options) and returns the process
// exit status: 0 success, 1 the work failed, 2 bad arguments or bad input.
namespace ves::station {

using CommandArgs = cli::CommandArgs;
using Command = cli::Command;

// Every subcommand, in the order `ves-station --help` lists them.
const std::vector<Command>& AllCommands();

// offline_commands.cc: the case library and the outbox.
int RunImportCaseCommand(const CommandArgs& args);
int RunExportCaseCommand(const CommandArgs& args);
int RunStatusCommand(const CommandArgs& args);

// haptic_check_command.cc: the VES-IV free/spring experiments (paper Fig. 5/6).
int RunHapticCheckCommand(const CommandArgs& args);

// replay_command.cc: re-run a session file's input log and re-score it.
int RunReplayCommand(const CommandArgs& args);

// sim_command.cc: the endoscope-colon model from the command line.
int RunSimCommand(const CommandArgs& args);

// snapshot_command.cc: the views of paper §4 as PNG files for a case and insertion.
int RunSnapshotCommand(const CommandArgs& args);

// run_command.cc: a training session end to end (case, run, outbox, upload).
int RunRunCommand(const CommandArgs& args);
// sync_command.cc: journal recovery, then the outbox to the server.
int RunSyncCommand(const CommandArgs& args);

}  // namespace ves::station
