// LoadCaseFile / WriteCaseFile and the four shipped cases.
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "patient_db/case_format.h"
#include "tests/patient_db/case_test_util.h"

namespace ves::patient_db {
namespace {

using google::protobuf::util::MessageDifferencer;
using testing::HasProblem;
using testing::MakeValidCase;
using testing::ScratchDir;
using testing::WriteText;

const std::string kCasesDir = VES_SOURCE_DIR "/patient_db/cases/";

ves::v1::ColonCase Shipped(const std::string& name) {
  return LoadCaseFile(kCasesDir + name + ".textproto");
}

double RegionLength_m(const ves::v1::ColonCase& c, ves::v1::Region region) {
  double length_m = 0.0;
  for (const auto& span : c.regions()) {
    if (span.region() == region) length_m += span.end_arc_m() - span.start_arc_m();
  }
  return length_m;
}

TEST(ShippedCases, AllFourAreValid) {
  for (const char* name : {"paper-sigmoid", "standard-adult", "redundant-sigmoid", "fixed-tube"}) {
    ves::v1::ColonCase c;
    ASSERT_NO_THROW(c = Shipped(name)) << name;
    EXPECT_EQ(c.id(), name);
  }
}

TEST(ShippedCases, StandardAdultRunsRectumToCecumAboutOneAndAHalfMetres) {
  const auto c = Shipped("standard-adult");
  const double length_m = CalcCenterlineLength_m(c);
  EXPECT_GT(length_m, 1.4);
  EXPECT_LT(length_m, 1.7);
  const std::vector<ves::v1::Region> order = {
      ves::v1::REGION_RECTUM,     ves::v1::REGION_SIGMOID,         ves::v1::REGION_DESCENDING,
      ves::v1::REGION_SPLENIC_FLEXURE, ves::v1::REGION_TRANSVERSE, ves::v1::REGION_HEPATIC_FLEXURE,
      ves::v1::REGION_ASCENDING,  ves::v1::REGION_CECUM};
  ASSERT_EQ(c.regions_size(), static_cast<int>(order.size()));
  for (int i = 0; i < c.regions_size(); ++i) EXPECT_EQ(c.regions(i).region(), order[i]);
  // Published ranges (docs/case-format.md): rectum 12-15 cm, sigmoid 35-45 cm.
  EXPECT_NEAR(RegionLength_m(c, ves::v1::REGION_RECTUM), 0.135, 0.015);
  EXPECT_NEAR(RegionLength_m(c, ves::v1::REGION_SIGMOID), 0.40, 0.05);
  EXPECT_NEAR(RegionLength_m(c, ves::v1::REGION_TRANSVERSE), 0.46, 0.04);
  // Anatomy in the patient frame (RAS): descending on the left (-x), ascending
  // on the right (+x), cecum the widest and low on the right.
  const auto arcs = CalcControlPointArcs_m(c);
  for (int i = 0; i < c.centerline_size(); ++i) {
    const auto region = CalcRegionAt(c, arcs[i]);
    if (region == ves::v1::REGION_DESCENDING) {
      EXPECT_LT(c.centerline(i).x_m(), -0.08) << i;
    }
    if (region == ves::v1::REGION_ASCENDING) {
      EXPECT_GT(c.centerline(i).x_m(), 0.08) << i;
    }
  }
  double widest_m = 0.0;
  for (const auto& r : c.radius_profile()) widest_m = std::max(widest_m, r.radius_m());
  EXPECT_EQ(CalcRadiusAt_m(c, arcs.back()), widest_m);
}

TEST(ShippedCases, MobileRegionsAreSoftFixedOnesStiff) {
  const auto c = Shipped("standard-adult");
  for (const auto& span : c.regions()) {
    const double k = span.tissue().suspension_stiffness_n_per_m2();
    EXPECT_EQ(k, IsMobileRegion(span.region()) ? 300.0 : 20000.0) << RegionName(span.region());
  }
}

TEST(ShippedCases, PaperSigmoidIsRectumSigmoidAndStartOfDescending) {
  const auto c = Shipped("paper-sigmoid");
  ASSERT_EQ(c.regions_size(), 3);
  EXPECT_EQ(c.regions(2).region(), ves::v1::REGION_DESCENDING);
  EXPECT_NEAR(CalcCenterlineLength_m(c), 0.6, 0.05);
  EXPECT_EQ(c.regions(1).tissue().suspension_stiffness_n_per_m2(), 300.0);
}

TEST(ShippedCases, RedundantSigmoidIsLongAndVeryMobile) {
  const auto c = Shipped("redundant-sigmoid");
  EXPECT_NEAR(RegionLength_m(c, ves::v1::REGION_SIGMOID), 0.65, 0.05);
  EXPECT_EQ(c.regions(1).tissue().suspension_stiffness_n_per_m2(), 150.0);
  EXPECT_EQ(c.difficulty(), ves::v1::DIFFICULTY_HARD);
}

// Its cecum lies beyond the default scope's 1.68 m working length
// (station/training), so a push that does not shorten the colon cannot reach
// it (issue #17's novice; version 1, 1.62 m to the cecum, let it arrive).
TEST(ShippedCases, MobileDescendingIsLongWithItsCecumBeyondTheScope) {
  const auto c = Shipped("mobile-descending");
  EXPECT_GE(c.version(), 2u);
  EXPECT_NEAR(RegionLength_m(c, ves::v1::REGION_SIGMOID), 0.54, 0.03);
  bool descending_mobile = false;
  double cecum_start_m = 0.0;
  for (const auto& span : c.regions()) {
    if (span.region() == ves::v1::REGION_DESCENDING) {
      descending_mobile = span.tissue().mobility() == ves::v1::MOBILITY_MOBILE;
    }
    if (span.region() == ves::v1::REGION_CECUM) cecum_start_m = span.start_arc_m();
  }
  EXPECT_TRUE(descending_mobile);
  EXPECT_GT(cecum_start_m, 1.68);
  EXPECT_EQ(c.difficulty(), ves::v1::DIFFICULTY_HARD);
}

TEST(ShippedCases, FixedTubeIsStandardAdultWithEverySuspensionStiff) {
  const auto fixed = Shipped("fixed-tube");
  const auto standard = Shipped("standard-adult");
  ASSERT_EQ(fixed.centerline_size(), standard.centerline_size());
  for (int i = 0; i < fixed.centerline_size(); ++i) {
    EXPECT_TRUE(MessageDifferencer::Equals(fixed.centerline(i), standard.centerline(i))) << i;
  }
  for (const auto& span : fixed.regions()) {
    EXPECT_EQ(span.tissue().suspension_stiffness_n_per_m2(), 20000.0);
    EXPECT_EQ(span.tissue().suspension_damping_n_s_per_m2(), 200.0);
  }
  EXPECT_EQ(fixed.difficulty(), ves::v1::DIFFICULTY_EASY);
}

TEST(CaseFile, KindByExtension) {
  EXPECT_EQ(CaseFileKindOf("a/b.mrk.json"), CaseFileKind::kSlicerMarkups);
  EXPECT_EQ(CaseFileKindOf("b.textproto"), CaseFileKind::kTextproto);
  EXPECT_EQ(CaseFileKindOf("b.vescase"), CaseFileKind::kBundle);
  EXPECT_EQ(CaseFileKindOf("b.csv"), CaseFileKind::kCsv);
  EXPECT_EQ(CaseFileKindOf("b.json"), std::nullopt);
  EXPECT_EQ(MarkupsRadiusSidecarPath("d/x.mrk.json"), std::filesystem::path("d/x.radius.csv"));
}

TEST(CaseFile, UnknownExtensionAndMissingFileRejected) {
  ScratchDir dir;
  WriteText(dir / "case.txt", "id: \"x\"");
  EXPECT_THROW(LoadCaseFile(dir / "case.txt"), CaseError);
  try {
    LoadCaseFile(dir / "absent.textproto");
    FAIL() << "missing file loaded";
  } catch (const CaseError& e) {
    EXPECT_EQ(e.problems()[0].field, "(file)");
    EXPECT_EQ(e.problems()[0].file, (dir / "absent.textproto").string());
  }
}

TEST(CaseFile, TextprotoSyntaxErrorNamesTheLine) {
  ScratchDir dir;
  WriteText(dir / "bad.textproto", "id: \"x\"\nversion: 1\nno_such_field: 3\n");
  try {
    LoadCaseFile(dir / "bad.textproto");
    FAIL() << "syntax error accepted";
  } catch (const CaseError& e) {
    ASSERT_FALSE(e.problems().empty());
    EXPECT_EQ(e.problems()[0].field, "textproto");
    EXPECT_EQ(e.problems()[0].index, 3);
  }
}

TEST(CaseFile, WriteThenLoadGivesTheSameCaseInBothFormats) {
  ScratchDir dir;
  const auto c = MakeValidCase();
  for (const char* name : {"c.textproto", "c.vescase"}) {
    WriteCaseFile(c, dir / name);
    EXPECT_TRUE(MessageDifferencer::Equals(LoadCaseFile(dir / name), c)) << name;
    EXPECT_FALSE(std::filesystem::exists(dir / (std::string(name) + ".tmp")));
  }
}

TEST(CaseFile, WriteRefusesAnInvalidCaseAndLeavesNoFile) {
  ScratchDir dir;
  auto c = MakeValidCase();
  c.set_id("");
  EXPECT_THROW(WriteCaseFile(c, dir / "c.vescase"), CaseError);
  EXPECT_FALSE(std::filesystem::exists(dir / "c.vescase"));
  EXPECT_THROW(WriteCaseFile(MakeValidCase(), dir / "c.csv"), CaseError);
}

TEST(CaseGeometry, RadiusInterpolatesLinearlyAndHoldsBeyondTheEnds) {
  auto c = MakeValidCase();
  c.clear_radius_profile();
  auto* a = c.add_radius_profile();
  a->set_arc_m(0.05);
  a->set_radius_m(0.01);
  auto* b = c.add_radius_profile();
  b->set_arc_m(0.15);
  b->set_radius_m(0.03);
  EXPECT_DOUBLE_EQ(CalcRadiusAt_m(c, 0.0), 0.01);
  EXPECT_DOUBLE_EQ(CalcRadiusAt_m(c, 0.10), 0.02);  // halfway
  EXPECT_DOUBLE_EQ(CalcRadiusAt_m(c, 0.5), 0.03);
  EXPECT_DOUBLE_EQ(CalcCenterlineLength_m(c), 0.18);
  EXPECT_EQ(CalcRegionAt(c, 0.1), ves::v1::REGION_SIGMOID);
  EXPECT_EQ(CalcRegionAt(c, 0.18), ves::v1::REGION_SIGMOID);
  EXPECT_EQ(CalcRegionAt(c, 0.0), ves::v1::REGION_RECTUM);
}

TEST(CaseRegions, NamesRoundTrip) {
  for (int value = ves::v1::REGION_RECTUM; value <= ves::v1::REGION_CECUM; ++value) {
    const auto region = static_cast<ves::v1::Region>(value);
    EXPECT_EQ(ParseRegionName(RegionName(region)), region);
  }
  EXPECT_EQ(ParseRegionName("Splenic_Flexure"), ves::v1::REGION_SPLENIC_FLEXURE);
  EXPECT_EQ(ParseRegionName("REGION_CECUM"), ves::v1::REGION_CECUM);
  EXPECT_EQ(ParseRegionName("colon"), std::nullopt);
  EXPECT_EQ(ParseRegionName("unspecified"), std::nullopt);
}

}  // namespace
}  // namespace ves::patient_db
