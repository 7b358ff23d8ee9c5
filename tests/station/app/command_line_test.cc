// The subcommands' shared command-line reading (station/app/command_line.h).
#include "station/app/command_line.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <sstream>
#include <string>

namespace ves::station {
namespace {

namespace po = boost::program_options;

// Captures what a parse prints on stdout and stderr.
struct Captured {
  std::optional<int> stop;
  po::variables_map vm;
  std::string out;
  std::string err;
};

Captured Parse(const CommandArgs& args) {
  po::options_description options("options");
  options.add_options()("help,h", "show this help")("case", po::value<std::string>()->required(),
                                                    "case file")(
      "seconds", po::value<double>()->default_value(60.0), "time limit, s");
  po::positional_options_description positional;
  positional.add("case", 1);
  Captured c;
  std::ostringstream out, err;
  auto* old_out = std::cout.rdbuf(out.rdbuf());
  auto* old_err = std::cerr.rdbuf(err.rdbuf());
  c.stop = ParseCommandLine("ves-station demo", "usage: ves-station demo CASE", args, options,
                            &c.vm, positional);
  std::cout.rdbuf(old_out);
  std::cerr.rdbuf(old_err);
  c.out = out.str();
  c.err = err.str();
  return c;
}

TEST(CommandLine, AWellFormedLineGoesOnWithItsValues) {
  const auto c = Parse({"adult.textproto", "--seconds", "12.5"});
  EXPECT_FALSE(c.stop.has_value());
  EXPECT_EQ(c.vm["case"].as<std::string>(), "adult.textproto");
  EXPECT_DOUBLE_EQ(c.vm["seconds"].as<double>(), 12.5);
  EXPECT_EQ(c.out, "");
  EXPECT_EQ(c.err, "");
}

TEST(CommandLine, HelpPrintsUsageAndOptionsEvenWithoutTheRequiredOnes) {
  const auto c = Parse({"--help"});
  ASSERT_TRUE(c.stop.has_value());
  EXPECT_EQ(*c.stop, 0);
  EXPECT_EQ(c.out.rfind("usage: ves-station demo CASE\n\noptions:", 0), 0u) << c.out;
  EXPECT_NE(c.out.find("--seconds"), std::string::npos);
  EXPECT_EQ(c.err, "");
}

TEST(CommandLine, AMalformedLineIsOneErrorLineNamingTheCommandAndExitStatus2) {
  for (const CommandArgs& args :
       {CommandArgs{"adult.textproto", "--bogus"}, CommandArgs{"--seconds", "soon", "x"},
        CommandArgs{"--seconds", "3"}}) {
    const auto c = Parse(args);
    ASSERT_TRUE(c.stop.has_value());
    EXPECT_EQ(*c.stop, 2);
    EXPECT_EQ(c.out, "");
    EXPECT_EQ(c.err.rfind("ves-station demo: ", 0), 0u) << c.err;
    EXPECT_EQ(std::count(c.err.begin(), c.err.end(), '\n'), 1) << c.err;
    EXPECT_NE(c.err.find("(see --help)"), std::string::npos) << c.err;
  }
  EXPECT_NE(Parse({"--seconds", "3"}).err.find("'--case'"), std::string::npos);
  EXPECT_NE(Parse({"--seconds", "soon", "x"}).err.find("'soon'"), std::string::npos);
}

}  // namespace
}  // namespace ves::station
