#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "ves/v1/case.pb.h"

// Names of the anatomical regions and the default tissue parameters given to
// imported centerlines (docs/case-format.md, "Default tissue").
namespace ves::patient_db {

// Short lowercase name used in CSV files and on the command line: "rectum",
// "sigmoid", "descending", "splenic-flexure", "transverse", "hepatic-flexure",
// "ascending", "cecum"; "unspecified" for anything else.
std::string RegionName(ves::v1::Region region);

// Inverse of RegionName; also accepts '_' for '-', any letter case, and the
// enum spelling ("REGION_SIGMOID"). nullopt for anything else (incl. unspecified).
std::optional<ves::v1::Region> ParseRegionName(std::string_view name);

// The sigmoid and transverse colon hang on a mesentery (mobile); the rest is
// held to the retroperitoneum or pelvis (fixed). Paper §3.3.
bool IsMobileRegion(ves::v1::Region region);

// Default tissue of a region: fixed regions K_c = 20000 N/m^2, D_c = 200 N s/m^2;
// mobile ones 300 and 10; wall, threshold and friction the same everywhere.
ves::v1::TissueParams DefaultTissue(ves::v1::Region region);

}  // namespace ves::patient_db
