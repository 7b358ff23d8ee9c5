// Import of centerline CSV tables and 3D Slicer curve markups.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "patient_db/case_format.h"
#include "tests/patient_db/case_test_util.h"

namespace ves::patient_db {
namespace {

using testing::HasProblem;
using testing::ScratchDir;
using testing::WriteText;

constexpr double kPositionTolerance_m = 1e-12;

// Five points, 3 cm apart along z, starting at (10, 20, 30) mm: the importer
// moves the first to the origin. Regions: rectum for the first three points,
// sigmoid after, so the joint is at the third point's arc, 0.06 m.
const char* kCsv =
    "# exported centerline\n"
    "x_mm,y_mm,z_mm,radius_mm,region\n"
    "10,20,30,20,rectum\n"
    "10,20,60,21,rectum\n"
    "10,20,90,22,rectum\n"
    "10,20,120,18,sigmoid\n"
    "10,20,150,16,sigmoid\n";

std::vector<CaseProblem> ImportProblems(const std::string& text, const ImportOptions& options = {}) {
  try {
    ImportCenterlineCsv(text, "in.csv", options);
  } catch (const CaseError& e) {
    return e.problems();
  }
  ADD_FAILURE() << "import accepted";
  return {};
}

TEST(CaseImportCsv, PointsRadiiAndRegionsComeFromTheTable) {
  const auto c = ImportCenterlineCsv(kCsv, "dir/My Case 07.csv");
  EXPECT_EQ(c.id(), "my-case-07");
  EXPECT_EQ(c.version(), 1u);
  ASSERT_EQ(c.centerline_size(), 5);
  EXPECT_NEAR(c.centerline(0).x_m(), 0.0, kPositionTolerance_m);
  EXPECT_NEAR(c.centerline(4).z_m(), 0.120, kPositionTolerance_m);  // (150 - 30) mm
  ASSERT_EQ(c.radius_profile_size(), 5);
  EXPECT_NEAR(c.radius_profile(1).arc_m(), 0.03, kPositionTolerance_m);
  EXPECT_NEAR(c.radius_profile(1).radius_m(), 0.021, kPositionTolerance_m);
  ASSERT_EQ(c.regions_size(), 2);
  EXPECT_EQ(c.regions(0).region(), ves::v1::REGION_RECTUM);
  EXPECT_NEAR(c.regions(0).end_arc_m(), 0.09, kPositionTolerance_m);  // first sigmoid row
  EXPECT_EQ(c.regions(1).region(), ves::v1::REGION_SIGMOID);
  EXPECT_NEAR(c.regions(1).end_arc_m(), 0.12, kPositionTolerance_m);
  EXPECT_EQ(c.regions(1).tissue().suspension_stiffness_n_per_m2(), 300.0);
  EXPECT_EQ(c.regions(0).tissue().suspension_stiffness_n_per_m2(), 20000.0);
}

TEST(CaseImportCsv, WithoutRegionColumnTheOptionGivesOneRegion) {
  const std::string csv =
      "x_mm,y_mm,z_mm,radius_mm\n0,0,0,20\n0,0,30,20\n0,0,60,20\n0,0,90,20\n";
  const auto problems = ImportProblems(csv);
  EXPECT_TRUE(HasProblem(problems, "region")) << JoinProblems(problems);
  ImportOptions options;
  options.region = ves::v1::REGION_SIGMOID;
  options.id = "chosen-id";
  const auto c = ImportCenterlineCsv(csv, "in.csv", options);
  ASSERT_EQ(c.regions_size(), 1);
  EXPECT_EQ(c.regions(0).region(), ves::v1::REGION_SIGMOID);
  EXPECT_NEAR(c.regions(0).end_arc_m(), 0.09, kPositionTolerance_m);
  EXPECT_EQ(c.id(), "chosen-id");
}

// A NaN in one row is one problem, on that row: not one more for every
// radius sample and region span derived from it (issue #20 saw ~150).
TEST(CaseImportCsv, ANonFiniteCoordinateIsOneProblemOnItsRow) {
  std::string csv = "x_mm,y_mm,z_mm,radius_mm,region\n";
  for (int i = 0; i < 100; ++i) {
    csv += std::string(i == 50 ? "nan" : "0") + ",0," + std::to_string(15 * i) + ",20," +
           (i < 30 ? "rectum" : "sigmoid") + "\n";
  }
  const auto problems = ImportProblems(csv);
  ASSERT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_EQ(problems[0].ToString(), "in.csv: csv.x_mm[52] = nan: not a finite number");
  csv = "x_mm,y_mm,z_mm,radius_mm\n0,0,0,inf\n0,0,30,20\n0,0,60,20\n0,0,90,20\n";
  ImportOptions options;
  options.region = ves::v1::REGION_SIGMOID;
  EXPECT_EQ(ImportProblems(csv, options).size(), 1u);
}

// Binary data given as a CSV: one problem that says so, not a "header" of
// raw bytes printed to the terminal.
TEST(CaseImportCsv, BinaryDataIsOneProblemSayingItIsNotText) {
  std::string garbage = "\x89PNG\r\n\x1a\n";
  for (int i = 0; i < 64; ++i) garbage += static_cast<char>((i * 37) & 0xff);
  const auto problems = ImportProblems(garbage);
  ASSERT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_EQ(problems[0].ToString(),
            "in.csv: csv = byte 0x1a at offset 6: not a text CSV file (a control byte: binary "
            "data?)");
  const auto latin1 = ImportProblems("x_mm,y_mm,z_mm,radius_mm,r\xe9gion\n");
  ASSERT_EQ(latin1.size(), 1u) << JoinProblems(latin1);
  EXPECT_NE(latin1[0].message.find("not valid UTF-8"), std::string::npos);
}

TEST(CaseImportCsv, ByteOrderMarkAndCrLfFromSpreadsheetsAccepted) {
  std::string csv = "\xEF\xBB\xBFx_mm,y_mm,z_mm,radius_mm,region\r\n";
  for (int i = 0; i < 4; ++i) csv += "0,0," + std::to_string(30 * i) + ",20,rectum\r\n";
  EXPECT_EQ(ImportCenterlineCsv(csv, "in.csv").centerline_size(), 4);
}

TEST(CaseImportCsv, ConstantRadiusOverridesTheColumn) {
  ImportOptions options;
  options.radius_mm = 25.0;
  const auto c = ImportCenterlineCsv(kCsv, "in.csv", options);
  for (const auto& sample : c.radius_profile()) EXPECT_DOUBLE_EQ(sample.radius_m(), 0.025);
}

TEST(CaseImportCsv, BadCellsNamedByLine) {
  const std::string csv =
      "x_mm,y_mm,z_mm,radius_mm,region\n"
      "0,0,0,20,rectum\n"
      "0,zero,30,20,rectum\n"    // line 3
      "0,0,60,20,colon\n"        // line 4
      "0,0,90,20\n";             // line 5: too few cells
  const auto problems = ImportProblems(csv);
  EXPECT_TRUE(HasProblem(problems, "csv.y_mm", 3)) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "csv.region", 4)) << JoinProblems(problems);
  EXPECT_TRUE(HasProblem(problems, "csv", 5)) << JoinProblems(problems);
  EXPECT_EQ(problems.size(), 3u) << JoinProblems(problems);
}

TEST(CaseImportCsv, HeaderRequiredWithKnownColumns) {
  EXPECT_TRUE(HasProblem(ImportProblems("0,0,0,20\n0,0,30,20\n"), "csv.header"));
  EXPECT_TRUE(HasProblem(ImportProblems("x_mm,y_mm,z_mm\n0,0,0\n"), "csv.header"));
  EXPECT_TRUE(HasProblem(ImportProblems(""), "csv"));
}

TEST(CaseImportCsv, ImportedGeometryIsValidated) {
  // Radius 70 mm is beyond anatomy: the import fails like any invalid case.
  ImportOptions options;
  options.radius_mm = 70.0;
  const auto problems = ImportProblems(kCsv, options);
  EXPECT_TRUE(HasProblem(problems, "--radius-mm")) << JoinProblems(problems);
}

std::string Markups(const std::string& system, const std::string& points) {
  return R"({"@schema": "https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/Resources/Schema/markups-schema-v1.0.3.json#",
  "markups": [{"type": "Curve", "coordinateSystem": ")" + system +
         R"(", "coordinateUnits": "mm", "controlPoints": [)" + points + "]}]}";
}

const char* kPoints =
    R"({"id": "1", "position": [1.0, 2.0, 3.0]}, {"id": "2", "position": [11.0, 12.0, 43.0]},)"
    R"({"id": "3", "position": [21.0, 22.0, 83.0]}, {"id": "4", "position": [31.0, 32.0, 123.0]})";

TEST(CaseImportMarkups, LpsPositionsMapToThePatientFrame) {
  // W = (R, A, S); LPS (x, y, z) -> (-x, -y, z), then the first point to the origin.
  ImportOptions options;
  options.radius_mm = 20.0;
  options.region = ves::v1::REGION_RECTUM;
  const auto c = ImportSlicerMarkups(Markups("LPS", kPoints), std::nullopt, "a.mrk.json", options);
  ASSERT_EQ(c.centerline_size(), 4);
  EXPECT_NEAR(c.centerline(1).x_m(), -0.010, kPositionTolerance_m);
  EXPECT_NEAR(c.centerline(1).y_m(), -0.010, kPositionTolerance_m);
  EXPECT_NEAR(c.centerline(1).z_m(), 0.040, kPositionTolerance_m);
  EXPECT_EQ(c.id(), "a");
}

TEST(CaseImportMarkups, RasPositionsMapToThePatientFrame) {
  // RAS is W itself: (x, y, z) -> (x, y, z).
  ImportOptions options;
  options.radius_mm = 20.0;
  options.region = ves::v1::REGION_RECTUM;
  const auto c = ImportSlicerMarkups(Markups("RAS", kPoints), std::nullopt, "a.mrk.json", options);
  EXPECT_NEAR(c.centerline(1).x_m(), 0.010, kPositionTolerance_m);
  EXPECT_NEAR(c.centerline(1).y_m(), 0.010, kPositionTolerance_m);
}

TEST(CaseImportMarkups, SidecarGivesRadiusAndRegionPerPoint) {
  ScratchDir dir;
  WriteText(dir / "colon.mrk.json", Markups("LPS", kPoints));
  WriteText(dir / "colon.radius.csv", "radius_mm,region\n20,rectum\n21,rectum\n17,sigmoid\n16,sigmoid\n");
  const auto c = LoadCaseFile(dir / "colon.mrk.json");
  ASSERT_EQ(c.radius_profile_size(), 4);
  EXPECT_NEAR(c.radius_profile(2).radius_m(), 0.017, kPositionTolerance_m);
  ASSERT_EQ(c.regions_size(), 2);
  EXPECT_EQ(c.regions(1).region(), ves::v1::REGION_SIGMOID);
  EXPECT_EQ(c.id(), "colon");
}

TEST(CaseImportMarkups, NoRadiusIsAnError) {
  ScratchDir dir;
  WriteText(dir / "colon.mrk.json", Markups("LPS", kPoints));
  ImportOptions options;
  options.region = ves::v1::REGION_RECTUM;
  try {
    LoadCaseFile(dir / "colon.mrk.json", options);
    FAIL() << "markups without radius accepted";
  } catch (const CaseError& e) {
    EXPECT_TRUE(HasProblem(e.problems(), "radius_mm")) << e.what();
  }
  options.radius_mm = 20.0;
  EXPECT_EQ(LoadCaseFile(dir / "colon.mrk.json", options).centerline_size(), 4);
}

// What 3D Slicer's Extract Centerline writes: the curve carries a "Radius"
// measurement with one value per control point.
std::string CurveWithRadius(const std::string& values, const std::string& extra_markups = "") {
  return R"({"markups": [{"type": "Curve", "coordinateSystem": "LPS", "coordinateUnits": "mm",
  "controlPoints": [)" + std::string(kPoints) + R"(],
  "measurements": [{"name": "length", "enabled": true, "value": 127.3, "units": "mm"},
                   {"name": "Radius", "enabled": true, "units": "mm",
                    "controlPointValues": [)" + values + "]}]}" + extra_markups + "]}";
}

// A point list of region landmarks (Slicer's "Fiducial" markup): each label
// names the region that begins there.
std::string Landmarks(const std::string& points) {
  return R"({"type": "Fiducial", "coordinateSystem": "LPS", "coordinateUnits": "mm",
  "controlPoints": [)" + points + "]}";
}

// The curve's segments are 42.43 mm long (10, 10, 40 mm steps).
const double kSegment_m = std::sqrt(0.010 * 0.010 + 0.010 * 0.010 + 0.040 * 0.040);

TEST(CaseImportMarkups, TheCurvesRadiusMeasurementGivesTheRadiiWithoutASidecar) {
  ImportOptions options;
  options.region = ves::v1::REGION_RECTUM;
  const auto c = ImportSlicerMarkups(CurveWithRadius("20, 21, 17.5, 16"), std::nullopt,
                                     "colon.mrk.json", options);
  ASSERT_EQ(c.radius_profile_size(), 4);
  EXPECT_NEAR(c.radius_profile(0).radius_m(), 0.020, 1e-12);
  EXPECT_NEAR(c.radius_profile(2).radius_m(), 0.0175, 1e-12);
  EXPECT_NEAR(c.radius_profile(3).arc_m(), 3 * kSegment_m, kPositionTolerance_m);
}

TEST(CaseImportMarkups, ARadiusMeasurementWithTheWrongCountIsRefused) {
  ImportOptions options;
  options.region = ves::v1::REGION_RECTUM;
  try {
    ImportSlicerMarkups(CurveWithRadius("20, 21, 17"), std::nullopt, "colon.mrk.json", options);
    FAIL() << "three radii for four points accepted";
  } catch (const CaseError& e) {
    EXPECT_TRUE(HasProblem(e.problems(), "markups[0].measurements[1].controlPointValues"))
        << e.what();
  }
}

TEST(CaseImportMarkups, LandmarksStartTheirRegionsWhereTheyProjectOntoTheCurve) {
  // "sigmoid" halfway along the second segment, 4 mm off the curve (across
  // its direction): the sigmoid begins at 1.5 segments; "descending" at the
  // third point. The rectum covers the curve from the anus.
  const std::string landmarks = Landmarks(
      R"({"label": "rectum", "position": [1.0, 2.0, 3.0]},)"
      R"({"label": "Sigmoid", "position": [19.0, 14.0, 63.0]},)"
      R"({"label": "descending", "position": [21.0, 22.0, 83.0]})");
  const auto c = ImportSlicerMarkups(CurveWithRadius("20, 21, 17.5, 16", ", " + landmarks),
                                     std::nullopt, "colon.mrk.json");
  ASSERT_EQ(c.regions_size(), 3);
  EXPECT_EQ(c.regions(0).region(), ves::v1::REGION_RECTUM);
  EXPECT_EQ(c.regions(0).start_arc_m(), 0.0);
  EXPECT_EQ(c.regions(1).region(), ves::v1::REGION_SIGMOID);
  EXPECT_NEAR(c.regions(1).start_arc_m(), 1.5 * kSegment_m, 1e-9);
  EXPECT_NEAR(c.regions(0).end_arc_m(), 1.5 * kSegment_m, 1e-9);
  EXPECT_EQ(c.regions(2).region(), ves::v1::REGION_DESCENDING);
  EXPECT_NEAR(c.regions(2).start_arc_m(), 2.0 * kSegment_m, 1e-9);
  EXPECT_NEAR(c.regions(2).end_arc_m(), 3.0 * kSegment_m, 1e-9);
  // Each region gets its default tissue: the sigmoid is mobile.
  EXPECT_EQ(c.regions(1).tissue().suspension_stiffness_n_per_m2(),
            DefaultTissue(ves::v1::REGION_SIGMOID).suspension_stiffness_n_per_m2());
}

TEST(CaseImportMarkups, ALandmarksFileNextToTheCurveImportsInOneCommand) {
  // As Slicer saves them: the curve (with its Radius measurement) and the
  // landmarks point list as two files; the landmarks in any order.
  ScratchDir dir;
  WriteText(dir / "patient.mrk.json", CurveWithRadius("20, 21, 17.5, 16"));
  WriteText(dir / "patient.regions.mrk.json",
            R"({"markups": [)" +
                Landmarks(R"({"label": "sigmoid", "position": [11.0, 12.0, 43.0]},)"
                          R"({"label": "rectum", "position": [1.0, 2.0, 3.0]})") +
                "]}");
  const auto c = LoadCaseFile(dir / "patient.mrk.json");
  ASSERT_EQ(c.regions_size(), 2);
  EXPECT_EQ(c.regions(0).region(), ves::v1::REGION_RECTUM);
  EXPECT_EQ(c.regions(1).region(), ves::v1::REGION_SIGMOID);
  EXPECT_NEAR(c.regions(1).start_arc_m(), kSegment_m, 1e-9);
  EXPECT_EQ(c.id(), "patient");
}

TEST(CaseImportMarkups, ALandmarkThatNamesNoRegionIsRefused) {
  const std::string landmarks = Landmarks(
      R"({"label": "rectum", "position": [1.0, 2.0, 3.0]},)"
      R"({"label": "liver", "position": [11.0, 12.0, 43.0]})");
  try {
    ImportSlicerMarkups(CurveWithRadius("20, 21, 17.5, 16", ", " + landmarks), std::nullopt,
                        "colon.mrk.json");
    FAIL() << "a landmark labelled 'liver' accepted";
  } catch (const CaseError& e) {
    EXPECT_TRUE(HasProblem(e.problems(), "markups[1].controlPoints.label", 1)) << e.what();
    EXPECT_NE(std::string(e.what()).find("liver"), std::string::npos) << e.what();
  }
}

TEST(CaseImportMarkups, SidecarRowCountMustMatch) {
  try {
    ImportSlicerMarkups(Markups("LPS", kPoints), std::string("radius_mm\n20\n20\n"), "a.mrk.json");
    FAIL() << "short sidecar accepted";
  } catch (const CaseError& e) {
    EXPECT_TRUE(HasProblem(e.problems(), "csv")) << e.what();
  }
}

TEST(CaseImportMarkups, MalformedFilesRejected) {
  auto field_of = [](const std::string& json) {
    try {
      ImportOptions options;
      options.radius_mm = 20.0;
      options.region = ves::v1::REGION_RECTUM;
      ImportSlicerMarkups(json, std::nullopt, "a.mrk.json", options);
    } catch (const CaseError& e) {
      return e.problems()[0].field;
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(field_of("{not json"), "json");
  EXPECT_EQ(field_of(R"({"markups": []})"), "markups");
  EXPECT_EQ(field_of(Markups("IJK", kPoints)), "markups[0].coordinateSystem");
  EXPECT_EQ(field_of(Markups("LPS", R"({"position": [1, 2]})")),
            "markups[0].controlPoints.position");
}

TEST(CaseImport, IdFromFileName) {
  EXPECT_EQ(CaseIdFromFileName("Case 07.mrk.json"), "case-07");
  EXPECT_EQ(CaseIdFromFileName("__x__.csv"), "x");
  EXPECT_EQ(CaseIdFromFileName("???.csv"), "imported-case");
}

// A member of the wrong JSON type aborted the process (uncaught
// nlohmann::json::type_error); now it is one problem naming the file.
TEST(CaseImportMarkups, AMemberOfTheWrongTypeIsAProblemNotAnAbort) {
  for (const char* text : {R"({"markups":[{"coordinateSystem":5,"controlPoints":[]}]})",
                           R"({"markups":[{"coordinateUnits":[],"controlPoints":[]}]})"}) {
    try {
      ImportSlicerMarkups(text, std::nullopt, "m.mrk.json");
      ADD_FAILURE() << "accepted " << text;
    } catch (const CaseError& e) {
      ASSERT_EQ(e.problems().size(), 1u) << e.what();
      EXPECT_EQ(e.problems()[0].field, "json");
      EXPECT_NE(e.problems()[0].message.find("type must be string"), std::string::npos)
          << e.what();
    }
  }
}

// --- Import a hospital can trust (issue #48): the anus end, one region over
// a whole colon, problems in the file's own terms.

// Rows "x,y,z,radius[,region]" in millimetres, one per line after the header.
std::string CsvOf(const std::vector<std::string>& rows, bool with_region) {
  std::string csv =
      with_region ? "x_mm,y_mm,z_mm,radius_mm,region\n" : "x_mm,y_mm,z_mm,radius_mm\n";
  for (const auto& row : rows) csv += row + "\n";
  return csv;
}

// A rectum rising 90 mm from the anus into a sigmoid, 30 mm per row.
const std::vector<std::string> kAnusFirstRows = {"0,0,0,13,rectum",     "0,-10,30,20,rectum",
                                                 "0,-15,60,22,rectum",  "5,-10,90,18,sigmoid",
                                                 "15,0,120,16,sigmoid", "25,10,150,16,sigmoid"};

TEST(CaseImportTrust, ACsvThatRunsCecumFirstIsReversedWithAWarning) {
  const auto forward = ImportCenterlineCsv(CsvOf(kAnusFirstRows, true), "in.csv");
  std::vector<std::string> reversed_rows(kAnusFirstRows.rbegin(), kAnusFirstRows.rend());
  std::vector<CaseProblem> warnings;
  ImportOptions options;
  options.warnings = &warnings;
  const auto reversed = ImportCenterlineCsv("# exported cecum first\n" + CsvOf(reversed_rows, true),
                                            "in.csv", options);
  // The same colon as the file in anus-first order.
  ASSERT_EQ(reversed.centerline_size(), forward.centerline_size());
  for (int i = 0; i < forward.centerline_size(); ++i) {
    EXPECT_NEAR(reversed.centerline(i).z_m(), forward.centerline(i).z_m(), 1e-12) << i;
    EXPECT_NEAR(reversed.centerline(i).y_m(), forward.centerline(i).y_m(), 1e-12) << i;
    EXPECT_NEAR(reversed.radius_profile(i).radius_m(), forward.radius_profile(i).radius_m(), 1e-12);
  }
  ASSERT_EQ(reversed.regions_size(), 2);
  EXPECT_EQ(reversed.regions(0).region(), ves::v1::REGION_RECTUM);
  EXPECT_NEAR(reversed.regions(0).end_arc_m(), forward.regions(0).end_arc_m(), 1e-12);
  // Said once, naming the file's rows: the anus is its last line (8).
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0].file, "in.csv");
  EXPECT_NE(warnings[0].message.find("regions run from sigmoid to rectum"), std::string::npos)
      << warnings[0].message;
  EXPECT_NE(warnings[0].message.find("the anus is line 8"), std::string::npos)
      << warnings[0].message;
  EXPECT_NE(reversed.provenance().notes().find("Reversed on import"), std::string::npos);
  EXPECT_TRUE(forward.provenance().notes().empty()) << forward.provenance().notes();
}

TEST(CaseImportTrust, AMarkupsCurveFromTheCecumIsReversedByItsLandmarks) {
  // The curve of kPoints (LPS), written deepest point first and labelled as
  // Slicer does; landmarks: the rectum at the anus, the sigmoid at the second point.
  const std::string points =
      R"({"label": "CL-1", "position": [31.0, 32.0, 123.0]}, {"label": "CL-2", "position": [21.0, 22.0, 83.0]},)"
      R"({"label": "CL-3", "position": [11.0, 12.0, 43.0]}, {"label": "CL-4", "position": [1.0, 2.0, 3.0]})";
  const std::string landmarks =
      Landmarks(R"({"label": "rectum", "position": [1.0, 2.0, 3.0]},)"
                R"({"label": "sigmoid", "position": [11.0, 12.0, 43.0]})");
  const std::string json = R"({"markups": [{"type": "Curve", "coordinateSystem": "LPS",
  "controlPoints": [)" + points +
                           R"(],
  "measurements": [{"name": "Radius", "units": "mm", "controlPointValues": [16, 17.5, 21, 20]}]}, )" +
                           landmarks + "]}";
  std::vector<CaseProblem> warnings;
  ImportOptions options;
  options.warnings = &warnings;
  const auto c = ImportSlicerMarkups(json, std::nullopt, "colon.mrk.json", options);
  EXPECT_NEAR(c.centerline(1).z_m(), 0.040, kPositionTolerance_m);
  EXPECT_NEAR(c.radius_profile(0).radius_m(), 0.020, 1e-12);
  ASSERT_EQ(c.regions_size(), 2);
  EXPECT_EQ(c.regions(0).region(), ves::v1::REGION_RECTUM);
  EXPECT_NEAR(c.regions(1).start_arc_m(), kSegment_m, 1e-9);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].message.find("the anus is point CL-4"), std::string::npos)
      << warnings[0].message;
}

// The shipped standard-adult written out as a CSV without regions, as a
// hospital's export of a whole colon would be.
std::string WholeColonCsv() {
  const auto c = LoadCaseFile(VES_SOURCE_DIR "/patient_db/cases/standard-adult.textproto");
  const auto arcs = CalcControlPointArcs_m(c);
  std::string csv = "x_mm,y_mm,z_mm,radius_mm\n";
  for (int i = 0; i < c.centerline_size(); ++i) {
    csv += std::to_string(c.centerline(i).x_m() * 1000) + "," +
           std::to_string(c.centerline(i).y_m() * 1000) + "," +
           std::to_string(c.centerline(i).z_m() * 1000) + "," +
           std::to_string(CalcRadiusAt_m(c, arcs[i]) * 1000) + "\n";
  }
  return csv;
}

TEST(CaseImportTrust, OneRegionOverAWholeColonIsRefusedWithTheReason) {
  ImportOptions options;
  options.region = ves::v1::REGION_SIGMOID;
  try {
    ImportCenterlineCsv(WholeColonCsv(), "patient.csv", options);
    FAIL() << "a 1.6 m sigmoid accepted";
  } catch (const CaseError& e) {
    ASSERT_EQ(e.problems().size(), 1u) << e.what();
    EXPECT_EQ(e.problems()[0].ToString(),
              "patient.csv: --region = sigmoid: the centreline is 1586 mm long, longer than any "
              "sigmoid (at most 900 mm): it spans several regions; name them with a region column "
              "or region landmarks (docs/case-format.md)");
  }
  // A sigmoid-length piece with one region still imports.
  std::string piece = "x_mm,y_mm,z_mm,radius_mm\n";
  for (int i = 0; i < 12; ++i)
    piece += "0," + std::to_string(i % 2) + "," + std::to_string(40 * i) + ",16\n";
  EXPECT_EQ(ImportCenterlineCsv(piece, "piece.csv", options).regions_size(), 1);
}

// WholeColonCsv's rows in the opposite order, or with the radii reversed.
std::string ReversedRows(const std::string& csv, bool points, bool radii) {
  std::vector<std::string> rows;
  std::istringstream lines(csv);
  std::string header;
  std::getline(lines, header);
  for (std::string line; std::getline(lines, line);) rows.push_back(line);
  std::vector<std::string> out = rows;
  for (size_t i = 0; i < rows.size(); ++i) {
    const std::string& xyz_from = points ? rows[rows.size() - 1 - i] : rows[i];
    const std::string& radius_from = points == radii ? xyz_from : rows[rows.size() - 1 - i];
    out[i] = xyz_from.substr(0, xyz_from.rfind(',')) + radius_from.substr(radius_from.rfind(','));
  }
  std::string text = header + "\n";
  for (const auto& row : out) text += row + "\n";
  return text;
}

TEST(CaseImportTrust, WithoutRegionsTheLumenAndTheHeightFindTheAnusOfAWholeColon) {
  // A whole colon exported cecum first, given one region: the reversal is
  // said (the 32 mm cecum at the start, the start 185 mm above the end),
  // then the one region is refused.
  ImportOptions options;
  options.region = ves::v1::REGION_SIGMOID;
  std::vector<CaseProblem> warnings;
  options.warnings = &warnings;
  try {
    ImportCenterlineCsv(ReversedRows(WholeColonCsv(), true, true), "patient.csv", options);
    FAIL() << "a whole colon as one sigmoid accepted";
  } catch (const CaseError& e) {
    EXPECT_EQ(e.problems()[0].field, "--region") << e.what();
  }
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].message.find("the lumen is 32 mm in radius at its start and"),
            std::string::npos)
      << warnings[0].message;
  EXPECT_NE(warnings[0].message.find("its start lies 185 mm above its end"), std::string::npos)
      << warnings[0].message;
  EXPECT_NE(warnings[0].message.find("the anus is line 65"), std::string::npos)
      << warnings[0].message;
  // The lumen says one end (widest at the first row), the height the other:
  // refused with both reasons.
  warnings.clear();
  try {
    ImportCenterlineCsv(ReversedRows(WholeColonCsv(), false, true), "odd.csv", options);
    FAIL() << "a wide, low start accepted";
  } catch (const CaseError& e) {
    ASSERT_EQ(e.problems().size(), 1u) << e.what();
    EXPECT_NE(e.problems()[0].message.find("cannot tell which end is the anus: the lumen is 32 mm"),
              std::string::npos)
        << e.what();
    EXPECT_NE(e.problems()[0].message.find("but its start lies 185 mm below its end"),
              std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(warnings.empty());
}

TEST(CaseImportTrust, ACsvRadiusProblemNamesItsLineAndMillimetres) {
  std::vector<std::string> rows = kAnusFirstRows;
  rows[3] = "5,-10,90,70,sigmoid";  // line 7 of the file below
  const auto problems =
      ImportProblems("# two comment lines\n# before the header\n" + CsvOf(rows, true));
  ASSERT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_EQ(problems[0].ToString(), "in.csv: csv.radius_mm[7] = 70: must be > 0 and <= 60 mm");
}

TEST(CaseImportTrust, AConstantRadiusProblemIsSaidOnceAsTheOption) {
  ImportOptions options;
  options.radius_mm = 70.0;
  const auto problems = ImportProblems(kCsv, options);
  ASSERT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_EQ(problems[0].ToString(), "in.csv: --radius-mm = 70: must be > 0 and <= 60 mm");
}

TEST(CaseImportTrust, ACsvDuplicateNamesItsLines) {
  ImportOptions options;
  options.region = ves::v1::REGION_SIGMOID;
  const auto problems = ImportProblems(
      "x_mm,y_mm,z_mm,radius_mm\n0,0,0,20\n0,0,30,20\n0,0,30,20\n0,0,60,20\n0,0,90,20\n", options);
  ASSERT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_EQ(problems[0].ToString(),
            "in.csv: csv[4] = 0 mm from line 3: a duplicate of line 3 (closer than 0.1 mm)");
}

TEST(CaseImportTrust, ACsvCentrelineThatCrossesItselfNamesBothLinesInMillimetres) {
  // Up 240 mm, then back down 31.6 mm beside itself with a 20 mm radius.
  std::string csv = "x_mm,y_mm,z_mm,radius_mm\n";
  for (int z = 0; z <= 240; z += 30) csv += "0,0," + std::to_string(z) + ",20\n";    // lines 2-10
  for (int z = 240; z >= 0; z -= 30) csv += "10,30," + std::to_string(z) + ",20\n";  // 11-19
  ImportOptions options;
  options.region = ves::v1::REGION_SIGMOID;
  const auto problems = ImportProblems(csv, options);
  ASSERT_FALSE(problems.empty());
  for (const auto& problem : problems) {
    EXPECT_EQ(problem.field, "csv") << problem.ToString();
    EXPECT_GE(problem.index, 2) << problem.ToString();
    EXPECT_LE(problem.index, 19) << problem.ToString();
    EXPECT_NE(problem.message.find("mm of itself at"), std::string::npos) << problem.ToString();
    EXPECT_NE(problem.message.find("(line "), std::string::npos) << problem.ToString();
    EXPECT_EQ(problem.ToString().find("control point"), std::string::npos) << problem.ToString();
  }
}

// A Slicer curve of 45 points 20 mm apart up z, labelled CL-1 ... CL-45, with
// its Radius measurement in `units`.
std::string LabelledCurve(const std::string& units, const std::string& radii) {
  std::string points;
  for (int i = 0; i < 45; ++i) {
    if (i > 0) points += ",";
    points += R"({"label": "CL-)" + std::to_string(i + 1) + R"(", "position": [0, )" +
              std::to_string(i % 2) + ", " + std::to_string(20 * i) + "]}";
  }
  return R"({"markups": [{"type": "Curve", "coordinateSystem": "RAS", "coordinateUnits": "mm",
  "controlPoints": [)" +
         points + R"(], "measurements": [{"name": "Radius", "units": ")" + units +
         R"(", "controlPointValues": [)" + radii + "]}]}]}";
}

std::string Radii(double value, double odd_one, int at) {
  std::string text;
  for (int i = 0; i < 45; ++i) {
    if (i > 0) text += ", ";
    text += std::to_string(i == at ? odd_one : value);
  }
  return text;
}

TEST(CaseImportTrust, AMarkupsRadiusProblemNamesThePointsLabelAndUnit) {
  ImportOptions options;
  options.region = ves::v1::REGION_SIGMOID;
  std::vector<CaseProblem> problems;
  try {
    ImportSlicerMarkups(LabelledCurve("mm", Radii(16, 70, 40)), std::nullopt, "colon.mrk.json",
                        options);
  } catch (const CaseError& e) {
    problems = e.problems();
  }
  ASSERT_EQ(problems.size(), 1u) << JoinProblems(problems);
  EXPECT_EQ(problems[0].ToString(),
            "colon.mrk.json: point CL-41 radius = 70 mm: must be > 0 and <= 60 mm "
            "(the Radius measurement, markups[0].measurements[0])");
  try {
    ImportSlicerMarkups(LabelledCurve("cm", Radii(1.6, 7, 40)), std::nullopt, "colon.mrk.json",
                        options);
    FAIL() << "a 7 cm radius accepted";
  } catch (const CaseError& e) {
    ASSERT_EQ(e.problems().size(), 1u) << e.what();
    EXPECT_EQ(e.problems()[0].field, "point CL-41 radius");
    EXPECT_EQ(e.problems()[0].value, "7 cm");
    EXPECT_NE(e.problems()[0].message.find("<= 6 cm"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ves::patient_db
