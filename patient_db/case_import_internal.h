#pragma once

#include <array>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "patient_db/case_import.h"
#include "patient_db/case_problem.h"
#include "ves/v1/case.pb.h"

// What the importers share: the CSV reading (centrelines and Slicer's radius
// sidecars), the points read from a file, and BuildCase, which makes and
// validates the case from them. Internal to case_import*.cc.
namespace ves::patient_db::case_import {

inline constexpr double kMetresPerMillimetre = 1e-3;

struct CsvRow {
  int line = 0;  // 1-based line number in the file
  std::vector<std::string> cells;
};

struct CsvTable {
  std::vector<std::string> header;
  std::vector<CsvRow> rows;
};

// Lines, '#' comments and blank lines skipped; the first remaining line is the header.
// Rows with the wrong number of cells go to `problems` (so every problem of the
// file is reported together); a missing header throws.
CsvTable ReadCsvTable(std::string_view text, const std::string& file,
                      std::vector<CaseProblem>& problems);

// The number a cell holds, all of it; nullopt when it holds anything else.
std::optional<double> ParseNumber(const std::string& cell);

// Column index by name; -1 when absent. Unknown names are problems.
std::map<std::string, int> MapColumns(const CsvTable& table, const std::vector<std::string>& known,
                                      const std::vector<std::string>& required,
                                      const std::string& file);

// A region landmark: the region that begins where `p_W_m` projects onto the curve.
struct RegionLandmark {
  std::array<double, 3> p_W_m;  // same frame as ImportedPoints::p_W_m
  ves::v1::Region region;
};

struct ImportedPoints {
  std::vector<std::array<double, 3>> p_W_m;  // patient frame, not yet translated
  std::vector<double> radius_m;              // empty: use options.radius_mm
  std::vector<ves::v1::Region> regions;      // empty: landmarks or options.region
  std::vector<RegionLandmark> landmarks;     // regions by position along the curve

  // How the file names its points and radii, so a problem says it in the
  // file's own terms (its line, its point label, its unit), not the case's.
  std::vector<int> lines;           // CSV: each point's line
  std::vector<std::string> labels;  // markups: each point's label
  std::string length_unit = "mm";
  double units_per_m = 1000.0;
  std::string radius_file;        // where the radii come from
  std::string radius_field;       // "csv.radius_mm", a measurement
  std::vector<int> radius_lines;  // CSV or sidecar line of each radius
  std::string radius_unit = "mm";
  double radius_units_per_m = 1000.0;
};

// Reads optional radius/region columns of `table` into `out`.
void ReadRadiusAndRegion(const CsvTable& table, const std::map<std::string, int>& columns,
                         const std::string& file, ImportedPoints& out,
                         std::vector<CaseProblem>& problems);

// The case of the file's points (case_import.h says how); throws CaseError
// with every problem in the file's own terms. `source` goes to the provenance.
ves::v1::ColonCase BuildCase(ImportedPoints in, const std::string& file,
                             const ImportOptions& options, const std::string& source);

}  // namespace ves::patient_db::case_import
