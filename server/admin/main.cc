// ves-admin: the command line of admins and supervisors (DESIGN.md §6). The first
// argument picks a subcommand; `ves-admin --help` lists them.
#include <iostream>
#include <string>
#include <string_view>

#include "server/admin/commands.h"

namespace {

void PrintUsage(std::ostream& out) {
  out << "usage: ves-admin <command> [options]   (ves-admin <command> --help)\n\n"
         "VES administration: cases, tokens, trainees, scores, audit.\n\n"
         "commands:\n";
  for (const auto& command : ves::admin::AllCommands()) {
    out << "  " << command.name << std::string(16 - std::string_view(command.name).size(), ' ')
        << command.summary << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    PrintUsage(std::cerr);
    return 2;
  }
  const std::string_view name = argv[1];
  if (name == "--help" || name == "-h" || name == "help") {
    PrintUsage(std::cout);
    return 0;
  }
  if (name == "--version") {
    std::cout << "ves-admin " << VES_VERSION << "\n";
    return 0;
  }
  for (const auto& command : ves::admin::AllCommands()) {
    if (name == command.name) {
      return command.run(ves::admin::CommandArgs(argv + 2, argv + argc));
    }
  }
  std::cerr << "ves-admin: unknown command '" << name << "' (see ves-admin --help)\n";
  return 2;
}
