#pragma once

#include <string>
#include <vector>

// The subcommands of ves-station. Each lives in its own <name>_command.cc,
// parses its own arguments (Boost.Program_options) and returns the process
// exit status: 0 success, 1 the work failed, 2 bad arguments or bad input.
namespace ves::station {

using CommandArgs = std::vector<std::string>;

struct Command {
  const char* name;
  const char* summary;
  int (*run)(const CommandArgs& args);
};

// Every subcommand, in the order `ves-station --help` lists them.
const std::vector<Command>& AllCommands();

}  // namespace ves::station
