#include "patient_db/case_import.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <vector>

#include "patient_db/case_geometry.h"
#include "patient_db/case_problem.h"
#include "patient_db/case_regions.h"
#include "patient_db/case_validate.h"
#include "patient_db/limits.h"

namespace ves::patient_db {
namespace {

constexpr double kMetresPerMillimetre = 1e-3;

struct CsvRow {
  int line = 0;  // 1-based line number in the file
  std::vector<std::string> cells;
};

struct CsvTable {
  std::vector<std::string> header;
  std::vector<CsvRow> rows;
};

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
    cells.push_back(Trim(line.substr(start, comma == std::string_view::npos ? std::string_view::npos
                                                                            : comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return cells;
}

// Lines, '#' comments and blank lines skipped; the first remaining line is the header.
// Rows with the wrong number of cells go to `problems` (so every problem of the
// file is reported together); a missing header throws.
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
      problems.push_back({file, "csv.header", i, name, "unknown column (expected one of the header " +
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

struct ImportedPoints {
  std::vector<std::array<double, 3>> p_W_m;     // patient frame, not yet translated
  std::vector<double> radius_m;                 // empty: use options.radius_mm
  std::vector<ves::v1::Region> regions;         // empty: use options.region
};

ves::v1::ColonCase BuildCase(const ImportedPoints& in, const std::string& file,
                             const ImportOptions& options, const std::string& source) {
  std::vector<CaseProblem> problems;
  if (in.p_W_m.empty()) problems.push_back({file, "centerline", -1, "", "no points"});
  if (in.radius_m.empty() && !options.radius_mm) {
    problems.push_back({file, "radius_mm", -1, "",
                        "no radius: give a radius column/sidecar or a constant (--radius-mm)"});
  }
  if (in.regions.empty() && !options.region) {
    problems.push_back({file, "region", -1, "",
                        "no region column: give the region of the whole centerline (--region)"});
  }
  // Arcs, radius samples and region spans are derived from the points: a
  // point that is not finite is reported once, here, instead of in each.
  for (size_t i = 0; i < in.p_W_m.size(); ++i) {
    const char* names[3] = {"centerline.x_m", "centerline.y_m", "centerline.z_m"};
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(in.p_W_m[i][k]) || std::abs(in.p_W_m[i][k]) > 1e6) {
        problems.push_back({file, names[k], static_cast<int>(i), std::to_string(in.p_W_m[i][k]),
                            "not a finite number in range"});
      }
    }
  }
  if (!problems.empty()) throw CaseError(std::move(problems));

  ves::v1::ColonCase c;
  const std::string name = std::filesystem::path(file).filename().string();
  c.set_id(options.id.empty() ? CaseIdFromFileName(name) : options.id);
  c.set_title(options.title.empty() ? "Imported centerline " + name : options.title);
  c.set_version(1);
  c.mutable_provenance()->set_source(source);
  const auto origin = in.p_W_m.front();
  for (const auto& p : in.p_W_m) {
    auto* point = c.add_centerline();
    point->set_x_m(p[0] - origin[0]);
    point->set_y_m(p[1] - origin[1]);
    point->set_z_m(p[2] - origin[2]);
  }
  const auto arcs_m = CalcControlPointArcs_m(c);
  for (size_t i = 0; i < arcs_m.size(); ++i) {
    auto* sample = c.add_radius_profile();
    sample->set_arc_m(arcs_m[i]);
    sample->set_radius_m(options.radius_mm ? *options.radius_mm * kMetresPerMillimetre
                                           : in.radius_m[i]);
  }
  // Region spans: a run of equal names from its first point to the next run's first point.
  const double length_m = arcs_m.back();
  if (in.regions.empty()) {
    auto* span = c.add_regions();
    span->set_region(*options.region);
    span->set_start_arc_m(0.0);
    span->set_end_arc_m(length_m);
    *span->mutable_tissue() = DefaultTissue(*options.region);
  } else {
    for (size_t i = 0; i < in.regions.size(); ++i) {
      if (i > 0 && in.regions[i] == in.regions[i - 1]) continue;
      if (c.regions_size() > 0) c.mutable_regions(c.regions_size() - 1)->set_end_arc_m(arcs_m[i]);
      auto* span = c.add_regions();
      span->set_region(in.regions[i]);
      span->set_start_arc_m(arcs_m[i]);
      *span->mutable_tissue() = DefaultTissue(in.regions[i]);
    }
    c.mutable_regions(c.regions_size() - 1)->set_end_arc_m(length_m);
  }
  CheckCase(c, file);
  return c;
}

// Reads optional radius/region columns of `table` into `out`.
void ReadRadiusAndRegion(const CsvTable& table, const std::map<std::string, int>& columns,
                         const std::string& file, ImportedPoints& out,
                         std::vector<CaseProblem>& problems) {
  for (const auto& row : table.rows) {
    if (columns.count("radius_mm")) {
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

}  // namespace

std::string CaseIdFromFileName(const std::string& file_name) {
  std::string stem = file_name;
  for (const char* suffix : {".mrk.json", ".textproto", ".vescase", ".csv"}) {
    const std::string s(suffix);
    if (stem.size() > s.size() && stem.compare(stem.size() - s.size(), s.size(), s) == 0) {
      stem.resize(stem.size() - s.size());
      break;
    }
  }
  std::string id;
  for (const unsigned char ch : stem) {
    if (std::isalnum(ch)) {
      id += static_cast<char>(std::tolower(ch));
    } else if (!id.empty() && id.back() != '-') {
      id += '-';
    }
  }
  while (!id.empty() && id.back() == '-') id.pop_back();
  if (id.size() > 64) id.resize(64);
  return id.empty() ? "imported-case" : id;
}

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
        problems.push_back({file_label, std::string("csv.") + names[k], row.line, cell,
                            "not a number"});
      } else if (!std::isfinite(*value)) {
        // Said here, once: arcs, radii and regions derived from it would repeat it.
        problems.push_back({file_label, std::string("csv.") + names[k], row.line, cell,
                            "not a finite number"});
      }
      p[k] = value.value_or(0.0) * kMetresPerMillimetre;
    }
    in.p_W_m.push_back(p);
  }
  ReadRadiusAndRegion(table, columns, file_label, in, problems);
  if (!problems.empty()) throw CaseError(std::move(problems));
  return BuildCase(in, file_label, options, "imported centerline (CSV)");
}

namespace {

ves::v1::ColonCase ImportSlicerMarkupsOrThrow(std::string_view json_text,
                                              const std::optional<std::string>& radius_csv_text,
                                              const std::string& file_label,
                                              const ImportOptions& options);

}  // namespace

ves::v1::ColonCase ImportSlicerMarkups(std::string_view json_text,
                                       const std::optional<std::string>& radius_csv_text,
                                       const std::string& file_label,
                                       const ImportOptions& options) {
  // A member of the wrong JSON type ("coordinateSystem": 5) is a problem of
  // the file, not an abort (found by fuzzing: tests/fuzz/regressions/markups).
  try {
    return ImportSlicerMarkupsOrThrow(json_text, radius_csv_text, file_label, options);
  } catch (const nlohmann::json::exception& e) {
    throw CaseError(file_label, "json", -1, "", std::string("unexpected content: ") + e.what());
  }
}

namespace {

ves::v1::ColonCase ImportSlicerMarkupsOrThrow(std::string_view json_text,
                                              const std::optional<std::string>& radius_csv_text,
                                              const std::string& file_label,
                                              const ImportOptions& options) {
  using nlohmann::json;
  json doc;
  try {
    doc = json::parse(json_text);
  } catch (const json::exception& e) {
    throw CaseError(file_label, "json", -1, "", std::string("not JSON: ") + e.what());
  }
  auto fail = [&](std::string field, std::string value, std::string message) {
    throw CaseError(file_label, std::move(field), -1, std::move(value), std::move(message));
  };
  if (!doc.is_object() || !doc.contains("markups") || !doc["markups"].is_array() ||
      doc["markups"].empty()) {
    fail("markups", "", "no markups array (not a 3D Slicer markups file)");
  }
  const json& markup = doc["markups"][0];
  const std::string system = markup.value("coordinateSystem", std::string("LPS"));
  if (system != "LPS" && system != "RAS") {
    fail("markups[0].coordinateSystem", system, "must be LPS or RAS");
  }
  const std::string units = markup.value("coordinateUnits", std::string("mm"));
  double metres_per_unit = kMetresPerMillimetre;
  if (units == "um") {
    metres_per_unit = 1e-6;
  } else if (units != "mm") {
    fail("markups[0].coordinateUnits", units, "must be mm or um");
  }
  if (!markup.contains("controlPoints") || !markup["controlPoints"].is_array()) {
    fail("markups[0].controlPoints", "", "missing");
  }
  ImportedPoints in;
  std::vector<CaseProblem> problems;
  int index = 0;
  for (const json& point : markup["controlPoints"]) {
    const json* position = point.is_object() && point.contains("position") ? &point["position"]
                                                                            : nullptr;
    if (!position || !position->is_array() || position->size() != 3 ||
        !std::all_of(position->begin(), position->end(),
                     [](const json& v) { return v.is_number(); })) {
      problems.push_back({file_label, "markups[0].controlPoints.position", index,
                          position ? position->dump() : "", "must be an array of 3 numbers"});
      ++index;
      continue;
    }
    const double a = (*position)[0].get<double>() * metres_per_unit;
    const double b = (*position)[1].get<double>() * metres_per_unit;
    const double c = (*position)[2].get<double>() * metres_per_unit;
    // W is RAS (+x right, +y anterior, +z superior): LPS -> (-x, -y, z).
    in.p_W_m.push_back(system == "LPS" ? std::array<double, 3>{-a, -b, c}
                                       : std::array<double, 3>{a, b, c});
    ++index;
  }
  if (radius_csv_text) {
    const std::string sidecar = file_label + " (radius sidecar)";
    std::vector<CaseProblem> row_problems;
    const CsvTable table = ReadCsvTable(*radius_csv_text, sidecar, row_problems);
    const auto columns = MapColumns(table, {"radius_mm", "region"}, {}, sidecar);
    problems.insert(problems.end(), row_problems.begin(), row_problems.end());
    if (!row_problems.empty()) {
      // Rows are missing: the count check below would only repeat them.
    } else if (table.rows.size() != in.p_W_m.size() && problems.empty()) {
      problems.push_back({sidecar, "csv", -1, std::to_string(table.rows.size()) + " rows",
                          "must have one row per control point (" +
                              std::to_string(in.p_W_m.size()) + ")"});
    } else {
      ReadRadiusAndRegion(table, columns, sidecar, in, problems);
    }
  }
  if (!problems.empty()) throw CaseError(std::move(problems));
  return BuildCase(in, file_label, options, "imported centerline (3D Slicer markups)");
}

}  // namespace

}  // namespace ves::patient_db
