#pragma once

#include <string>
#include <vector>

#include "patient_db/case_problem.h"
#include "ves/v1/case.pb.h"

// Validation of a ColonCase against the rules of docs/case-format.md. Every
// rule reports every violation (not only the first).
namespace ves::patient_db {

// Limits of the rules; the documented ranges.
inline constexpr double kMaxRadius_m = 0.060;              // beyond anatomy
inline constexpr int kMinControlPoints = 4;
inline constexpr int kMaxControlPoints = 5000;             // patient_db/limits.h kMaxCasePoints
inline constexpr double kMaxCenterlineLength_m = 3.0;      // a colon is 1.5 to 1.9 m
inline constexpr int kMaxRegionSpans = 64;
inline constexpr double kMinPointSpacing_m = 1e-4;         // closer: a duplicate point
inline constexpr double kMaxCoordinate_m = 2.0;            // |x|,|y|,|z| from the anus
inline constexpr double kArcTolerance_m = 0.001;           // region joints and ends
inline constexpr double kSelfProximityStep_m = 0.005;      // sampling of the crossing test
inline constexpr double kMaxSuspensionStiffness_N_per_m2 = 1e7;
inline constexpr double kMaxSuspensionDamping_N_s_per_m2 = 1e6;
inline constexpr double kMaxWallStiffness_N_per_m = 1e6;
inline constexpr double kMaxWallDamping_N_s_per_m = 1e5;
inline constexpr double kMaxFriction = 2.0;
inline constexpr double kMaxNeighborTension_N = 1e4;
inline constexpr double kMaxMesenteryLength_m = 0.5;
inline constexpr double kMaxMesenteryStiffness_N_per_m2 = 1e7;
inline constexpr double kMinPleatLimit = 0.05;
inline constexpr double kMaxGatheredReserve = 0.6;  // as station/model's
inline constexpr int kMinProvenanceYear = 1900;
inline constexpr int kMaxProvenanceYear = 2100;

// All problems of `colon_case`; empty when it is valid. `file_label` fills
// CaseProblem::file.
std::vector<CaseProblem> ValidateCase(const ves::v1::ColonCase& colon_case,
                                      const std::string& file_label);

// Throws CaseError with all problems unless the case is valid.
void CheckCase(const ves::v1::ColonCase& colon_case, const std::string& file_label);

// True when `text` contains something that reads as a date finer than a year
// ("2019-03", "12/03/2019", "March 2019", "3 Mar 2019"): de-identification.
bool LooksLikeFineDate(const std::string& text);

}  // namespace ves::patient_db
