#include "patient_db/case_regions.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <utility>

namespace ves::patient_db {
namespace {

constexpr std::array<std::pair<ves::v1::Region, const char*>, 8> kRegionNames = {{
    {ves::v1::REGION_RECTUM, "rectum"},
    {ves::v1::REGION_SIGMOID, "sigmoid"},
    {ves::v1::REGION_DESCENDING, "descending"},
    {ves::v1::REGION_SPLENIC_FLEXURE, "splenic-flexure"},
    {ves::v1::REGION_TRANSVERSE, "transverse"},
    {ves::v1::REGION_HEPATIC_FLEXURE, "hepatic-flexure"},
    {ves::v1::REGION_ASCENDING, "ascending"},
    {ves::v1::REGION_CECUM, "cecum"},
}};

// Values shared by every region (docs/case-format.md).
constexpr double kFixedSuspensionStiffness_N_per_m2 = 20000.0;
constexpr double kFixedSuspensionDamping_N_s_per_m2 = 200.0;
constexpr double kMobileSuspensionStiffness_N_per_m2 = 300.0;
constexpr double kMobileSuspensionDamping_N_s_per_m2 = 10.0;
constexpr double kWallStiffness_N_per_m = 400.0;
constexpr double kWallDamping_N_s_per_m = 4.0;
constexpr double kDeformationThreshold_m = 0.004;
// Lubricated colonoscope shaft on human colonic mucosa: dynamic about 0.1
// (Watanabe et al., Commun Eng 2024); static a little above it.
constexpr double kStaticFriction = 0.15;
constexpr double kDynamicFriction = 0.10;
constexpr double kNeighborTension_N = 2.0;

}  // namespace

std::string RegionName(ves::v1::Region region) {
  for (const auto& [value, name] : kRegionNames) {
    if (value == region) return name;
  }
  return "unspecified";
}

std::optional<ves::v1::Region> ParseRegionName(std::string_view name) {
  std::string key(name);
  std::transform(key.begin(), key.end(), key.begin(), [](unsigned char c) {
    return c == '_' ? '-' : static_cast<char>(std::tolower(c));
  });
  if (key.rfind("region-", 0) == 0) key.erase(0, 7);
  for (const auto& [value, region_name] : kRegionNames) {
    if (key == region_name) return value;
  }
  return std::nullopt;
}

bool IsMobileRegion(ves::v1::Region region) {
  return region == ves::v1::REGION_SIGMOID || region == ves::v1::REGION_TRANSVERSE;
}

ves::v1::TissueParams DefaultTissue(ves::v1::Region region) {
  ves::v1::TissueParams tissue;
  const bool mobile = IsMobileRegion(region);
  tissue.set_suspension_stiffness_n_per_m2(mobile ? kMobileSuspensionStiffness_N_per_m2
                                                  : kFixedSuspensionStiffness_N_per_m2);
  tissue.set_suspension_damping_n_s_per_m2(mobile ? kMobileSuspensionDamping_N_s_per_m2
                                                  : kFixedSuspensionDamping_N_s_per_m2);
  tissue.set_wall_stiffness_n_per_m(kWallStiffness_N_per_m);
  tissue.set_wall_damping_n_s_per_m(kWallDamping_N_s_per_m);
  tissue.set_deformation_threshold_m(kDeformationThreshold_m);
  tissue.set_static_friction(kStaticFriction);
  tissue.set_dynamic_friction(kDynamicFriction);
  tissue.set_neighbor_tension_n(kNeighborTension_N);
  return tissue;
}

}  // namespace ves::patient_db
