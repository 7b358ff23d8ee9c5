#pragma once

#include <string>
#include <vector>

// The subcommands of ves-admin (admins and supervisors). Each lives in its own
// *_command.cc and returns the exit status: 0 success, 1 the operation failed
// (e.g. server refused), 2 bad arguments or invalid input.
namespace ves::admin {

using CommandArgs = std::vector<std::string>;

struct Command {
  const char* name;
  const char* summary;
  int (*run)(const CommandArgs& args);
};

const std::vector<Command>& AllCommands();

}  // namespace ves::admin
