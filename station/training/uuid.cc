#include "station/training/uuid.h"

#include <cstdio>
#include <random>

namespace ves::training {

std::string FormatUuidV4(std::uint64_t high, std::uint64_t low) {
  high = (high & ~std::uint64_t{0xf000}) | std::uint64_t{0x4000};          // version 4
  low = (low & ~(std::uint64_t{0x3} << 62)) | (std::uint64_t{0x2} << 62);  // variant 10xx
  char text[37];
  std::snprintf(text, sizeof(text), "%08x-%04x-%04x-%04x-%012llx",
                static_cast<unsigned>(high >> 32), static_cast<unsigned>((high >> 16) & 0xffff),
                static_cast<unsigned>(high & 0xffff), static_cast<unsigned>(low >> 48),
                static_cast<unsigned long long>(low & 0xffffffffffffULL));
  return text;
}

std::string NewUuidV4() {
  std::random_device device;
  auto draw64 = [&device] {
    return (static_cast<std::uint64_t>(device()) << 32) ^ static_cast<std::uint64_t>(device());
  };
  const std::uint64_t high = draw64();
  return FormatUuidV4(high, draw64());
}

}  // namespace ves::training
