#include "patient_db/case_import.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
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

// A region landmark: the region that begins where `p_W_m` projects onto the curve.
struct RegionLandmark {
  std::array<double, 3> p_W_m;  // same frame as ImportedPoints::p_W_m
  ves::v1::Region region;
};

struct ImportedPoints {
  std::vector<std::array<double, 3>> p_W_m;     // patient frame, not yet translated
  std::vector<double> radius_m;                 // empty: use options.radius_mm
  std::vector<ves::v1::Region> regions;         // empty: landmarks or options.region
  std::vector<RegionLandmark> landmarks;        // regions by position along the curve
};

// Arc length along the polyline through `points` of the point of it nearest
// to `p` (the first of equally near ones).
double ProjectOntoPolyline(const std::vector<std::array<double, 3>>& points,
                           const std::vector<double>& arcs_m, const std::array<double, 3>& p) {
  double best_distance2 = std::numeric_limits<double>::infinity();
  double best_arc_m = 0.0;
  for (size_t i = 0; i + 1 < points.size(); ++i) {
    double d[3];
    double w[3];
    double length2 = 0.0;
    double along = 0.0;
    for (int k = 0; k < 3; ++k) {
      d[k] = points[i + 1][k] - points[i][k];
      w[k] = p[k] - points[i][k];
      length2 += d[k] * d[k];
      along += w[k] * d[k];
    }
    const double t = length2 > 0.0 ? std::clamp(along / length2, 0.0, 1.0) : 0.0;
    double distance2 = 0.0;
    for (int k = 0; k < 3; ++k) distance2 += (w[k] - t * d[k]) * (w[k] - t * d[k]);
    if (distance2 < best_distance2) {
      best_distance2 = distance2;
      best_arc_m = arcs_m[i] + t * (arcs_m[i + 1] - arcs_m[i]);
    }
  }
  return best_arc_m;
}

ves::v1::ColonCase BuildCase(const ImportedPoints& in, const std::string& file,
                             const ImportOptions& options, const std::string& source) {
  std::vector<CaseProblem> problems;
  if (in.p_W_m.empty()) problems.push_back({file, "centerline", -1, "", "no points"});
  if (in.radius_m.empty() && !options.radius_mm) {
    problems.push_back({file, "radius_mm", -1, "",
                        "no radius: give a radius column/sidecar or a constant (--radius-mm)"});
  }
  if (in.regions.empty() && in.landmarks.empty() && !options.region) {
    problems.push_back({file, "region", -1, "",
                        "no region column or landmarks: give the region of the whole "
                        "centerline (--region)"});
  }
  if (!in.regions.empty() && !in.landmarks.empty()) {
    problems.push_back({file, "region", -1, "",
                        "regions given twice (a region column and landmarks): keep one"});
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
  if (!in.landmarks.empty()) {
    // Each landmark starts its region where it projects onto the curve; the
    // first region also covers the curve before its landmark (from the anus).
    std::vector<std::pair<double, ves::v1::Region>> starts;
    for (const auto& landmark : in.landmarks) {
      starts.emplace_back(ProjectOntoPolyline(in.p_W_m, arcs_m, landmark.p_W_m), landmark.region);
    }
    std::stable_sort(starts.begin(), starts.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (size_t i = 0; i < starts.size(); ++i) {
      if (c.regions_size() > 0 && c.regions(c.regions_size() - 1).region() == starts[i].second) {
        continue;  // the same region again: one span
      }
      const double start_m = c.regions_size() == 0 ? 0.0 : starts[i].first;
      if (c.regions_size() > 0) c.mutable_regions(c.regions_size() - 1)->set_end_arc_m(start_m);
      auto* span = c.add_regions();
      span->set_region(starts[i].second);
      span->set_start_arc_m(start_m);
      *span->mutable_tissue() = DefaultTissue(starts[i].second);
    }
    c.mutable_regions(c.regions_size() - 1)->set_end_arc_m(length_m);
  } else if (in.regions.empty()) {
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

// Coordinates of a markup node in W (metres): its coordinateSystem and
// coordinateUnits read and checked; `where` names the markup in messages.
struct MarkupFrame {
  bool lps{true};
  double metres_per_unit{1e-3};
};

MarkupFrame ReadMarkupFrame(const nlohmann::json& markup, const std::string& file_label,
                            const std::string& where) {
  MarkupFrame frame;
  const std::string system = markup.value("coordinateSystem", std::string("LPS"));
  if (system != "LPS" && system != "RAS") {
    throw CaseError(file_label, where + ".coordinateSystem", -1, system, "must be LPS or RAS");
  }
  frame.lps = system == "LPS";
  const std::string units = markup.value("coordinateUnits", std::string("mm"));
  if (units == "um") {
    frame.metres_per_unit = 1e-6;
  } else if (units != "mm") {
    throw CaseError(file_label, where + ".coordinateUnits", -1, units, "must be mm or um");
  }
  return frame;
}

// controlPoints[].position of `markup` in W; problems for malformed points.
std::vector<std::array<double, 3>> ReadControlPoints(const nlohmann::json& markup,
                                                     const MarkupFrame& frame,
                                                     const std::string& file_label,
                                                     const std::string& where,
                                                     std::vector<CaseProblem>& problems) {
  using nlohmann::json;
  std::vector<std::array<double, 3>> points;
  if (!markup.contains("controlPoints") || !markup["controlPoints"].is_array()) {
    throw CaseError(file_label, where + ".controlPoints", -1, "", "missing");
  }
  int index = 0;
  for (const json& point : markup["controlPoints"]) {
    const json* position = point.is_object() && point.contains("position") ? &point["position"]
                                                                            : nullptr;
    if (!position || !position->is_array() || position->size() != 3 ||
        !std::all_of(position->begin(), position->end(),
                     [](const json& v) { return v.is_number(); })) {
      problems.push_back({file_label, where + ".controlPoints.position", index,
                          position ? position->dump() : "", "must be an array of 3 numbers"});
      points.push_back({0.0, 0.0, 0.0});
      ++index;
      continue;
    }
    const double a = (*position)[0].get<double>() * frame.metres_per_unit;
    const double b = (*position)[1].get<double>() * frame.metres_per_unit;
    const double c = (*position)[2].get<double>() * frame.metres_per_unit;
    // W is RAS (+x right, +y anterior, +z superior): LPS -> (-x, -y, z).
    points.push_back(frame.lps ? std::array<double, 3>{-a, -b, c} : std::array<double, 3>{a, b, c});
    ++index;
  }
  return points;
}

bool IsPointList(const nlohmann::json& markup) {
  const std::string type = markup.value("type", std::string());
  return type == "Fiducial" || type == "PointList";
}

// The labelled points of a point list markup as region landmarks; a label
// that is no region is a problem naming it.
void ReadLandmarks(const nlohmann::json& markup, const std::string& file_label,
                   const std::string& where, ImportedPoints& in,
                   std::vector<CaseProblem>& problems) {
  const MarkupFrame frame = ReadMarkupFrame(markup, file_label, where);
  const auto points = ReadControlPoints(markup, frame, file_label, where, problems);
  for (size_t i = 0; i < points.size(); ++i) {
    const std::string label = markup["controlPoints"][i].value("label", std::string());
    const auto region = ParseRegionName(label);
    if (!region) {
      problems.push_back({file_label, where + ".controlPoints.label", static_cast<int>(i), label,
                          "must name the region that begins there (rectum, sigmoid, descending, "
                          "splenic-flexure, transverse, hepatic-flexure, ascending, cecum)"});
      continue;
    }
    in.landmarks.push_back({points[i], *region});
  }
  if (points.empty()) problems.push_back({file_label, where + ".controlPoints", -1, "", "no landmarks"});
}

// The curve's "Radius" measurement, one value per control point (Slicer's
// Extract Centerline writes it): radii in metres, or empty when absent.
std::vector<double> ReadRadiusMeasurement(const nlohmann::json& markup, size_t point_count,
                                          const std::string& file_label,
                                          std::vector<CaseProblem>& problems) {
  if (!markup.contains("measurements") || !markup["measurements"].is_array()) return {};
  int index = 0;
  for (const auto& measurement : markup["measurements"]) {
    const std::string where = "markups[0].measurements[" + std::to_string(index++) + "]";
    if (!measurement.is_object()) continue;
    std::string name = measurement.value("name", std::string());
    std::transform(name.begin(), name.end(), name.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (name != "radius") continue;
    const std::string units = measurement.value("units", std::string("mm"));
    const double metres_per_unit = units == "mm" ? 1e-3 : units == "cm" ? 1e-2 : units == "um" ? 1e-6 : 0.0;
    if (metres_per_unit == 0.0) {
      problems.push_back({file_label, where + ".units", -1, units, "must be mm, cm or um"});
      return {};
    }
    if (!measurement.contains("controlPointValues") ||
        !measurement["controlPointValues"].is_array()) {
      problems.push_back({file_label, where + ".controlPointValues", -1, "",
                          "missing: the Radius measurement needs one value per control point"});
      return {};
    }
    const auto& values = measurement["controlPointValues"];
    if (values.size() != point_count) {
      problems.push_back({file_label, where + ".controlPointValues", -1,
                          std::to_string(values.size()) + " values",
                          "must have one value per control point (" +
                              std::to_string(point_count) + ")"});
      return {};
    }
    std::vector<double> radius_m;
    for (size_t i = 0; i < values.size(); ++i) {
      if (!values[i].is_number() || !std::isfinite(values[i].get<double>())) {
        problems.push_back({file_label, where + ".controlPointValues", static_cast<int>(i),
                            values[i].dump(), "not a finite number"});
        radius_m.push_back(0.0);
        continue;
      }
      radius_m.push_back(values[i].get<double>() * metres_per_unit);
    }
    return radius_m;
  }
  return {};
}

}  // namespace

namespace {

ves::v1::ColonCase ImportSlicerMarkupsOrThrow(
    std::string_view json_text, const std::optional<std::string>& radius_csv_text,
    const std::string& file_label, const ImportOptions& options,
    const std::optional<std::string>& landmarks_json_text) {
  using nlohmann::json;
  const auto parse = [](std::string_view text, const std::string& label) {
    try {
      return json::parse(text);
    } catch (const json::exception& e) {
      throw CaseError(label, "json", -1, "", std::string("not JSON: ") + e.what());
    }
  };
  const json doc = parse(json_text, file_label);
  if (!doc.is_object() || !doc.contains("markups") || !doc["markups"].is_array() ||
      doc["markups"].empty()) {
    throw CaseError(file_label, "markups", -1, "",
                    "no markups array (not a 3D Slicer markups file)");
  }
  const json& markup = doc["markups"][0];
  ImportedPoints in;
  std::vector<CaseProblem> problems;
  in.p_W_m = ReadControlPoints(markup, ReadMarkupFrame(markup, file_label, "markups[0]"),
                               file_label, "markups[0]", problems);
  in.radius_m = ReadRadiusMeasurement(markup, in.p_W_m.size(), file_label, problems);
  // Point lists after the curve in the same file are region landmarks.
  for (size_t m = 1; m < doc["markups"].size(); ++m) {
    if (IsPointList(doc["markups"][m])) {
      ReadLandmarks(doc["markups"][m], file_label, "markups[" + std::to_string(m) + "]", in,
                    problems);
    }
  }
  if (landmarks_json_text) {
    const std::string label = file_label + " (region landmarks)";
    const json landmarks = parse(*landmarks_json_text, label);
    bool found = false;
    if (landmarks.is_object() && landmarks.contains("markups") && landmarks["markups"].is_array()) {
      for (size_t m = 0; m < landmarks["markups"].size(); ++m) {
        if (!IsPointList(landmarks["markups"][m])) continue;
        ReadLandmarks(landmarks["markups"][m], label, "markups[" + std::to_string(m) + "]", in,
                      problems);
        found = true;
      }
    }
    if (!found) problems.push_back({label, "markups", -1, "", "no point list of landmarks"});
  }
  if (radius_csv_text) {
    // The sidecar, when there is one, gives the radii (over the measurement).
    in.radius_m.clear();
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

ves::v1::ColonCase ImportSlicerMarkups(std::string_view json_text,
                                       const std::optional<std::string>& radius_csv_text,
                                       const std::string& file_label,
                                       const ImportOptions& options,
                                       const std::optional<std::string>& landmarks_json_text) {
  // A member of the wrong JSON type ("coordinateSystem": 5) is a problem of
  // the file, not an abort (found by fuzzing: tests/fuzz/regressions/markups).
  try {
    return ImportSlicerMarkupsOrThrow(json_text, radius_csv_text, file_label, options,
                                      landmarks_json_text);
  } catch (const nlohmann::json::exception& e) {
    throw CaseError(file_label, "json", -1, "", std::string("unexpected content: ") + e.what());
  }
}

}  // namespace ves::patient_db
