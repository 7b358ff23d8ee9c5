#include "station/app/commands.h"

namespace ves::station {

// Subcommands join this table as their parts are built.
const std::vector<Command>& AllCommands() {
  static const std::vector<Command> kCommands = {
  };
  return kCommands;
}

}  // namespace ves::station
