#include "server/admin/commands.h"

namespace ves::admin {

// Subcommands join this table as their parts are built.
const std::vector<Command>& AllCommands() {
  static const std::vector<Command> kCommands = {
  };
  return kCommands;
}

}  // namespace ves::admin
