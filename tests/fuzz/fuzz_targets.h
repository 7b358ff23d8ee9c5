#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

// The fuzz targets (docs/fuzzing.md): one function per reader of untrusted
// bytes. Each returns 0 for any input; the only exceptions it lets through
// are the ones its reader is not documented to throw, and it aborts when a
// round trip that must hold does not (both are findings). A libFuzzer
// executable (fuzz_main.cc) wraps one of them; fuzz_regression_test runs
// all of them over their seeds and every saved crash, in every build.
namespace ves::fuzz {

using FuzzFunction = int (*)(const std::uint8_t* data, std::size_t size);

struct FuzzTarget {
  const char* name;  // "csv", "markups", ...: the folder of its seeds and regressions
  FuzzFunction run;
};

int FuzzCsv(const std::uint8_t* data, std::size_t size);
int FuzzMarkups(const std::uint8_t* data, std::size_t size);
int FuzzTextproto(const std::uint8_t* data, std::size_t size);
int FuzzBundle(const std::uint8_t* data, std::size_t size);
int FuzzSessionFile(const std::uint8_t* data, std::size_t size);
int FuzzInputLog(const std::uint8_t* data, std::size_t size);
int FuzzCanFrame(const std::uint8_t* data, std::size_t size);
int FuzzJournal(const std::uint8_t* data, std::size_t size);

const std::vector<FuzzTarget>& AllFuzzTargets();

// Seeds from the project's own data (shipped cases, a short scripted session,
// frames of every kind): a starting corpus the fuzzer mutates.
std::vector<std::string> SeedsFor(const std::string& target);

// Aborts with `what` when `ok` is false: a property every input must keep.
void Require(bool ok, const char* what);

}  // namespace ves::fuzz
