#include "patient_db/case_import.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <regex>
#include <string>
#include <vector>

#include "patient_db/case_geometry.h"
#include "patient_db/case_import_internal.h"
#include "patient_db/case_problem.h"
#include "patient_db/case_regions.h"
#include "patient_db/case_validate.h"
#include "patient_db/limits.h"

namespace ves::patient_db::case_import {
namespace {

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

// What makes the points no case at all (no points, no radius, no regions,
// a coordinate that is not finite): every such problem at once.
void CheckImportable(const ImportedPoints& in, const std::string& file,
                     const ImportOptions& options) {
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
}

// The region spans of `c` (its centreline and radii made, arcs `arcs_m`):
// a run of equal names from its first point to the next run's first point.
void AddRegionSpans(const ImportedPoints& in, const ImportOptions& options,
                    const std::vector<double>& arcs_m, ves::v1::ColonCase& c) {
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
}

}  // namespace

ves::v1::ColonCase BuildCase(ImportedPoints in, const std::string& file,
                             const ImportOptions& options, const std::string& source) {
  CheckImportable(in, file, options);

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
  AddRegionSpans(in, options, arcs_m, c);
  const auto invalid = ValidateCase(c, file);
  if (!invalid.empty()) throw CaseError(InFileTerms(invalid, in, file_index, options, file));
  return c;
}

}  // namespace ves::patient_db::case_import

namespace ves::patient_db {

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

}  // namespace ves::patient_db
