// The case readers: CSV, 3D Slicer markups, textproto and bundle
// (patient_db/case_import.h, case_textproto.h, case_bundle.h). Each may only
// throw CaseError; whatever it accepts is a valid case that survives a
// bundle round trip.
#include <google/protobuf/util/message_differencer.h>

#include <optional>
#include <string>
#include <string_view>

#include "patient_db/case_format.h"
#include "tests/fuzz/fuzz_targets.h"

namespace ves::fuzz {
namespace {

std::string_view AsText(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// A case a reader accepted: valid, and the same after encode and decode.
void CheckAccepted(const ves::v1::ColonCase& c) {
  Require(patient_db::ValidateCase(c, "fuzz").empty(), "an accepted case validates");
  const auto again = patient_db::DecodeCaseBundle(patient_db::EncodeCaseBundle(c), "fuzz");
  Require(google::protobuf::util::MessageDifferencer::Equals(c, again),
          "a case survives a bundle round trip");
}

}  // namespace

// First byte: import options (bit 0 a constant radius, bit 1 a region); the
// rest is the CSV text.
int FuzzCsv(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  patient_db::ImportOptions options;
  if (data[0] & 1) options.radius_mm = 20.0;
  if (data[0] & 2) options.region = ves::v1::REGION_SIGMOID;
  try {
    CheckAccepted(patient_db::ImportCenterlineCsv(AsText(data + 1, size - 1), "fuzz.csv", options));
  } catch (const patient_db::CaseError&) {
  }
  return 0;
}

// The markups JSON, then (after a NUL byte, when there is one) the radius sidecar.
int FuzzMarkups(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = AsText(data, size);
  const std::size_t nul = text.find('\0');
  std::optional<std::string> sidecar;
  if (nul != std::string_view::npos) sidecar = std::string(text.substr(nul + 1));
  patient_db::ImportOptions options;
  options.radius_mm = sidecar ? std::nullopt : std::optional<double>(20.0);
  options.region = ves::v1::REGION_RECTUM;
  try {
    CheckAccepted(patient_db::ImportSlicerMarkups(text.substr(0, nul), sidecar, "fuzz.mrk.json",
                                                  options));
  } catch (const patient_db::CaseError&) {
  }
  return 0;
}

// Text format: parsing never throws anything but CaseError; validation
// never throws; a valid case round-trips.
int FuzzTextproto(const std::uint8_t* data, std::size_t size) {
  ves::v1::ColonCase c;
  try {
    c = patient_db::ParseCaseTextproto(AsText(data, size), "fuzz.textproto");
  } catch (const patient_db::CaseError&) {
    return 0;
  }
  if (patient_db::ValidateCase(c, "fuzz").empty()) CheckAccepted(c);
  return 0;
}

int FuzzBundle(const std::uint8_t* data, std::size_t size) {
  try {
    CheckAccepted(patient_db::DecodeCaseBundle(AsText(data, size), "fuzz.vescase"));
  } catch (const patient_db::CaseError&) {
  }
  return 0;
}

}  // namespace ves::fuzz
