// ves-station: the training tower's one program (DESIGN.md §1). The first
// argument picks a subcommand; `ves-station --help` lists them.
#include "patient_db/cli/subcommands.h"
#include "station/app/commands.h"

int main(int argc, char** argv) {
  return ves::cli::RunProgram(
      {"ves-station", "VES training station: haptic loop, endoscope/colon model, views, sessions.",
       VES_VERSION},
      ves::station::AllCommands(), argc, argv);
}
