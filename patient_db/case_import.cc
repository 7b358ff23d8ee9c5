#include "patient_db/case_import.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
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

std::string Num(double value) {
  char text[40];
  std::snprintf(text, sizeof text, "%.9g", value);
  return text;
}

std::vector<double> PolylineArcs(const std::vector<std::array<double, 3>>& points) {
  std::vector<double> arcs(points.size(), 0.0);
  for (size_t i = 1; i < points.size(); ++i) {
    arcs[i] =
        arcs[i - 1] + std::hypot(points[i][0] - points[i - 1][0], points[i][1] - points[i - 1][1],
                                 points[i][2] - points[i - 1][2]);
  }
  return arcs;
}

// The file's name for its point `i` (in file order): "line 12" in a CSV,
// "point CL-41" (its label) in a markups file.
std::string PointName(const ImportedPoints& in, size_t i) {
  if (i < in.lines.size()) return "line " + std::to_string(in.lines[i]);
  if (i < in.labels.size()) return "point " + in.labels[i];
  return "point " + std::to_string(i + 1);
}

// A problem at the file's point `i`: the CSV's field and line, or the
// markups point's label.
CaseProblem AtPoint(const ImportedPoints& in, const std::string& file, size_t i,
                    const std::string& what, std::string value, std::string message) {
  if (i < in.lines.size()) {
    return {file, "csv" + (what.empty() ? "" : "." + what), in.lines[i], std::move(value),
            std::move(message)};
  }
  return {file, PointName(in, i) + (what.empty() ? "" : " " + what), -1, std::move(value),
          std::move(message)};
}

// The validation problems of the built case in the file's terms: its point
// names (case point k is the file's point file_index[k]), its units.
std::vector<CaseProblem> InFileTerms(const std::vector<CaseProblem>& problems,
                                     const ImportedPoints& in,
                                     const std::vector<size_t>& file_index,
                                     const ImportOptions& options, const std::string& file) {
  static const std::regex kCrossing(
      R"(near arc (\S+) m the centerline comes within (\S+) m of itself at arc (\S+) m )"
      R"(\(control point (\d+)\), closer than the sum of radii (\S+) m)");
  const double u = in.units_per_m;
  const std::string& unit = in.length_unit;
  // A length the case states in metres, in the file's unit to a tenth.
  const auto in_units = [&](const std::string& metres) {
    return Num(std::round(std::strtod(metres.c_str(), nullptr) * u * 10.0) / 10.0) + " " + unit;
  };
  const auto point_of = [&](int case_index) {
    return case_index >= 0 && static_cast<size_t>(case_index) < file_index.size()
               ? file_index[case_index]
               : static_cast<size_t>(0);
  };
  bool duplicates = false;
  bool constant_radius_said = false;
  std::vector<CaseProblem> out;
  for (const auto& problem : problems) {
    const size_t i = point_of(problem.index);
    if (problem.field == "radius_profile.radius_m" && problem.index >= 0) {
      const double r_m = std::strtod(problem.value.c_str(), nullptr);
      if (options.radius_mm) {
        if (!constant_radius_said) {
          out.push_back({file, "--radius-mm", -1, Num(*options.radius_mm),
                         "must be > 0 and <= " + Num(kMaxRadius_m * 1000.0) + " mm"});
        }
        constant_radius_said = true;
        continue;
      }
      const std::string limit =
          "must be > 0 and <= " + Num(kMaxRadius_m * in.radius_units_per_m) + " " + in.radius_unit;
      const std::string value = Num(r_m * in.radius_units_per_m);
      if (i < in.radius_lines.size()) {
        // A CSV's radius_mm column or a sidecar's: its line; a sidecar also
        // names the curve's point.
        out.push_back({in.radius_file, in.radius_field, in.radius_lines[i], value,
                       limit + (in.lines.empty() ? " (" + PointName(in, i) + ")" : "")});
      } else {
        out.push_back(AtPoint(in, file, i, "radius", value + " " + in.radius_unit,
                              limit + " (" + in.radius_field + ")"));
      }
    } else if (problem.field == "centerline" && problem.index > 0 &&
               problem.message.rfind("duplicate", 0) == 0) {
      duplicates = true;
      const size_t previous = point_of(problem.index - 1);
      const double step_m = std::strtod(problem.value.c_str(), nullptr);
      out.push_back(AtPoint(in, file, i, "",
                            Num(step_m * u) + " " + unit + " from " + PointName(in, previous),
                            "a duplicate of " + PointName(in, previous) + " (closer than " +
                                Num(kMinPointSpacing_m * u) + " " + unit + ")"));
    } else if (problem.field == "centerline" && problem.index >= 0 &&
               std::regex_search(problem.message, kCrossing)) {
      std::smatch m;
      std::regex_search(problem.message, m, kCrossing);
      const size_t other = point_of(std::stoi(m[4].str()));
      out.push_back(AtPoint(in, file, i, "", in_units(m[2].str()),
                            in_units(m[1].str()) +
                                " along the centreline from the anus it comes within " +
                                in_units(m[2].str()) + " of itself at " + in_units(m[3].str()) +
                                " (" + PointName(in, other) + "), closer than the sum of radii " +
                                in_units(m[5].str()) + ": the tube would cross itself"));
    } else if (problem.field.rfind("centerline.", 0) == 0 && problem.index >= 0) {
      const std::string axis = problem.field.substr(11, 1);  // x, y or z
      out.push_back(AtPoint(in, file, i, in.lines.empty() ? "position" : axis + "_mm",
                            axis + " " + in_units(problem.value) + " from the anus end",
                            "more than " + Num(kMaxCoordinate_m * u) + " " + unit +
                                " from the anus end of the centreline"));
    } else if (problem.field == "radius_profile.arc_m" && duplicates) {
      // Said above as a duplicate point.
    } else if (problem.field == "centerline") {
      out.push_back({file, in.lines.empty() ? "markups[0].controlPoints" : "csv", -1, problem.value,
                     problem.message});
    } else {
      out.push_back(problem);
    }
  }
  return out;
}

// +1: the sequence of regions along the file runs rectum to cecum (the
// enum's order), -1: cecum to rectum, 0: cannot tell (one region).
int RegionOrderVote(const std::vector<ves::v1::Region>& sequence) {
  int up = 0;
  int down = 0;
  for (size_t i = 1; i < sequence.size(); ++i) {
    if (sequence[i] > sequence[i - 1]) ++up;
    if (sequence[i] < sequence[i - 1]) ++down;
  }
  return up > down ? 1 : down > up ? -1 : 0;
}

// A centreline at least this long runs from the anus into the right colon
// (the transverse colon starts about 0.8 m in): its deep end is the cecum.
constexpr double kMinWholeColonLength_m = 1.0;

// Which end of the file's centreline is the anus. The regions decide when
// the file names them; otherwise the lumen (the anal canal is the narrowest,
// the cecum the widest) and the height (the anus is the colon's lowest end).
// Returns +1 (the first point), -1 (the last) or throws when the lumen and
// the height disagree.
int AnusEnd(const ImportedPoints& in, const ImportOptions& options, const std::string& file,
            std::string* reason) {
  std::vector<ves::v1::Region> sequence;
  if (!in.landmarks.empty()) {
    const auto arcs_m = PolylineArcs(in.p_W_m);
    std::vector<std::pair<double, ves::v1::Region>> along;
    for (const auto& landmark : in.landmarks) {
      along.emplace_back(ProjectOntoPolyline(in.p_W_m, arcs_m, landmark.p_W_m), landmark.region);
    }
    std::stable_sort(along.begin(), along.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [arc, region] : along) sequence.push_back(region);
  } else {
    for (const auto region : in.regions) {
      if (sequence.empty() || sequence.back() != region) sequence.push_back(region);
    }
  }
  const int by_regions = RegionOrderVote(sequence);
  if (by_regions != 0) {
    *reason = "its regions run from " + RegionName(sequence.front()) + " to " +
              RegionName(sequence.back());
    return by_regions;
  }
  // The lumen: mean radius over 5 cm at either end, on a centreline long
  // enough to reach the cecum (on a shorter piece the rectal ampulla may be
  // the widest).
  int by_radius = 0;
  std::string radius_said;
  const auto arcs_m = PolylineArcs(in.p_W_m);
  if (!options.radius_mm && in.radius_m.size() == in.p_W_m.size() &&
      arcs_m.back() >= kMinWholeColonLength_m) {
    constexpr double kEnd_m = 0.05;
    double start_sum = 0.0, end_sum = 0.0;
    int start_n = 0, end_n = 0;
    for (size_t i = 0; i < arcs_m.size(); ++i) {
      if (arcs_m[i] <= kEnd_m) start_sum += in.radius_m[i], ++start_n;
      if (arcs_m.back() - arcs_m[i] <= kEnd_m) end_sum += in.radius_m[i], ++end_n;
    }
    const double start_r = start_sum / start_n;
    const double end_r = end_sum / end_n;
    constexpr double kRatio = 1.2;
    by_radius = end_r > kRatio * start_r ? 1 : start_r > kRatio * end_r ? -1 : 0;
    radius_said = "the lumen is " + Num(std::round(start_r * in.radius_units_per_m * 10) / 10) +
                  " " + in.radius_unit + " in radius at its start and " +
                  Num(std::round(end_r * in.radius_units_per_m * 10) / 10) + " " + in.radius_unit +
                  " at its end (the anal canal is the narrowest, the cecum the "
                  "widest)";
  }
  // The height: +z is cranial in W.
  constexpr double kHeight_m = 0.03;
  const double rise_m = in.p_W_m.back()[2] - in.p_W_m.front()[2];
  const int by_height = rise_m > kHeight_m ? 1 : rise_m < -kHeight_m ? -1 : 0;
  const std::string height_said = "its start lies " +
                                  Num(std::round(std::abs(rise_m) * in.units_per_m)) + " " +
                                  in.length_unit + (rise_m >= 0 ? " below" : " above") +
                                  " its end (the anus is the colon's lowest end)";
  if (by_radius * by_height < 0) {
    throw CaseError(file, in.lines.empty() ? "markups[0].controlPoints" : "csv", -1, "",
                    "cannot tell which end is the anus: " + radius_said + ", but " + height_said +
                        "; name the regions (a region column, or region "
                        "landmarks) so the rectum is known");
  }
  if (by_radius + by_height < 0) {
    *reason = by_radius < 0 && by_height < 0 ? radius_said + ", and " + height_said
              : by_radius < 0                ? radius_said
                                             : height_said;
    return -1;
  }
  return 1;
}

ves::v1::ColonCase BuildCase(ImportedPoints in, const std::string& file,
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

  // The anus end first: a centreline exported cecum first is reversed.
  std::vector<size_t> file_index(in.p_W_m.size());
  for (size_t i = 0; i < file_index.size(); ++i) file_index[i] = i;
  std::string reversed_because;
  const bool reversed = in.p_W_m.size() >= 2 && AnusEnd(in, options, file, &reversed_because) < 0;
  if (reversed) {
    std::reverse(in.p_W_m.begin(), in.p_W_m.end());
    std::reverse(in.radius_m.begin(), in.radius_m.end());
    std::reverse(in.regions.begin(), in.regions.end());
    std::reverse(file_index.begin(), file_index.end());
  }
  const CaseProblem reversal{file, in.lines.empty() ? "markups[0].controlPoints" : "csv", -1, "",
                             "runs cecum first (" + reversed_because +
                                 "): reversed, so the anus is " +
                                 PointName(in, file_index.front()) + " and the deepest point " +
                                 PointName(in, file_index.back())};
  // Said before anything else can refuse the file: both are worth knowing.
  if (reversed && options.warnings) options.warnings->push_back(reversal);

  // One region over a whole colon makes all of it that region (a 1.6 m
  // mobile "sigmoid"): refused, with what to give instead.
  const double file_length_m = PolylineArcs(in.p_W_m).back();
  if (in.regions.empty() && in.landmarks.empty() &&
      file_length_m > MaxPlausibleRegionLength_m(*options.region)) {
    const std::string name = RegionName(*options.region);
    throw CaseError(file, "--region", -1, name,
                    "the centreline is " + Num(std::round(file_length_m * in.units_per_m)) + " " +
                        in.length_unit + " long, longer than any " + name + " (at most " +
                        Num(MaxPlausibleRegionLength_m(*options.region) * in.units_per_m) + " " +
                        in.length_unit +
                        "): it spans several regions; name them with a region "
                        "column or region landmarks (docs/case-format.md)");
  }

  ves::v1::ColonCase c;
  const std::string name = std::filesystem::path(file).filename().string();
  c.set_id(options.id.empty() ? CaseIdFromFileName(name) : options.id);
  c.set_title(options.title.empty() ? "Imported centerline " + name : options.title);
  c.set_version(1);
  c.mutable_provenance()->set_source(source);
  if (reversed) {
    c.mutable_provenance()->set_notes("Reversed on import: the file " + reversal.message + ".");
  }
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
  const auto invalid = ValidateCase(c, file);
  if (!invalid.empty()) throw CaseError(InFileTerms(invalid, in, file_index, options, file));
  return c;
}

// Reads optional radius/region columns of `table` into `out`.
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

}  // namespace

double MaxPlausibleRegionLength_m(ves::v1::Region region) {
  // Above the longest reported (sigmoid 67.8 cm, Alatise et al. 2013) and the
  // generator's ranges (docs/case-generator.md), with room to spare.
  switch (region) {
    case ves::v1::REGION_SIGMOID:
    case ves::v1::REGION_TRANSVERSE:
      return 0.90;
    case ves::v1::REGION_DESCENDING:
      return 0.40;
    case ves::v1::REGION_ASCENDING:
      return 0.30;
    case ves::v1::REGION_RECTUM:
    case ves::v1::REGION_SPLENIC_FLEXURE:
    case ves::v1::REGION_HEPATIC_FLEXURE:
      return 0.20;
    case ves::v1::REGION_CECUM:
      return 0.15;
    default:
      return 0.0;
  }
}

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
    in.lines.push_back(row.line);
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
