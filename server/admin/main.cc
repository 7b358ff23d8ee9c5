// ves-admin: the command line of admins and supervisors (DESIGN.md §6). The first
// argument picks a subcommand; `ves-admin --help` lists them.
#include "patient_db/cli/subcommands.h"
#include "server/admin/commands.h"

int main(int argc, char** argv) {
  return ves::cli::RunProgram(
      {"ves-admin", "VES administration: cases, tokens, trainees, scores, audit.", VES_VERSION},
      ves::admin::AllCommands(), argc, argv);
}
