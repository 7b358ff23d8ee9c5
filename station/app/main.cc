// ves-station: the training tower's one program (DESIGN.md §1). The first
// argument picks a subcommand; `ves-station --help` lists them.
#include <iostream>
#include <string>
#include <string_view>

#include "station/app/commands.h"

namespace {

void PrintUsage(std::ostream& out) {
  out << "usage: ves-station <command> [options]   (ves-station <command> --help)\n\n"
         "VES training station: haptic loop, endoscope/colon model, views, sessions.\n\n"
         "commands:\n";
  for (const auto& command : ves::station::AllCommands()) {
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
    std::cout << "ves-station " << VES_VERSION << "\n";
    return 0;
  }
  for (const auto& command : ves::station::AllCommands()) {
    if (name == command.name) {
      return command.run(ves::station::CommandArgs(argv + 2, argv + argc));
    }
  }
  std::cerr << "ves-station: unknown command '" << name << "' (see ves-station --help)\n";
  return 2;
}
