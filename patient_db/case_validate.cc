#include "patient_db/case_validate.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <regex>
#include <unordered_map>
#include <vector>

#include "patient_db/case_geometry.h"
#include "patient_db/case_regions.h"
#include "patient_db/limits.h"

namespace ves::patient_db {
namespace {

using ves::v1::ColonCase;

std::string Num(double value) {
  char text[40];
  std::snprintf(text, sizeof(text), "%.9g", value);
  return text;
}

class Checker {
 public:
  explicit Checker(const std::string& file) : file_(file.empty() ? "<case>" : file) {}

  void Add(std::string field, int index, std::string value, std::string message) {
    problems_.push_back({file_, std::move(field), index, std::move(value), std::move(message)});
  }
  // Finite and within [lo, hi]; returns false (after reporting) otherwise.
  bool InRange(const std::string& field, int index, double value, double lo, double hi,
               const std::string& unit) {
    if (!std::isfinite(value)) {
      Add(field, index, Num(value), "not a finite number");
      return false;
    }
    if (value < lo || value > hi) {
      Add(field, index, Num(value), "out of range [" + Num(lo) + ", " + Num(hi) + "] " + unit);
      return false;
    }
    return true;
  }
  std::vector<CaseProblem> Take() { return std::move(problems_); }
  size_t count() const { return problems_.size(); }

 private:
  std::string file_;
  std::vector<CaseProblem> problems_;
};

void CheckHeader(const ColonCase& c, Checker& check) {
  static const std::regex kIdPattern("[a-z0-9-]+");
  if (!std::regex_match(c.id(), kIdPattern) || c.id().size() > 64) {
    check.Add("id", -1, "\"" + c.id() + "\"", "must match [a-z0-9-]+ (1 to 64 characters)");
  }
  if (c.title().empty()) check.Add("title", -1, "", "must not be empty");
  if (c.version() == 0) check.Add("version", -1, "0", "must be >= 1");
  if (!ves::v1::Difficulty_IsValid(c.difficulty())) {
    check.Add("difficulty", -1, std::to_string(c.difficulty()), "unknown Difficulty value");
  }
  const auto& p = c.provenance();
  if (p.year() != 0 && (p.year() < static_cast<unsigned>(kMinProvenanceYear) ||
                        p.year() > static_cast<unsigned>(kMaxProvenanceYear))) {
    check.Add("provenance.year", -1, std::to_string(p.year()),
              "must be 0 (unknown) or within " + std::to_string(kMinProvenanceYear) + ".." +
                  std::to_string(kMaxProvenanceYear));
  }
  const std::pair<const char*, const std::string*> texts[] = {
      {"title", &c.title()},
      {"description", &c.description()},
      {"provenance.source", &p.source()},
      {"provenance.institution", &p.institution()},
      {"provenance.notes", &p.notes()},
  };
  for (const auto& [field, text] : texts) {
    if (LooksLikeFineDate(*text)) {
      check.Add(field, -1, "\"" + *text + "\"",
                "looks like a date finer than a year (de-identified cases keep the year only)");
    }
  }
}

// Returns true when the centerline is usable for arc-length computations.
bool CheckCenterline(const ColonCase& c, Checker& check) {
  const auto& points = c.centerline();
  bool usable = true;
  if (points.size() < kMinControlPoints) {
    check.Add("centerline", -1, std::to_string(points.size()) + " points",
              "needs at least " + std::to_string(kMinControlPoints) + " control points");
    usable = points.size() >= 2;
  }
  if (points.size() > kMaxControlPoints) {
    // One problem, and nothing computed from them: the rest would only cost time.
    check.Add("centerline", -1, std::to_string(points.size()) + " points",
              "more than " + std::to_string(kMaxControlPoints) + " control points");
    return false;
  }
  for (int i = 0; i < points.size(); ++i) {
    const double xyz[3] = {points[i].x_m(), points[i].y_m(), points[i].z_m()};
    const char* names[3] = {"centerline.x_m", "centerline.y_m", "centerline.z_m"};
    for (int k = 0; k < 3; ++k) {
      if (!check.InRange(names[k], i, xyz[k], -kMaxCoordinate_m, kMaxCoordinate_m, "m")) {
        usable = false;
      }
    }
  }
  if (!usable) return false;
  const auto arcs_m = CalcControlPointArcs_m(c);
  for (int i = 1; i < points.size(); ++i) {
    const double step_m = arcs_m[i] - arcs_m[i - 1];
    if (step_m < kMinPointSpacing_m) {
      check.Add("centerline", i, Num(step_m) + " m from previous",
                "duplicate of control point " + std::to_string(i - 1) + " (closer than " +
                    Num(kMinPointSpacing_m) + " m)");
      usable = false;
    }
  }
  if (usable && arcs_m.back() > kMaxCenterlineLength_m) {
    check.Add("centerline", -1, Num(arcs_m.back()) + " m long",
              "longer than " + Num(kMaxCenterlineLength_m) + " m (a colon is 1.5 to 1.9 m)");
    usable = false;
  }
  return usable;
}

// Returns true when the profile can be interpolated.
bool CheckRadiusProfile(const ColonCase& c, double length_m, bool length_known,
                        Checker& check) {
  const auto& profile = c.radius_profile();
  if (profile.empty()) {
    check.Add("radius_profile", -1, "", "needs at least one radius sample");
    return false;
  }
  if (profile.size() > kMaxControlPoints) {
    check.Add("radius_profile", -1, std::to_string(profile.size()) + " samples",
              "more than " + std::to_string(kMaxControlPoints) + " radius samples");
    return false;
  }
  bool usable = true;
  for (int i = 0; i < profile.size(); ++i) {
    const double arc_hi = length_known ? length_m + kArcTolerance_m : 1e3;
    if (!check.InRange("radius_profile.arc_m", i, profile[i].arc_m(), 0.0, arc_hi, "m")) {
      usable = false;
    } else if (i > 0 && std::isfinite(profile[i - 1].arc_m()) &&
               profile[i].arc_m() <= profile[i - 1].arc_m()) {
      check.Add("radius_profile.arc_m", i, Num(profile[i].arc_m()),
                "not greater than the previous sample's " + Num(profile[i - 1].arc_m()) + " m");
      usable = false;
    }
    const double r = profile[i].radius_m();
    if (!std::isfinite(r)) {
      check.Add("radius_profile.radius_m", i, Num(r), "not a finite number");
      usable = false;
    } else if (r <= 0.0 || r > kMaxRadius_m) {
      check.Add("radius_profile.radius_m", i, Num(r),
                "must be > 0 and <= " + Num(kMaxRadius_m) + " m");
      usable = false;
    }
  }
  return usable;
}

double MinRadiusOver_m(const ColonCase& c, double start_m, double end_m) {
  double r_min = std::min(CalcRadiusAt_m(c, start_m), CalcRadiusAt_m(c, end_m));
  for (const auto& sample : c.radius_profile()) {
    if (sample.arc_m() > start_m && sample.arc_m() < end_m) r_min = std::min(r_min, sample.radius_m());
  }
  return r_min;
}

void CheckTissue(const ves::v1::TissueParams& t, int i, double min_radius_m, Checker& check) {
  const std::string f = "regions.tissue.";
  check.InRange(f + "suspension_stiffness_N_per_m2", i, t.suspension_stiffness_n_per_m2(), 0.0,
                kMaxSuspensionStiffness_N_per_m2, "N/m^2");
  check.InRange(f + "suspension_damping_N_s_per_m2", i, t.suspension_damping_n_s_per_m2(), 0.0,
                kMaxSuspensionDamping_N_s_per_m2, "N s/m^2");
  if (check.InRange(f + "wall_stiffness_N_per_m", i, t.wall_stiffness_n_per_m(), 0.0,
                    kMaxWallStiffness_N_per_m, "N/m") &&
      t.wall_stiffness_n_per_m() <= 0.0) {
    check.Add(f + "wall_stiffness_N_per_m", i, Num(t.wall_stiffness_n_per_m()), "must be > 0");
  }
  check.InRange(f + "wall_damping_N_s_per_m", i, t.wall_damping_n_s_per_m(), 0.0,
                kMaxWallDamping_N_s_per_m, "N s/m");
  const double L = t.deformation_threshold_m();
  if (!std::isfinite(L)) {
    check.Add(f + "deformation_threshold_m", i, Num(L), "not a finite number");
  } else if (L <= 0.0 || (min_radius_m > 0.0 && L >= min_radius_m)) {
    check.Add(f + "deformation_threshold_m", i, Num(L),
              "must be > 0 and < the region's smallest radius " + Num(min_radius_m) + " m");
  }
  const bool mu_s_ok =
      check.InRange(f + "static_friction", i, t.static_friction(), 0.0, kMaxFriction, "");
  const bool mu_d_ok =
      check.InRange(f + "dynamic_friction", i, t.dynamic_friction(), 0.0, kMaxFriction, "");
  if (mu_s_ok && mu_d_ok && t.dynamic_friction() > t.static_friction()) {
    check.Add(f + "dynamic_friction", i, Num(t.dynamic_friction()),
              "must not exceed static_friction " + Num(t.static_friction()));
  }
  check.InRange(f + "neighbor_tension_N", i, t.neighbor_tension_n(), 0.0, kMaxNeighborTension_N,
                "N");
  // The colon's mobility (0 and MOBILITY_DEFAULT: the region's defaults).
  if (!ves::v1::Mobility_IsValid(t.mobility())) {
    check.Add(f + "mobility", i, std::to_string(t.mobility()), "unknown Mobility");
  }
  check.InRange(f + "mesentery_length_m", i, t.mesentery_length_m(), 0.0, kMaxMesenteryLength_m,
                "m");
  check.InRange(f + "mesentery_stiffness_N_per_m2", i, t.mesentery_stiffness_n_per_m2(), 0.0,
                kMaxMesenteryStiffness_N_per_m2, "N/m^2");
  if (check.InRange(f + "pleat_limit", i, t.pleat_limit(), 0.0, 1.0, "") &&
      t.pleat_limit() != 0.0 && t.pleat_limit() < kMinPleatLimit) {
    check.Add(f + "pleat_limit", i, Num(t.pleat_limit()),
              "must be 0 (the region's default) or in [" + Num(kMinPleatLimit) + ", 1]");
  }
  if (t.has_gathered_reserve()) {
    check.InRange(f + "gathered_reserve", i, t.gathered_reserve(), 0.0, kMaxGatheredReserve, "");
  }
}

void CheckRegions(const ColonCase& c, double length_m, bool length_known, bool radius_usable,
                  Checker& check) {
  const auto& regions = c.regions();
  if (regions.empty()) {
    check.Add("regions", -1, "", "needs at least one region span");
    return;
  }
  if (regions.size() > kMaxRegionSpans) {
    check.Add("regions", -1, std::to_string(regions.size()) + " spans",
              "more than " + std::to_string(kMaxRegionSpans) + " region spans");
    return;
  }
  for (int i = 0; i < regions.size(); ++i) {
    const auto& span = regions[i];
    if (!ves::v1::Region_IsValid(span.region()) ||
        span.region() == ves::v1::REGION_UNSPECIFIED) {
      check.Add("regions.region", i, std::to_string(span.region()),
                "unknown or unspecified Region");
    }
    const bool start_ok = check.InRange("regions.start_arc_m", i, span.start_arc_m(),
                                        -kArcTolerance_m, 1e3, "m");
    const bool end_ok =
        check.InRange("regions.end_arc_m", i, span.end_arc_m(), -kArcTolerance_m, 1e3, "m");
    if (start_ok && end_ok && span.end_arc_m() <= span.start_arc_m()) {
      check.Add("regions.end_arc_m", i, Num(span.end_arc_m()),
                "not greater than start_arc_m " + Num(span.start_arc_m()));
    }
    if (i == 0 && start_ok && std::abs(span.start_arc_m()) > kArcTolerance_m) {
      check.Add("regions.start_arc_m", 0, Num(span.start_arc_m()),
                "the first region must start at 0 (the anus)");
    }
    if (i > 0 && start_ok && std::isfinite(regions[i - 1].end_arc_m())) {
      const double joint_m = span.start_arc_m() - regions[i - 1].end_arc_m();
      if (joint_m > kArcTolerance_m) {
        check.Add("regions.start_arc_m", i, Num(span.start_arc_m()),
                  "leaves a gap of " + Num(joint_m) + " m after region " + std::to_string(i - 1));
      } else if (joint_m < -kArcTolerance_m) {
        check.Add("regions.start_arc_m", i, Num(span.start_arc_m()),
                  "overlaps region " + std::to_string(i - 1) + " by " + Num(-joint_m) + " m");
      }
    }
    const int last = regions.size() - 1;
    if (i == last && end_ok && length_known &&
        std::abs(span.end_arc_m() - length_m) > kArcTolerance_m) {
      check.Add("regions.end_arc_m", last, Num(span.end_arc_m()),
                "the last region must end at the centerline length " + Num(length_m) + " m");
    }
    const double min_radius_m =
        radius_usable && start_ok && end_ok ? MinRadiusOver_m(c, span.start_arc_m(),
                                                              span.end_arc_m())
                                            : 0.0;
    CheckTissue(span.tissue(), i, min_radius_m, check);
  }
}

// CalcRadiusAt_m by bisection: the profile is strictly increasing here
// (CheckRadiusProfile passed), so the self-proximity test stays O(N log N).
double SortedRadiusAt_m(const ColonCase& c, double arc_m) {
  const auto& profile = c.radius_profile();
  if (profile.empty()) return 0.0;
  if (arc_m <= profile[0].arc_m()) return profile[0].radius_m();
  const auto it = std::partition_point(profile.begin() + 1, profile.end(),
                                       [&](const auto& s) { return s.arc_m() < arc_m; });
  if (it == profile.end()) return profile[profile.size() - 1].radius_m();
  const auto& a = *(it - 1);
  const auto& b = *it;
  const double span_m = b.arc_m() - a.arc_m();
  if (!(span_m > 0.0)) return b.radius_m();
  const double t = (arc_m - a.arc_m()) / span_m;
  return a.radius_m() + t * (b.radius_m() - a.radius_m());
}

struct Sample {
  double x, y, z, arc_m, radius_m;
  int control_index;
};

// Two parts of the tube, far apart along the colon, closer in space than the
// sum of their radii. "Far apart" is an arc separation above pi/2 (r_i + r_j):
// a bend whose radius is at least the lumen radius (the tightest bend a tube
// can make without folding its inner wall) never triggers it.
void CheckSelfProximity(const ColonCase& c, Checker& check) {
  const auto& points = c.centerline();
  const auto arcs_m = CalcControlPointArcs_m(c);
  std::vector<Sample> samples;
  for (int i = 0; i + 1 < points.size(); ++i) {
    const auto& a = points[i];
    const auto& b = points[i + 1];
    const int pieces = std::max(1, static_cast<int>(std::ceil((arcs_m[i + 1] - arcs_m[i]) /
                                                              kSelfProximityStep_m)));
    for (int k = 0; k < pieces; ++k) {
      const double t = static_cast<double>(k) / pieces;
      const double arc_m = arcs_m[i] + t * (arcs_m[i + 1] - arcs_m[i]);
      samples.push_back({a.x_m() + t * (b.x_m() - a.x_m()), a.y_m() + t * (b.y_m() - a.y_m()),
                         a.z_m() + t * (b.z_m() - a.z_m()), arc_m, SortedRadiusAt_m(c, arc_m), i});
    }
  }
  const auto& end = points[points.size() - 1];
  samples.push_back({end.x_m(), end.y_m(), end.z_m(), arcs_m.back(),
                     SortedRadiusAt_m(c, arcs_m.back()), static_cast<int>(points.size()) - 1});

  // Candidates from a uniform grid of cells no smaller than the largest sum
  // of radii: a pair closer than its sum of radii lies in the same or a
  // neighbouring cell, so each sample is compared with the samples near it
  // in space, not with all of them (the test grew quadratically: 15 s for a
  // 40k-point case).
  double max_radius_m = 0.0;
  for (const Sample& sample : samples) max_radius_m = std::max(max_radius_m, sample.radius_m);
  const double cell_m = std::max(2.0 * max_radius_m, 1e-3);
  auto cell_of = [&](double v) { return static_cast<int64_t>(std::floor(v / cell_m)); };
  auto key_of = [](int64_t cx, int64_t cy, int64_t cz) {
    // Coordinates are within +-kMaxCoordinate_m: a few thousand cells a side.
    return ((cx + (1 << 20)) << 42) | ((cy + (1 << 20)) << 21) | (cz + (1 << 20));
  };
  std::unordered_map<int64_t, std::vector<int>> cells;
  for (size_t i = 0; i < samples.size(); ++i) {
    cells[key_of(cell_of(samples[i].x), cell_of(samples[i].y), cell_of(samples[i].z))].push_back(
        static_cast<int>(i));
  }

  constexpr int kMaxReports = 20;
  int reports = 0;
  bool in_run = false;
  double worst_ratio = 0.0;
  int worst_i = -1, worst_j = -1;
  auto flush = [&]() {
    if (worst_i < 0) return;
    const Sample& si = samples[worst_i];
    const Sample& sj = samples[worst_j];
    const double d = std::hypot(si.x - sj.x, si.y - sj.y, si.z - sj.z);
    if (reports++ < kMaxReports) {
      check.Add("centerline", si.control_index, Num(d) + " m",
                "near arc " + Num(si.arc_m) + " m the centerline comes within " + Num(d) +
                    " m of itself at arc " + Num(sj.arc_m) + " m (control point " +
                    std::to_string(sj.control_index) + "), closer than the sum of radii " +
                    Num(si.radius_m + sj.radius_m) + " m");
    }
    worst_i = worst_j = -1;
  };
  for (size_t i = 0; i < samples.size(); ++i) {
    const Sample& si = samples[i];
    const int64_t cx = cell_of(si.x), cy = cell_of(si.y), cz = cell_of(si.z);
    bool violates = false;
    for (int64_t dx = -1; dx <= 1; ++dx) {
      for (int64_t dy = -1; dy <= 1; ++dy) {
        for (int64_t dz = -1; dz <= 1; ++dz) {
          const auto cell = cells.find(key_of(cx + dx, cy + dy, cz + dz));
          if (cell == cells.end()) continue;
          for (const int j : cell->second) {
            if (j <= static_cast<int>(i)) continue;
            const Sample& sj = samples[j];
            const double sum_m = si.radius_m + sj.radius_m;
            if (sj.arc_m - si.arc_m <= std::numbers::pi / 2.0 * sum_m) continue;
            const double d = std::hypot(si.x - sj.x, si.y - sj.y, si.z - sj.z);
            if (d >= sum_m) continue;
            violates = true;
            const double ratio = d / sum_m;
            // The closest pair of the run; on a tie the earlier sample.
            if (worst_i < 0 || ratio < worst_ratio ||
                (ratio == worst_ratio && worst_i == static_cast<int>(i) && j < worst_j)) {
              worst_ratio = ratio;
              worst_i = static_cast<int>(i);
              worst_j = j;
            }
          }
        }
      }
    }
    if (!violates && in_run) flush();
    in_run = violates;
  }
  flush();
}

void CheckTexture(const ColonCase& c, Checker& check) {
  if (!c.has_mucosa_texture()) return;
  const auto& tex = c.mucosa_texture();
  const std::string& image = tex.image();
  if (tex.media_type() == "image/png") {
    if (image.rfind("\x89PNG\r\n\x1a\n", 0) != 0) {
      check.Add("mucosa_texture.image", -1, std::to_string(image.size()) + " bytes",
                "media_type is image/png but the bytes are not a PNG");
    }
  } else if (tex.media_type() == "image/jpeg") {
    if (image.rfind("\xff\xd8\xff", 0) != 0) {
      check.Add("mucosa_texture.image", -1, std::to_string(image.size()) + " bytes",
                "media_type is image/jpeg but the bytes are not a JPEG");
    }
  } else {
    check.Add("mucosa_texture.media_type", -1, "\"" + tex.media_type() + "\"",
              "must be image/png or image/jpeg");
  }
}

}  // namespace

bool LooksLikeFineDate(const std::string& text) {
  if (text.empty()) return false;
  static const std::regex kPatterns[] = {
      // 2019-03, 2019/3/12, 2019.03.12
      std::regex(R"(\b(18|19|20|21)\d\d[-/.](0?[1-9]|1[0-2])\b)"),
      // 12/03/2019, 3-12-19
      std::regex(R"(\b\d{1,2}([-/.])\d{1,2}\1\d{2,4}\b)"),
      // 03/2019
      std::regex(R"(\b(0?[1-9]|1[0-2])[-/.](18|19|20|21)\d\d\b)"),
      // March 2019, Mar. 12, 2019
      std::regex(R"(\b(jan(uary)?|feb(ruary)?|mar(ch)?|apr(il)?|may|june?|july?|aug(ust)?|)"
                 R"(sep(t(ember)?)?|oct(ober)?|nov(ember)?|dec(ember)?)\.?\s+)"
                 R"((\d{1,2}(st|nd|rd|th)?,?\s+)?(18|19|20|21)\d\d\b)",
                 std::regex::icase),
      // 12 March, 3rd Mar
      std::regex(R"(\b\d{1,2}(st|nd|rd|th)?\s+(jan(uary)?|feb(ruary)?|mar(ch)?|apr(il)?|may|)"
                 R"(june?|july?|aug(ust)?|sep(t(ember)?)?|oct(ober)?|nov(ember)?|dec(ember)?)\b)",
                 std::regex::icase),
  };
  for (const auto& pattern : kPatterns) {
    if (std::regex_search(text, pattern)) return true;
  }
  return false;
}

std::vector<CaseProblem> ValidateCase(const ColonCase& colon_case, const std::string& file_label) {
  Checker check(file_label);
  // Text that is not UTF-8 (a textproto "\xff" escape), control characters in
  // a title, an over-long note: what every other reader of the case (the
  // bundle's protobuf parser, a terminal) would trip on.
  bool over = false;
  const LimitProblem limit = FindLimitProblem(colon_case, "case", &over);
  // (Counts of points, samples and regions have their own rules below.)
  if (over && limit.is_text) {
    check.Add(limit.path.substr(5), -1, "\"" + limit.excerpt + "\"", limit.why);
  }
  CheckHeader(colon_case, check);
  const bool centerline_usable = CheckCenterline(colon_case, check);
  const double length_m = centerline_usable ? CalcCenterlineLength_m(colon_case) : 0.0;
  const bool radius_usable =
      CheckRadiusProfile(colon_case, length_m, centerline_usable, check);
  CheckRegions(colon_case, length_m, centerline_usable, radius_usable, check);
  if (centerline_usable && radius_usable) CheckSelfProximity(colon_case, check);
  CheckTexture(colon_case, check);
  return check.Take();
}

void CheckCase(const ColonCase& colon_case, const std::string& file_label) {
  auto problems = ValidateCase(colon_case, file_label);
  if (!problems.empty()) throw CaseError(std::move(problems));
}

}  // namespace ves::patient_db
