#pragma once

#include <cstdint>
#include <string>

namespace ves::training {

// RFC 4122 version-4 UUID text (lower case) from 128 random bits; the version
// and variant bits are overwritten.
std::string FormatUuidV4(std::uint64_t high_bits, std::uint64_t low_bits);
// A fresh random UUID v4 (std::random_device).
std::string NewUuidV4();

}  // namespace ves::training
