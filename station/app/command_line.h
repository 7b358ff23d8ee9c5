#pragma once

#include <boost/program_options.hpp>
#include <optional>
#include <string_view>

#include "station/app/commands.h"

namespace ves::station {

// Reads a subcommand's command line into `vm`, the same way for every
// subcommand. Returns the exit status to stop with: 0 after --help (prints
// `usage`, a blank line and the options), 2 after a malformed line (prints
// "<name>: <what was wrong> (see --help)"); nothing when the command goes on.
// --help is honoured before required options are checked.
std::optional<int> ParseCommandLine(
    std::string_view name, std::string_view usage, const CommandArgs& args,
    const boost::program_options::options_description& options,
    boost::program_options::variables_map* vm,
    const boost::program_options::positional_options_description& positional = {});

}  // namespace ves::station
