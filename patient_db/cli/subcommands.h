#pragma once

#include <iostream>
#include <string>
#include <string_view>
#include <vector>

// The one `main` of ves-station and ves-admin: a program of subcommands,
// picked by the first argument (DESIGN.md §1, §6). Header-only and
// dependency-free, so the station and the server share it without depending
// on each other (docs/architecture.md).
namespace ves::cli {

// A subcommand's arguments: the command line after its name.
using CommandArgs = std::vector<std::string>;

// A subcommand returns the process exit status: 0 success, 1 the work
// failed, 2 bad arguments or bad input.
struct Command {
  const char* name;
  const char* summary;
  int (*run)(const CommandArgs& args);
};

// What `--help` and `--version` say about the program.
struct Program {
  const char* name;         // "ves-station"
  const char* description;  // one line under the usage
  const char* version;
};

inline void PrintUsage(const Program& program, const std::vector<Command>& commands,
                       std::ostream& out) {
  out << "usage: " << program.name << " <command> [options]   (" << program.name
      << " <command> --help)\n\n"
      << program.description << "\n\ncommands:\n";
  for (const auto& command : commands) {
    out << "  " << command.name << std::string(16 - std::string_view(command.name).size(), ' ')
        << command.summary << "\n";
  }
}

// Runs the subcommand argv[1] with the rest of the arguments and returns its
// exit status; without one, or with an unknown one, says so and returns 2.
inline int RunProgram(const Program& program, const std::vector<Command>& commands, int argc,
                      char** argv) {
  if (argc < 2) {
    PrintUsage(program, commands, std::cerr);
    return 2;
  }
  const std::string_view name = argv[1];
  if (name == "--help" || name == "-h" || name == "help") {
    PrintUsage(program, commands, std::cout);
    return 0;
  }
  if (name == "--version") {
    std::cout << program.name << " " << program.version << "\n";
    return 0;
  }
  for (const auto& command : commands) {
    if (name == command.name) return command.run(CommandArgs(argv + 2, argv + argc));
  }
  std::cerr << program.name << ": unknown command '" << name << "' (see " << program.name
            << " --help)\n";
  return 2;
}

}  // namespace ves::cli
