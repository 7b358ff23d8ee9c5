#include "server/admin/commands.h"

namespace ves::admin {

// Subcommands join this table as their parts are built.
const std::vector<Command>& AllCommands() {
  static const std::vector<Command> kCommands = {
      {"case", "colon case files: validate, convert, info", RunCaseCommand},
      {"init", "create the database, print the first admin token", RunInitCommand},
      {"token", "create a bearer token (admin)", RunTokenCommand},
      {"account", "people's sign-in accounts: create, revoke, password, list", RunAccountCommand},
      {"trainee", "add or list trainees", RunTraineeCommand},
      {"scores", "a trainee's sessions and scores", RunScoresCommand},
      {"session", "show one session whole", RunSessionCommand},
      {"audit", "read the audit log (admin)", RunAuditCommand},
      {"stations", "stations: last seen, version, health (admin, supervisor)", RunStationsCommand},
      {"curriculum", "create or list curricula of lessons", RunCurriculumCommand},
      {"assign", "assign a curriculum to a trainee or a group", RunAssignCommand},
      {"progress", "a trainee's or a group's lesson progress", RunProgressCommand},
      {"group", "put a trainee in a group", RunGroupCommand},
  };
  return kCommands;
}

}  // namespace ves::admin
