// ves_fuzz_seeds TARGET DIR: writes the target's seeds (SeedsFor) into DIR as
// the fuzzer's starting corpus (deploy/fuzz.sh).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "tests/fuzz/fuzz_targets.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: ves_fuzz_seeds TARGET DIR\n");
    return 2;
  }
  const auto seeds = ves::fuzz::SeedsFor(argv[1]);
  if (seeds.empty()) {
    std::fprintf(stderr, "ves_fuzz_seeds: no target '%s'\n", argv[1]);
    return 2;
  }
  std::filesystem::create_directories(argv[2]);
  for (size_t i = 0; i < seeds.size(); ++i) {
    std::ofstream(std::filesystem::path(argv[2]) / ("seed-" + std::to_string(i)),
                  std::ios::binary)
        << seeds[i];
  }
  return 0;
}
