// Every fuzz target over its seeds (the project's own data) and over every
// input a fuzzer ever crashed it with (tests/fuzz/regressions/<target>/):
// each crash stays fixed, in every build, with or without clang.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "tests/fuzz/fuzz_targets.h"

namespace ves::fuzz {
namespace {

std::string ReadAll(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

int RunTarget(const FuzzTarget& target, const std::string& input) {
  return target.run(reinterpret_cast<const std::uint8_t*>(input.data()), input.size());
}

class FuzzRegression : public ::testing::TestWithParam<FuzzTarget> {};

TEST_P(FuzzRegression, SeedsPassAndEverySavedCrashStaysFixed) {
  const FuzzTarget& target = GetParam();
  const auto seeds = SeedsFor(target.name);
  EXPECT_FALSE(seeds.empty());
  for (const std::string& seed : seeds) EXPECT_EQ(RunTarget(target, seed), 0);
  const std::filesystem::path dir =
      std::filesystem::path(VES_SOURCE_DIR) / "tests/fuzz/regressions" / target.name;
  int crashes = 0;
  if (std::filesystem::is_directory(dir)) {
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
      SCOPED_TRACE(entry.path().string());
      EXPECT_EQ(RunTarget(target, ReadAll(entry.path())), 0);
      ++crashes;
    }
  }
  RecordProperty("saved_crashes", crashes);
}

INSTANTIATE_TEST_SUITE_P(AllTargets, FuzzRegression, ::testing::ValuesIn(AllFuzzTargets()),
                         [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace ves::fuzz
