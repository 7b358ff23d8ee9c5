// The libFuzzer entry of one target: VES_FUZZ_TARGET names its function
// (tests/fuzz/CMakeLists.txt builds one executable per target).
#include "tests/fuzz/fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return ves::fuzz::VES_FUZZ_TARGET(data, size);
}
