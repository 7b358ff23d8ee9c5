// Import of centrelines from CSV, and the CSV reading the Slicer import's
// radius sidecar shares (case_import_internal.h).
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "patient_db/case_import.h"
#include "patient_db/case_import_internal.h"
#include "patient_db/case_problem.h"
#include "patient_db/case_regions.h"
#include "patient_db/limits.h"

namespace ves::patient_db::case_import {
namespace {

std::string Trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return "";
  const auto last = text.find_last_not_of(" \t\r\n");
  return std::string(text.substr(first, last - first + 1));
}

std::vector<std::string> SplitCells(std::string_view line) {
  std::vector<std::string> cells;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    cells.push_back(Trim(line.substr(
        start, comma == std::string_view::npos ? std::string_view::npos : comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return cells;
}

}  // namespace

CsvTable ReadCsvTable(std::string_view text, const std::string& file,
                      std::vector<CaseProblem>& problems) {
  CsvTable table;
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);  // UTF-8 BOM (spreadsheets)
  // A binary file is one problem, said as such, not a header of garbage.
  for (size_t i = 0; i < text.size(); ++i) {
    const auto byte = static_cast<unsigned char>(text[i]);
    if (byte < 0x20 && byte != '\t' && byte != '\r' && byte != '\n') {
      char at[48];
      std::snprintf(at, sizeof at, "byte 0x%02x at offset %zu", byte, i);
      throw CaseError(file, "csv", -1, at, "not a text CSV file (a control byte: binary data?)");
    }
  }
  if (!IsValidUtf8(text)) {
    throw CaseError(file, "csv", -1, "", "not a text CSV file (not valid UTF-8: binary data?)");
  }
  int line_number = 0;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    ++line_number;
    const std::string line = Trim(text.substr(start, end - start));
    start = end + 1;
    if (line.empty() || line[0] == '#') continue;
    auto cells = SplitCells(line);
    if (table.header.empty()) {
      table.header = std::move(cells);
      continue;
    }
    if (cells.size() != table.header.size()) {
      problems.push_back({file, "csv", line_number, line,
                          "has " + std::to_string(cells.size()) + " cells, the header has " +
                              std::to_string(table.header.size())});
      continue;
    }
    table.rows.push_back({line_number, std::move(cells)});
  }
  if (table.header.empty()) throw CaseError(file, "csv", -1, "", "empty: no header line");
  return table;
}

std::optional<double> ParseNumber(const std::string& cell) {
  double value = 0.0;
  const char* end = cell.data() + cell.size();
  const auto [ptr, ec] = std::from_chars(cell.data(), end, value);
  if (ec != std::errc() || ptr != end || cell.empty()) return std::nullopt;
  return value;
}

// Column index by name; -1 when absent. Unknown names are problems.
std::map<std::string, int> MapColumns(const CsvTable& table, const std::vector<std::string>& known,
                                      const std::vector<std::string>& required,
                                      const std::string& file) {
  std::map<std::string, int> columns;
  std::vector<CaseProblem> problems;
  for (int i = 0; i < static_cast<int>(table.header.size()); ++i) {
    const std::string& name = table.header[i];
    if (std::find(known.begin(), known.end(), name) == known.end()) {
      problems.push_back({file, "csv.header", i, name,
                          "unknown column (expected one of the header " +
                              std::string("names in docs/case-format.md)")});
    } else {
      columns[name] = i;
    }
  }
  for (const auto& name : required) {
    if (!columns.count(name)) {
      problems.push_back({file, "csv.header", -1, name, "required column missing"});
    }
  }
  if (!problems.empty()) throw CaseError(std::move(problems));
  return columns;
}

void ReadRadiusAndRegion(const CsvTable& table, const std::map<std::string, int>& columns,
                         const std::string& file, ImportedPoints& out,
                         std::vector<CaseProblem>& problems) {
  if (columns.count("radius_mm")) {
    out.radius_file = file;
    out.radius_field = "csv.radius_mm";
  }
  for (const auto& row : table.rows) {
    if (columns.count("radius_mm")) {
      out.radius_lines.push_back(row.line);
      const auto r = ParseNumber(row.cells[columns.at("radius_mm")]);
      if (!r || !std::isfinite(*r)) {
        problems.push_back({file, "csv.radius_mm", row.line, row.cells[columns.at("radius_mm")],
                            r ? "not a finite number" : "not a number"});
      }
      out.radius_m.push_back(r.value_or(0.0) * kMetresPerMillimetre);
    }
    if (columns.count("region")) {
      const std::string& name = row.cells[columns.at("region")];
      const auto region = ParseRegionName(name);
      if (!region) {
        problems.push_back({file, "csv.region", row.line, name,
                            "unknown region (rectum, sigmoid, descending, splenic-flexure, "
                            "transverse, hepatic-flexure, ascending, cecum)"});
      }
      out.regions.push_back(region.value_or(ves::v1::REGION_UNSPECIFIED));
    }
  }
}

}  // namespace ves::patient_db::case_import

namespace ves::patient_db {

using case_import::BuildCase;
using case_import::CsvTable;
using case_import::ImportedPoints;
using case_import::kMetresPerMillimetre;
using case_import::MapColumns;
using case_import::ParseNumber;
using case_import::ReadCsvTable;
using case_import::ReadRadiusAndRegion;

ves::v1::ColonCase ImportCenterlineCsv(std::string_view csv_text, const std::string& file_label,
                                       const ImportOptions& options) {
  std::vector<CaseProblem> problems;
  const CsvTable table = ReadCsvTable(csv_text, file_label, problems);
  const auto columns = MapColumns(table, {"x_mm", "y_mm", "z_mm", "radius_mm", "region"},
                                  {"x_mm", "y_mm", "z_mm", "radius_mm"}, file_label);
  ImportedPoints in;
  for (const auto& row : table.rows) {
    std::array<double, 3> p{};
    const char* names[3] = {"x_mm", "y_mm", "z_mm"};
    for (int k = 0; k < 3; ++k) {
      const std::string& cell = row.cells[columns.at(names[k])];
      const auto value = ParseNumber(cell);
      if (!value) {
        problems.push_back(
            {file_label, std::string("csv.") + names[k], row.line, cell, "not a number"});
      } else if (!std::isfinite(*value)) {
        // Said here, once: arcs, radii and regions derived from it would repeat it.
        problems.push_back(
            {file_label, std::string("csv.") + names[k], row.line, cell, "not a finite number"});
      }
      p[k] = value.value_or(0.0) * kMetresPerMillimetre;
    }
    in.p_W_m.push_back(p);
    in.lines.push_back(row.line);
  }
  ReadRadiusAndRegion(table, columns, file_label, in, problems);
  if (!problems.empty()) throw CaseError(std::move(problems));
  return BuildCase(in, file_label, options, "imported centerline (CSV)");
}

}  // namespace ves::patient_db
