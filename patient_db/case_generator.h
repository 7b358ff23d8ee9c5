#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "ves/v1/case.pb.h"

// A generator of plausible colons (docs/case-generator.md): region lengths,
// radii and mesentery heights drawn from published distributions, shapes
// from the shipped cases' anatomy stretched to those lengths. The same seed
// gives the same case, byte for byte; every generated case passes
// ValidateCase.
namespace ves::patient_db {

struct ColonGeneratorOptions {
  // nullopt: drawn (docs/case-generator.md gives the probabilities).
  std::optional<bool> redundant_sigmoid;
  std::optional<bool> mobile_descending;
  std::string id;  // default "generated-<seed>"
};

// The range each region's length is drawn in; a generated region's length
// lies within it (checked after the shape is fitted).
struct GeneratedLengthRange {
  ves::v1::Region region;
  double min_m;
  double max_m;
};
const std::array<GeneratedLengthRange, 8>& GeneratedLengthRanges();

// The whole colon's length lies in [kGeneratedMinLength_m, kGeneratedMaxLength_m]
// (CT colonography range; draws outside it are drawn again).
inline constexpr double kGeneratedMinLength_m = 1.30;
inline constexpr double kGeneratedMaxLength_m = 2.00;

// Throws CaseError only if no valid colon was found in a bounded number of
// draws for this seed (never seen: every seed tried in the tests succeeds).
ves::v1::ColonCase GenerateColonCase(std::uint64_t seed, const ColonGeneratorOptions& options = {});

}  // namespace ves::patient_db
