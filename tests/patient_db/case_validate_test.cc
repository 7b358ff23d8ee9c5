// Every validation rule of docs/case-format.md, each with a broken file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "patient_db/case_format.h"
#include "tests/patient_db/case_test_util.h"

namespace ves::patient_db {
namespace {

using testing::HasProblem;
using testing::MakeValidCase;
using testing::ProblemsOfBrokenFile;
using testing::ScratchDir;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(CaseValidate, ValidCaseHasNoProblems) {
  EXPECT_TRUE(ValidateCase(MakeValidCase(), "unit").empty())
      << JoinProblems(ValidateCase(MakeValidCase(), "unit"));
}

TEST(CaseValidate, ProblemNamesFileFieldIndexAndValue) {
  ScratchDir dir;
  auto c = MakeValidCase();
  c.mutable_centerline(3)->set_y_m(kNaN);
  const auto problems = ProblemsOfBrokenFile(dir, c);
  ASSERT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_EQ(problems[0].file, (dir / "broken.textproto").string());
  EXPECT_EQ(problems[0].field, "centerline.y_m");
  EXPECT_EQ(problems[0].index, 3);
  EXPECT_EQ(problems[0].value, "nan");
  EXPECT_NE(problems[0].ToString().find("centerline.y_m[3] = nan"), std::string::npos)
      << problems[0].ToString();
}

TEST(CaseValidate, NonFiniteNumbersAnywhereAreRejected) {
  ScratchDir dir;
  auto c = MakeValidCase();
  c.mutable_centerline(1)->set_x_m(kInf);
  c.mutable_radius_profile(0)->set_arc_m(kNaN);
  c.mutable_regions(1)->set_end_arc_m(kInf);
  c.mutable_regions(0)->mutable_tissue()->set_static_friction(kNaN);
  c.mutable_regions(1)->mutable_tissue()->set_suspension_damping_n_s_per_m2(-kInf);
  const auto problems = ProblemsOfBrokenFile(dir, c);
  EXPECT_TRUE(HasProblem(problems, "centerline.x_m", 1)) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "radius_profile.arc_m", 0)) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "regions.end_arc_m", 1)) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "regions.tissue.static_friction", 0));
  EXPECT_TRUE(HasProblem(problems, "regions.tissue.suspension_damping_N_s_per_m2", 1));
}

TEST(CaseValidate, RadiusMustBePositiveAndAnatomical) {
  ScratchDir dir;
  auto c = MakeValidCase();
  c.mutable_radius_profile(0)->set_radius_m(0.0);
  auto* beyond = c.add_radius_profile();
  beyond->set_arc_m(0.1);
  beyond->set_radius_m(0.0605);  // just over the 60 mm limit
  auto* fine = c.add_radius_profile();
  fine->set_arc_m(0.15);
  fine->set_radius_m(0.060);  // the limit itself is allowed
  const auto problems = ProblemsOfBrokenFile(dir, c);
  EXPECT_TRUE(HasProblem(problems, "radius_profile.radius_m", 0)) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "radius_profile.radius_m", 1)) << JoinProblems(problems);
  EXPECT_FALSE(HasProblem(problems, "radius_profile.radius_m", 2)) << JoinProblems(problems);
}

TEST(CaseValidate, RadiusProfileMustIncreaseInArcAndStayOnTheCenterline) {
  ScratchDir dir;
  auto c = MakeValidCase();
  auto* same = c.add_radius_profile();
  same->set_arc_m(0.0);  // not greater than the previous sample
  same->set_radius_m(0.02);
  auto* past_end = c.add_radius_profile();
  past_end->set_arc_m(0.5);  // the centerline is 0.18 m long
  past_end->set_radius_m(0.02);
  const auto problems = ProblemsOfBrokenFile(dir, c);
  EXPECT_TRUE(HasProblem(problems, "radius_profile.arc_m", 1)) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "radius_profile.arc_m", 2)) << JoinProblems(problems);
}

TEST(CaseValidate, FewerThanFourControlPointsRejected) {
  ScratchDir dir;
  auto c = MakeValidCase();
  c.mutable_centerline()->DeleteSubrange(3, 7);
  c.mutable_regions(0)->set_end_arc_m(0.02);
  c.mutable_regions(1)->set_start_arc_m(0.02);
  c.mutable_regions(1)->set_end_arc_m(0.04);
  const auto problems = ProblemsOfBrokenFile(dir, c);
  ASSERT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_EQ(problems[0].field, "centerline");
  EXPECT_EQ(problems[0].value, "3 points");
}

TEST(CaseValidate, ConsecutiveDuplicatePointRejected) {
  ScratchDir dir;
  auto c = MakeValidCase();
  // Point 5 (z = 0.10) moved onto point 4 (z = 0.08); the length stays 0.18 m,
  // so the duplicate is the only problem.
  *c.mutable_centerline(5) = c.centerline(4);
  const auto problems = ProblemsOfBrokenFile(dir, c);
  ASSERT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "centerline", 5)) << JoinProblems(problems);
}

// A U: up x = 0 from z = 0 to 0.2, across to x = gap, down to z = 0; radius 2 cm.
ves::v1::ColonCase MakeUTurn(double gap_m) {
  auto c = MakeValidCase();
  c.clear_centerline();
  auto add = [&](double x, double z) {
    auto* p = c.add_centerline();
    p->set_x_m(x);
    p->set_z_m(z);
  };
  for (int i = 0; i <= 10; ++i) add(0.0, 0.02 * i);
  add(gap_m / 2, 0.2 + gap_m / 2);
  for (int i = 10; i >= 0; --i) add(gap_m, 0.02 * i);
  const double length_m = CalcCenterlineLength_m(c);
  c.mutable_regions(0)->set_end_arc_m(length_m / 2);
  c.mutable_regions(1)->set_start_arc_m(length_m / 2);
  c.mutable_regions(1)->set_end_arc_m(length_m);
  return c;
}

TEST(CaseValidate, UTurnWithLegsFartherThanSumOfRadiiIsValid) {
  // Legs 5 cm apart, radii 2 + 2 cm: the lumens do not touch.
  const auto c = MakeUTurn(0.05);
  EXPECT_TRUE(ValidateCase(c, "u").empty()) << JoinProblems(ValidateCase(c, "u"));
}

TEST(CaseValidate, CenterlineCloserToItselfThanSumOfRadiiRejected) {
  // Legs 3 cm apart, radii 2 + 2 cm: the lumens overlap along both legs.
  ScratchDir dir;
  const auto problems = ProblemsOfBrokenFile(dir, MakeUTurn(0.03));
  ASSERT_TRUE(HasProblem(problems, "centerline")) << JoinProblems(problems);
  // One report per touching stretch, not one per sample pair.
  EXPECT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_NE(problems[0].message.find("sum of radii 0.04"), std::string::npos)
      << problems[0].message;
}

// A colon of `points` control points on a helix along z (radius `helix_m`,
// `pitch_m` per turn), lumen radius 2 cm, one region over its length.
ves::v1::ColonCase MakeHelix(int points, double step_rad, double helix_m, double pitch_m) {
  auto c = MakeValidCase();
  c.clear_centerline();
  for (int i = 0; i < points; ++i) {
    const double a = step_rad * i;
    auto* p = c.add_centerline();
    p->set_x_m(helix_m * std::cos(a) - helix_m);
    p->set_y_m(helix_m * std::sin(a));
    p->set_z_m(pitch_m * a / (2 * std::numbers::pi));
  }
  const double length_m = CalcCenterlineLength_m(c);
  c.clear_regions();
  auto* span = c.add_regions();
  span->set_region(ves::v1::REGION_SIGMOID);
  span->set_end_arc_m(length_m);
  *span->mutable_tissue() = DefaultTissue(ves::v1::REGION_SIGMOID);
  c.mutable_radius_profile(0)->set_arc_m(0.0);
  while (c.radius_profile_size() > 1) c.mutable_radius_profile()->RemoveLast();
  return c;
}

// The self-crossing rule as it was first written: every pair of 5 mm samples.
// The grid must find exactly the same stretches and closest pairs.
std::vector<std::string> QuadraticSelfProximity(const ves::v1::ColonCase& c) {
  struct S {
    double x, y, z, arc, r;
    int control;
  };
  const auto arcs = CalcControlPointArcs_m(c);
  std::vector<S> s;
  for (int i = 0; i + 1 < c.centerline_size(); ++i) {
    const auto& a = c.centerline(i);
    const auto& b = c.centerline(i + 1);
    const int pieces = std::max(1, static_cast<int>(std::ceil((arcs[i + 1] - arcs[i]) / 0.005)));
    for (int k = 0; k < pieces; ++k) {
      const double t = static_cast<double>(k) / pieces;
      const double arc = arcs[i] + t * (arcs[i + 1] - arcs[i]);
      s.push_back({a.x_m() + t * (b.x_m() - a.x_m()), a.y_m() + t * (b.y_m() - a.y_m()),
                   a.z_m() + t * (b.z_m() - a.z_m()), arc, CalcRadiusAt_m(c, arc), i});
    }
  }
  const auto& e = c.centerline(c.centerline_size() - 1);
  s.push_back({e.x_m(), e.y_m(), e.z_m(), arcs.back(), CalcRadiusAt_m(c, arcs.back()),
               c.centerline_size() - 1});
  std::vector<std::string> runs;
  bool in_run = false;
  int wi = -1, wj = -1;
  double worst = 0;
  for (size_t i = 0; i < s.size(); ++i) {
    bool violates = false;
    for (size_t j = i + 1; j < s.size(); ++j) {
      const double sum = s[i].r + s[j].r;
      if (s[j].arc - s[i].arc <= std::numbers::pi / 2 * sum) continue;
      const double d = std::hypot(s[i].x - s[j].x, s[i].y - s[j].y, s[i].z - s[j].z);
      if (d >= sum) continue;
      violates = true;
      if (wi < 0 || d / sum < worst) {
        worst = d / sum;
        wi = static_cast<int>(i);
        wj = static_cast<int>(j);
      }
    }
    if (!violates && in_run && wi >= 0) {
      runs.push_back(std::to_string(s[wi].control) + "/" + std::to_string(s[wj].control));
      wi = wj = -1;
    }
    in_run = violates;
  }
  if (wi >= 0) runs.push_back(std::to_string(s[wi].control) + "/" + std::to_string(s[wj].control));
  return runs;
}

TEST(CaseValidate, SelfProximityOnAGridFindsWhatEveryPairFinds) {
  // Helices whose turns come closer than the lumen (pitch 3 cm < 4 cm) or not.
  for (const auto& [pitch_m, helix_m] : {std::pair{0.03, 0.05}, std::pair{0.06, 0.05},
                                         std::pair{0.035, 0.02}, std::pair{0.02, 0.08}}) {
    const auto c = MakeHelix(100, 0.3, helix_m, pitch_m);
    std::vector<std::string> found;
    for (const auto& p : ValidateCase(c, "helix")) {
      ASSERT_EQ(p.field, "centerline") << p.ToString();
      const size_t at = p.message.find("(control point ");
      ASSERT_NE(at, std::string::npos) << p.ToString();
      found.push_back(std::to_string(p.index) + "/" +
                      std::to_string(std::stoi(p.message.substr(at + 15))));
    }
    const auto expected = QuadraticSelfProximity(c);
    const size_t reported = std::min<size_t>(20, expected.size());  // the first 20 are named
    EXPECT_EQ(found, std::vector<std::string>(expected.begin(), expected.begin() + reported))
        << "pitch " << pitch_m << " helix " << helix_m;
    if (pitch_m < 0.04) {
      EXPECT_FALSE(expected.empty());
    }
  }
}

// Found by probing (issue #20): a 40 m colon of 40,000 points passed, and the
// crossing test took 15 s on it. A case is at most 5000 points and 3 m now,
// each said in one problem.
TEST(CaseValidate, TooManyPointsOrTooLongIsOneProblem) {
  auto many = MakeHelix(40000, 0.001, 0.05, 0.5);
  auto problems = ValidateCase(many, "big");
  ASSERT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_EQ(problems[0].ToString(),
            "big: centerline = 40000 points: more than 5000 control points");
  auto long_one = MakeHelix(200, 0.1, 0.3, 0.1);  // 6 m coiled within 0.6 m
  problems = ValidateCase(long_one, "long");
  ASSERT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_NE(problems[0].message.find("longer than 3 m"), std::string::npos) << problems[0].message;
}

// Found by fuzzing (tests/fuzz/regressions/textproto): text format escapes
// can put bytes that are not UTF-8 in a string; such a case passed validation
// and then could not be read back from its own bundle.
TEST(CaseValidate, TextThatIsNotUtf8OrHasControlCharactersIsRejected) {
  auto c = MakeValidCase();
  c.mutable_provenance()->set_notes("scanned \xff\xfe");
  auto problems = ValidateCase(c, "x");
  ASSERT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_EQ(problems[0].ToString(),
            "x: provenance.notes = \"scanned \\xff\\xfe\": not valid UTF-8 (byte 8)");
  c = MakeValidCase();
  c.set_title("red \x1b[31m");
  problems = ValidateCase(c, "x");
  ASSERT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_NE(problems[0].message.find("control character U+001B"), std::string::npos);
}

TEST(CaseValidate, RegionsOverlappingRejected) {
  ScratchDir dir;
  auto c = MakeValidCase();
  c.mutable_regions(1)->set_start_arc_m(0.08);  // rectum ends at 0.09
  const auto problems = ProblemsOfBrokenFile(dir, c);
  ASSERT_TRUE(HasProblem(problems, "regions.start_arc_m", 1)) << JoinProblems(problems);
  EXPECT_NE(problems[0].message.find("overlaps"), std::string::npos) << problems[0].message;
}

TEST(CaseValidate, RegionsLeavingGapRejected) {
  ScratchDir dir;
  auto c = MakeValidCase();
  c.mutable_regions(1)->set_start_arc_m(0.1);
  const auto problems = ProblemsOfBrokenFile(dir, c);
  ASSERT_TRUE(HasProblem(problems, "regions.start_arc_m", 1)) << JoinProblems(problems);
  EXPECT_NE(problems[0].message.find("gap"), std::string::npos) << problems[0].message;
}

TEST(CaseValidate, RegionJointWithinToleranceAccepted) {
  auto c = MakeValidCase();
  c.mutable_regions(1)->set_start_arc_m(0.09 + 0.5 * kArcTolerance_m);
  EXPECT_TRUE(ValidateCase(c, "unit").empty()) << JoinProblems(ValidateCase(c, "unit"));
}

TEST(CaseValidate, RegionsMustStartAtZeroAndEndAtTheLength) {
  ScratchDir dir;
  auto c = MakeValidCase();
  c.mutable_regions(0)->set_start_arc_m(0.01);
  c.mutable_regions(1)->set_end_arc_m(0.17);
  const auto problems = ProblemsOfBrokenFile(dir, c);
  EXPECT_TRUE(HasProblem(problems, "regions.start_arc_m", 0)) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "regions.end_arc_m", 1)) << JoinProblems(problems);
}

TEST(CaseValidate, UnknownOrUnspecifiedRegionRejected) {
  ScratchDir dir;
  auto c = MakeValidCase();
  c.mutable_regions(0)->set_region(ves::v1::REGION_UNSPECIFIED);
  c.mutable_regions(1)->set_region(static_cast<ves::v1::Region>(42));
  EXPECT_TRUE(HasProblem(ValidateCase(c, "unit"), "regions.region", 1));
  const auto problems = ProblemsOfBrokenFile(dir, c);
  EXPECT_TRUE(HasProblem(problems, "regions.region", 0)) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "regions.region", 1)) << JoinProblems(problems);
}

TEST(CaseValidate, TissueParametersOutOfPhysicalRangeRejected) {
  ScratchDir dir;
  auto c = MakeValidCase();
  auto* t0 = c.mutable_regions(0)->mutable_tissue();
  t0->set_suspension_stiffness_n_per_m2(-1.0);
  t0->set_wall_stiffness_n_per_m(0.0);
  t0->set_dynamic_friction(0.3);  // above static_friction 0.25
  t0->set_neighbor_tension_n(-2.0);
  auto* t1 = c.mutable_regions(1)->mutable_tissue();
  t1->set_static_friction(2.5);
  t1->set_deformation_threshold_m(0.02);  // not below the 0.02 m radius
  t1->set_wall_damping_n_s_per_m(-4.0);
  const auto problems = ProblemsOfBrokenFile(dir, c);
  const std::string f = "regions.tissue.";
  EXPECT_TRUE(HasProblem(problems, f + "suspension_stiffness_N_per_m2", 0)) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, f + "wall_stiffness_N_per_m", 0));
  EXPECT_TRUE(HasProblem(problems, f + "dynamic_friction", 0));
  EXPECT_TRUE(HasProblem(problems, f + "neighbor_tension_N", 0));
  EXPECT_TRUE(HasProblem(problems, f + "static_friction", 1));
  EXPECT_TRUE(HasProblem(problems, f + "deformation_threshold_m", 1));
  EXPECT_TRUE(HasProblem(problems, f + "wall_damping_N_s_per_m", 1));
  EXPECT_EQ(problems.size(), 7u) << JoinProblems(problems);
}

TEST(CaseValidate, ZeroDeformationThresholdRejected) {
  auto c = MakeValidCase();
  c.mutable_regions(0)->mutable_tissue()->set_deformation_threshold_m(0.0);
  EXPECT_TRUE(HasProblem(ValidateCase(c, "unit"), "regions.tissue.deformation_threshold_m", 0));
}

TEST(CaseValidate, IdVersionAndTitleChecked) {
  ScratchDir dir;
  auto c = MakeValidCase();
  c.set_id("Bad_ID");
  c.set_version(0);
  c.set_title("");
  const auto problems = ProblemsOfBrokenFile(dir, c);
  EXPECT_TRUE(HasProblem(problems, "id", -1)) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "version", -1)) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "title", -1)) << JoinProblems(problems);
}

TEST(CaseValidate, ProvenanceKeepsOnlyTheYear) {
  ScratchDir dir;
  auto c = MakeValidCase();
  c.mutable_provenance()->set_year(1850);
  c.mutable_provenance()->set_notes("scanned 2019-03-04");
  c.set_description("acquired March 2019");
  const auto problems = ProblemsOfBrokenFile(dir, c);
  EXPECT_TRUE(HasProblem(problems, "provenance.year")) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "provenance.notes")) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "description")) << JoinProblems(problems);
}

TEST(CaseValidate, DateDetectorFlagsDaysAndMonthsNotYears) {
  EXPECT_TRUE(LooksLikeFineDate("2019-03"));
  EXPECT_TRUE(LooksLikeFineDate("on 2019-03-04"));
  EXPECT_TRUE(LooksLikeFineDate("12/03/2019"));
  EXPECT_TRUE(LooksLikeFineDate("03/2019"));
  EXPECT_TRUE(LooksLikeFineDate("Mar. 12, 2019"));
  EXPECT_TRUE(LooksLikeFineDate("12 March"));
  EXPECT_FALSE(LooksLikeFineDate("CT colonography 2019"));
  EXPECT_FALSE(LooksLikeFineDate("synthetic, version 1.2"));
  EXPECT_FALSE(LooksLikeFineDate("segment lengths 12-15 cm"));
}

TEST(CaseValidate, MucosaTextureMustMatchItsMediaType) {
  ScratchDir dir;
  auto c = MakeValidCase();
  c.mutable_mucosa_texture()->set_media_type("image/png");
  c.mutable_mucosa_texture()->set_image("not a png");
  EXPECT_TRUE(HasProblem(ProblemsOfBrokenFile(dir, c), "mucosa_texture.image"));
  c.mutable_mucosa_texture()->set_media_type("image/gif");
  EXPECT_TRUE(HasProblem(ProblemsOfBrokenFile(dir, c), "mucosa_texture.media_type"));
  c.mutable_mucosa_texture()->set_media_type("image/png");
  c.mutable_mucosa_texture()->set_image(std::string("\x89PNG\r\n\x1a\n", 8) + "rest");
  EXPECT_TRUE(ValidateCase(c, "unit").empty()) << JoinProblems(ValidateCase(c, "unit"));
}

TEST(CaseValidate, ReportsEveryProblemNotOnlyTheFirst) {
  auto c = MakeValidCase();
  c.set_version(0);
  c.mutable_centerline(2)->set_z_m(kNaN);
  c.mutable_radius_profile(0)->set_radius_m(-0.01);
  c.mutable_regions(1)->mutable_tissue()->set_static_friction(-1.0);
  const auto problems = ValidateCase(c, "unit");
  EXPECT_TRUE(HasProblem(problems, "version"));
  EXPECT_TRUE(HasProblem(problems, "centerline.z_m", 2));
  EXPECT_TRUE(HasProblem(problems, "radius_profile.radius_m", 0));
  EXPECT_TRUE(HasProblem(problems, "regions.tissue.static_friction", 1));
}

}  // namespace
}  // namespace ves::patient_db
