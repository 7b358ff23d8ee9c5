#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "patient_db/case_problem.h"
#include "ves/v1/case.pb.h"

// Import of centerlines exported by segmentation tools (docs/case-format.md):
//  - CSV: header line, columns x_mm,y_mm,z_mm,radius_mm[,region] in the patient
//    frame W, first row at the anus;
//  - 3D Slicer curve markups (*.mrk.json): markups[0].controlPoints[].position in
//    LPS or RAS millimetres, radius from the curve's "Radius" measurement (its
//    controlPointValues, as Slicer's Extract Centerline writes it), a sidecar
//    CSV (radius_mm[,region], one row per control point) or a constant;
//    regions from the sidecar's region column or from landmarks: a point
//    list whose labels name the region that begins there, each projected
//    onto the curve (another markup of the file, or a landmarks file).
// The importer moves the first point to the origin, puts a radius sample at every
// point, makes region spans from runs of equal region names (or one region from
// the options) with DefaultTissue(region), and validates the result.
namespace ves::patient_db {

struct ImportOptions {
  std::optional<double> radius_mm;        // constant radius; overrides a sidecar's radii
  std::optional<ves::v1::Region> region;  // used when the file names no regions
  std::string id;                         // default: derived from the file name
  std::string title;                      // default: "Imported centerline <file name>"
  // Receives what the import changed on its own (a centreline that ran
  // cecum first, reversed); also recorded in the case's provenance notes.
  std::vector<CaseProblem>* warnings = nullptr;
};

// The longest a region can plausibly be: a centreline given one region
// (--region) that is longer is a whole colon and refused.
double MaxPlausibleRegionLength_m(ves::v1::Region region);

// Throws CaseError (parse errors with their line, or validation problems).
ves::v1::ColonCase ImportCenterlineCsv(std::string_view csv_text, const std::string& file_label,
                                       const ImportOptions& options = {});

// `radius_csv_text`: the sidecar's content when there is one.
// `landmarks_json_text`: a markups file with a point list of region
// landmarks (Slicer's "Fiducial"/point list), when there is one.
ves::v1::ColonCase ImportSlicerMarkups(std::string_view json_text,
                                       const std::optional<std::string>& radius_csv_text,
                                       const std::string& file_label,
                                       const ImportOptions& options = {},
                                       const std::optional<std::string>& landmarks_json_text = {});

// "Case 07.mrk.json" -> "case-07": lowercase, runs of other characters to '-'.
std::string CaseIdFromFileName(const std::string& file_name);

}  // namespace ves::patient_db
