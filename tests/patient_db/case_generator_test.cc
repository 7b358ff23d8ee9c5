// The generator of plausible colons (docs/case-generator.md).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "patient_db/case_format.h"
#include "tests/patient_db/case_test_util.h"

namespace ves::patient_db {
namespace {

using testing::ScratchDir;

// The ranges docs/case-generator.md documents, written out here so the test
// checks the document, not the generator's own constants.
const std::map<ves::v1::Region, std::pair<double, double>> kDocumentedRange_m = {
    {ves::v1::REGION_RECTUM, {0.12, 0.15}},     {ves::v1::REGION_SIGMOID, {0.15, 0.70}},
    {ves::v1::REGION_DESCENDING, {0.20, 0.28}}, {ves::v1::REGION_SPLENIC_FLEXURE, {0.06, 0.10}},
    {ves::v1::REGION_TRANSVERSE, {0.30, 0.65}}, {ves::v1::REGION_HEPATIC_FLEXURE, {0.05, 0.08}},
    {ves::v1::REGION_ASCENDING, {0.15, 0.20}},  {ves::v1::REGION_CECUM, {0.05, 0.08}},
};
const std::vector<ves::v1::Region> kAnusToCecum = {
    ves::v1::REGION_RECTUM,          ves::v1::REGION_SIGMOID,    ves::v1::REGION_DESCENDING,
    ves::v1::REGION_SPLENIC_FLEXURE, ves::v1::REGION_TRANSVERSE, ves::v1::REGION_HEPATIC_FLEXURE,
    ves::v1::REGION_ASCENDING,       ves::v1::REGION_CECUM};

constexpr int kSeeds = 50;

const std::vector<ves::v1::ColonCase>& FiftyColons() {
  static const std::vector<ves::v1::ColonCase> colons = [] {
    std::vector<ves::v1::ColonCase> out;
    for (int seed = 1; seed <= kSeeds; ++seed) out.push_back(GenerateColonCase(seed));
    return out;
  }();
  return colons;
}

TEST(CaseGenerator, FiftySeedsAllValidateAndLoadBackAsWritten) {
  ScratchDir dir;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const auto& c = FiftyColons()[seed - 1];
    EXPECT_TRUE(ValidateCase(c, "g").empty()) << seed << ": " << JoinProblems(ValidateCase(c, "g"));
    const auto path = dir / ("seed-" + std::to_string(seed) + ".textproto");
    WriteCaseFile(c, path);
    EXPECT_EQ(FormatCaseTextproto(LoadCaseFile(path)), FormatCaseTextproto(c)) << seed;
    EXPECT_EQ(c.id(), "generated-" + std::to_string(seed));
  }
}

TEST(CaseGenerator, TheSameSeedGivesTheSameBytes) {
  for (std::uint64_t seed : {1ull, 17ull, 18446744073709551615ull}) {
    const auto a = GenerateColonCase(seed);
    const auto b = GenerateColonCase(seed);
    EXPECT_EQ(FormatCaseTextproto(a), FormatCaseTextproto(b)) << seed;
    EXPECT_EQ(EncodeCaseBundle(a), EncodeCaseBundle(b)) << seed;
  }
}

TEST(CaseGenerator, DifferentSeedsGiveDifferentColons) {
  std::set<std::string> texts;
  std::set<long> lengths_mm;
  for (const auto& c : FiftyColons()) {
    ves::v1::ColonCase shape = c;  // the geometry alone, not the id and title
    shape.clear_id();
    shape.clear_title();
    shape.clear_provenance();
    texts.insert(FormatCaseTextproto(shape));
    lengths_mm.insert(std::lround(CalcCenterlineLength_m(c) * 1000.0));
  }
  EXPECT_EQ(texts.size(), static_cast<size_t>(kSeeds));
  EXPECT_GE(lengths_mm.size(), 40u);  // 1 mm bins: nearly all lengths differ
}

TEST(CaseGenerator, EachRegionLengthIsWithinItsDocumentedRange) {
  for (const auto& c : FiftyColons()) {
    ASSERT_EQ(c.regions_size(), 8) << c.id();
    for (int r = 0; r < c.regions_size(); ++r) {
      const auto& span = c.regions(r);
      EXPECT_EQ(span.region(), kAnusToCecum[r]) << c.id();
      const double length_m = span.end_arc_m() - span.start_arc_m();
      const auto [lo, hi] = kDocumentedRange_m.at(span.region());
      EXPECT_GE(length_m, lo) << c.id() << " " << RegionName(span.region());
      EXPECT_LE(length_m, hi) << c.id() << " " << RegionName(span.region());
    }
    const double total_m = CalcCenterlineLength_m(c);
    EXPECT_GE(total_m, 1.30) << c.id();
    EXPECT_LE(total_m, 2.00) << c.id();
  }
}

TEST(CaseGenerator, TheAnusEndIsFirst) {
  for (const auto& c : FiftyColons()) {
    EXPECT_EQ(c.centerline(0).x_m(), 0.0);
    EXPECT_EQ(c.centerline(0).y_m(), 0.0);
    EXPECT_EQ(c.centerline(0).z_m(), 0.0);
    EXPECT_EQ(c.regions(0).region(), ves::v1::REGION_RECTUM);
    EXPECT_EQ(c.regions(c.regions_size() - 1).region(), ves::v1::REGION_CECUM);
    // The anal canal is the narrowest lumen, the cecum the widest.
    double narrowest_m = 1.0;
    double widest_m = 0.0;
    for (const auto& sample : c.radius_profile()) {
      narrowest_m = std::min(narrowest_m, sample.radius_m());
      widest_m = std::max(widest_m, sample.radius_m());
    }
    EXPECT_EQ(CalcRadiusAt_m(c, 0.0), narrowest_m) << c.id();
    EXPECT_EQ(CalcRadiusAt_m(c, CalcCenterlineLength_m(c)), widest_m) << c.id();
    // Nothing lies below the anus: the rectum rises from it.
    for (const auto& p : c.centerline()) EXPECT_GE(p.z_m(), 0.0) << c.id();
  }
}

TEST(CaseGenerator, TheFiftyShowTheDocumentedVariety) {
  int redundant = 0;
  int short_sigmoid = 0;
  int mobile_descending = 0;
  int deep_transverse = 0;
  for (const auto& c : FiftyColons()) {
    const auto& sigmoid = c.regions(1);
    const double sigmoid_m = sigmoid.end_arc_m() - sigmoid.start_arc_m();
    redundant += sigmoid_m >= 0.50;
    short_sigmoid += sigmoid_m < 0.30;
    mobile_descending += c.regions(2).tissue().mobility() == ves::v1::MOBILITY_MOBILE;
    // The transverse colon's lowest point within 0.15 m of the anus's height
    // plus the pelvis (0.25 m): a sag toward the pelvis.
    double lowest_m = 1.0;
    const auto arcs = CalcControlPointArcs_m(c);
    for (int i = 0; i < c.centerline_size(); ++i) {
      if (CalcRegionAt(c, arcs[i]) == ves::v1::REGION_TRANSVERSE) {
        lowest_m = std::min(lowest_m, c.centerline(i).z_m());
      }
    }
    deep_transverse += lowest_m < 0.30;
    for (int r : {1, 4}) {
      const double mesentery_m = c.regions(r).tissue().mesentery_length_m();
      EXPECT_GE(mesentery_m, 0.02) << c.id();
      EXPECT_LE(mesentery_m, 0.18) << c.id();
    }
  }
  EXPECT_GE(redundant, 5);
  EXPECT_GE(short_sigmoid, 2);
  EXPECT_GE(mobile_descending, 5);
  EXPECT_LE(mobile_descending, 25);
  EXPECT_GE(deep_transverse, 5);
}

TEST(CaseGenerator, OptionsForceTheSigmoidAndTheDescendingColon) {
  ColonGeneratorOptions options;
  options.redundant_sigmoid = true;
  options.mobile_descending = true;
  options.id = "chosen";
  for (int seed = 1; seed <= 5; ++seed) {
    const auto c = GenerateColonCase(seed, options);
    EXPECT_GE(c.regions(1).end_arc_m() - c.regions(1).start_arc_m(), 0.50);
    EXPECT_EQ(c.regions(2).tissue().mobility(), ves::v1::MOBILITY_MOBILE);
    EXPECT_EQ(c.id(), "chosen");
  }
  options.redundant_sigmoid = false;
  options.mobile_descending = false;
  for (int seed = 1; seed <= 5; ++seed) {
    const auto c = GenerateColonCase(seed, options);
    EXPECT_LE(c.regions(1).end_arc_m() - c.regions(1).start_arc_m(), 0.50);
    EXPECT_NE(c.regions(2).tissue().mobility(), ves::v1::MOBILITY_MOBILE);
  }
}

TEST(CaseGenerator, ABadIdIsRefusedNamingIt) {
  ColonGeneratorOptions options;
  options.id = "Not An Id";
  try {
    GenerateColonCase(1, options);
    FAIL() << "accepted";
  } catch (const CaseError& e) {
    ASSERT_EQ(e.problems().size(), 1u) << e.what();
    EXPECT_EQ(e.problems()[0].field, "id");
  }
}

}  // namespace
}  // namespace ves::patient_db
