#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "patient_db/case_bundle.h"
#include "patient_db/case_generator.h"
#include "patient_db/case_geometry.h"
#include "patient_db/case_import.h"
#include "patient_db/case_problem.h"
#include "patient_db/case_regions.h"
#include "patient_db/case_textproto.h"
#include "patient_db/case_validate.h"
#include "ves/v1/case.pb.h"

// The colon case format (docs/case-format.md): one entry point that reads any
// supported file by its extension and writes textproto or bundle.
namespace ves::patient_db {

enum class CaseFileKind { kTextproto, kBundle, kCsv, kSlicerMarkups };

// By extension: .textproto, .vescase, .csv, .mrk.json; nullopt otherwise.
std::optional<CaseFileKind> CaseFileKindOf(const std::filesystem::path& path);

// Reads, parses and validates; throws CaseError (unreadable file, unknown
// extension, syntax, validation). Never returns an invalid case. For .mrk.json
// the radius sidecar "<stem>.radius.csv" and the region landmarks
// "<stem>.regions.mrk.json" next to it are used when present.
// `import` applies to .csv and .mrk.json only.
ves::v1::ColonCase LoadCaseFile(const std::filesystem::path& path,
                                const ImportOptions& import = {});

// Validates, then writes textproto (.textproto) or bundle (.vescase) through a
// temporary file renamed into place. Throws CaseError for an invalid case, an
// unsupported extension or a failed write.
void WriteCaseFile(const ves::v1::ColonCase& colon_case, const std::filesystem::path& path);

// Whole file as bytes; throws CaseError naming the path when unreadable.
std::string ReadFileBytes(const std::filesystem::path& path);

// Sidecar path of a markups file: "dir/x.mrk.json" -> "dir/x.radius.csv".
std::filesystem::path MarkupsRadiusSidecarPath(const std::filesystem::path& markups_path);
// Region landmarks next to a markups file: "dir/x.mrk.json" -> "dir/x.regions.mrk.json".
std::filesystem::path MarkupsLandmarksPath(const std::filesystem::path& markups_path);

}  // namespace ves::patient_db
