// Import of 3D Slicer curve markups (*.mrk.json) with their radius sidecar
// or measurement and region landmarks (case_import.h).
#include <array>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "patient_db/case_import.h"
#include "patient_db/case_import_internal.h"
#include "patient_db/case_problem.h"
#include "patient_db/case_regions.h"
#include "patient_db/limits.h"

namespace ves::patient_db {

using case_import::BuildCase;
using case_import::CsvTable;
using case_import::ImportedPoints;
using case_import::MapColumns;
using case_import::ReadCsvTable;
using case_import::ReadRadiusAndRegion;

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
    const json* position =
        point.is_object() && point.contains("position") ? &point["position"] : nullptr;
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
  if (points.empty())
    problems.push_back({file_label, where + ".controlPoints", -1, "", "no landmarks"});
}

// The curve's "Radius" measurement, one value per control point (Slicer's
// Extract Centerline writes it): radii in metres, or empty when absent.
std::vector<double> ReadRadiusMeasurement(const nlohmann::json& markup, size_t point_count,
                                          const std::string& file_label, ImportedPoints& in,
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
    const double metres_per_unit = units == "mm"   ? 1e-3
                                   : units == "cm" ? 1e-2
                                   : units == "um" ? 1e-6
                                                   : 0.0;
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
      problems.push_back(
          {file_label, where + ".controlPointValues", -1, std::to_string(values.size()) + " values",
           "must have one value per control point (" + std::to_string(point_count) + ")"});
      return {};
    }
    in.radius_file = file_label;
    in.radius_field = "the " + measurement.value("name", std::string()) + " measurement, " + where;
    in.radius_unit = units;
    in.radius_units_per_m = 1.0 / metres_per_unit;
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
  // The points' own labels (3D Slicer's "CL-41"), 1-based numbers for unlabelled ones.
  for (size_t i = 0; i < in.p_W_m.size(); ++i) {
    const auto& point = markup["controlPoints"][i];
    std::string label = point.is_object() ? point.value("label", std::string()) : std::string();
    in.labels.push_back(label.empty() ? std::to_string(i + 1) : PrintableExcerpt(label, 64));
  }
  const MarkupFrame curve_frame = ReadMarkupFrame(markup, file_label, "markups[0]");
  in.units_per_m = 1.0 / curve_frame.metres_per_unit;
  in.length_unit = curve_frame.metres_per_unit == 1e-3 ? "mm" : "um";
  in.radius_m = ReadRadiusMeasurement(markup, in.p_W_m.size(), file_label, in, problems);
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
      problems.push_back(
          {sidecar, "csv", -1, std::to_string(table.rows.size()) + " rows",
           "must have one row per control point (" + std::to_string(in.p_W_m.size()) + ")"});
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
                                       const std::string& file_label, const ImportOptions& options,
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
