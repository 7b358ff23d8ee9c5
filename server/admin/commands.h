#pragma once

#include <vector>

#include "patient_db/cli/subcommands.h"

// The subcommands of ves-admin (admins and supervisors). Each lives in its own
// *_command.cc and returns the exit status: 0 success, 1 the operation failed
// (e.g. server refused), 2 bad arguments or invalid input.
namespace ves::admin {

using CommandArgs = cli::CommandArgs;
using Command = cli::Command;

const std::vector<Command>& AllCommands();

// case_command.cc: validate, convert and inspect colon case files.
int RunCaseCommand(const CommandArgs& args);

// Server work: init_command.cc, remote_commands.cc, case_remote.cc (docs/server.md).
int RunInitCommand(const CommandArgs& args);
// Accounts of people (docs/web.md, "Accounts"): account_command.cc.
int RunAccountCommand(const CommandArgs& args);
int RunTokenCommand(const CommandArgs& args);
int RunTraineeCommand(const CommandArgs& args);
int RunScoresCommand(const CommandArgs& args);
int RunSessionCommand(const CommandArgs& args);
int RunAuditCommand(const CommandArgs& args);
int RunStationsCommand(const CommandArgs& args);
int RunCaseUpload(const CommandArgs& args);
int RunCaseList(const CommandArgs& args);
int RunCaseDownload(const CommandArgs& args);

// Lessons (docs/lessons.md): lessons_command.cc.
int RunCurriculumCommand(const CommandArgs& args);
int RunAssignCommand(const CommandArgs& args);
int RunProgressCommand(const CommandArgs& args);
int RunGroupCommand(const CommandArgs& args);

}  // namespace ves::admin
