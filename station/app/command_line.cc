#include "station/app/command_line.h"

#include <iostream>

namespace ves::station {
namespace po = boost::program_options;

std::optional<int> ParseCommandLine(std::string_view name, std::string_view usage,
                                    const CommandArgs& args, const po::options_description& options,
                                    po::variables_map* vm,
                                    const po::positional_options_description& positional) {
  try {
    po::store(po::command_line_parser(args).options(options).positional(positional).run(), *vm);
    if (vm->count("help")) {
      std::cout << usage << "\n\n" << options;
      return 0;
    }
    po::notify(*vm);
  } catch (const po::error& error) {
    std::cerr << name << ": " << error.what() << " (see --help)\n";
    return 2;
  }
  return std::nullopt;
}

}  // namespace ves::station
