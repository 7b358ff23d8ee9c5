#include "tests/fuzz/fuzz_targets.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "patient_db/case_format.h"
#include "station/haptics/candump_log.h"
#include "station/haptics/protocol.h"
#include "station/sync/session_journal.h"
#include "station/training/case_run.h"
#include "station/training/input_log.h"
#include "station/training/session.h"
#include "station/training/session_file.h"

namespace ves::fuzz {
namespace {

const char* const kShippedCases[] = {"paper-sigmoid", "standard-adult", "fixed-tube",
                                     "redundant-sigmoid"};

std::filesystem::path CaseFile(const std::string& id) {
  return std::filesystem::path(VES_SOURCE_DIR) / "patient_db/cases" / (id + ".textproto");
}

std::string Bytes(const void* data, std::size_t size) {
  return {static_cast<const char*>(data), size};
}

// The case's control points as the CSV importer reads them (mm, radius, region).
std::string CaseAsCsv(const ves::v1::ColonCase& c, bool with_region) {
  std::ostringstream csv;
  csv << "# " << c.id() << "\nx_mm,y_mm,z_mm,radius_mm" << (with_region ? ",region" : "") << "\n";
  const auto arcs = patient_db::CalcControlPointArcs_m(c);
  for (int i = 0; i < c.centerline_size(); ++i) {
    csv << c.centerline(i).x_m() * 1e3 << "," << c.centerline(i).y_m() * 1e3 << ","
        << c.centerline(i).z_m() * 1e3 << "," << patient_db::CalcRadiusAt_m(c, arcs[i]) * 1e3;
    if (with_region) {
      csv << "," << ves::v1::Region_Name(patient_db::CalcRegionAt(c, arcs[i]));
    }
    csv << "\n";
  }
  return csv.str();
}

std::string CaseAsMarkups(const ves::v1::ColonCase& c) {
  std::ostringstream json;
  json << R"({"markups":[{"type":"Curve","coordinateSystem":"RAS","coordinateUnits":"mm",)"
       << R"("controlPoints":[)";
  for (int i = 0; i < c.centerline_size(); ++i) {
    json << (i ? "," : "") << R"({"position":[)" << c.centerline(i).x_m() * 1e3 << ","
         << c.centerline(i).y_m() * 1e3 << "," << c.centerline(i).z_m() * 1e3 << "]}";
  }
  json << "]}]}";
  return json.str();
}

}  // namespace

void Require(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "fuzz: property broken: %s\n", what);
  std::abort();
}

const std::vector<FuzzTarget>& AllFuzzTargets() {
  static const std::vector<FuzzTarget> kTargets = {
      {"csv", FuzzCsv},
      {"markups", FuzzMarkups},
      {"textproto", FuzzTextproto},
      {"bundle", FuzzBundle},
      {"session_file", FuzzSessionFile},
      {"input_log", FuzzInputLog},
      {"can_frame", FuzzCanFrame},
      {"journal", FuzzJournal},
  };
  return kTargets;
}

std::vector<std::string> SeedsFor(const std::string& target) {
  std::vector<std::string> seeds;
  std::vector<ves::v1::ColonCase> cases;
  for (const char* id : kShippedCases) cases.push_back(patient_db::LoadCaseFile(CaseFile(id)));
  if (target == "csv") {
    for (const auto& c : cases) {
      seeds.push_back(std::string(1, '\0') + CaseAsCsv(c, true));
      seeds.push_back(std::string(1, '\3') + CaseAsCsv(c, false));
    }
  } else if (target == "markups") {
    for (const auto& c : cases) {
      seeds.push_back(CaseAsMarkups(c));
      std::string sidecar = "radius_mm,region\n";
      const auto arcs = patient_db::CalcControlPointArcs_m(c);
      for (int i = 0; i < c.centerline_size(); ++i) {
        sidecar += std::to_string(patient_db::CalcRadiusAt_m(c, arcs[i]) * 1e3) + "," +
                   ves::v1::Region_Name(patient_db::CalcRegionAt(c, arcs[i])) + "\n";
      }
      seeds.push_back(CaseAsMarkups(c) + std::string(1, '\0') + sidecar);
    }
  } else if (target == "textproto") {
    for (const char* id : kShippedCases) seeds.push_back(patient_db::ReadFileBytes(CaseFile(id)));
  } else if (target == "bundle") {
    for (const auto& c : cases) seeds.push_back(patient_db::EncodeCaseBundle(c));
  } else if (target == "session_file") {
    // A short scripted run on the smallest case: a real record with its log.
    v1::SessionRecord record;
    training::RunScriptedCase(cases[0], training::DefaultEndoscopeSpec(), {}, "novice", 0.3,
                              1'700'000'000'000, &record);
    seeds.push_back(training::EncodeSessionFile(record));
    record.clear_replay_setup();
    seeds.push_back(training::EncodeSessionFile(record));
  } else if (target == "input_log") {
    for (int n : {0, 1, 7, 300}) {
      std::vector<training::InputSample> samples(n);
      for (int i = 0; i < n; ++i) {
        samples[i].tick = i;
        samples[i].thrust_mode = i % 50 < 25 ? training::ThrustMode::kForce
                                             : training::ThrustMode::kPosition;
        samples[i].push_force_N = 0.01 * (i % 37);
        samples[i].insertion_m = 1e-4 * i;
        samples[i].roll_rad = 0.001 * (i % 11) - 0.005;
        samples[i].view_mode = static_cast<training::ViewMode>(i % 3);
        samples[i].fluoroscopy_on = i % 5 == 0;
      }
      // Format 1 (no toolkit columns), as stations before format 2 wrote it.
      seeds.push_back(training::EncodeInputSamples(samples, 1));
      for (int i = 0; i < n; ++i) {
        samples[i].abdominal_press = static_cast<training::AbdominalPress>(i / 40 % 3);
        samples[i].patient_position = static_cast<training::PatientPosition>(i / 100 % 3);
      }
      seeds.push_back(training::EncodeInputSamples(samples));
    }
  } else if (target == "journal") {
    // A short scripted run's header and its log in chunks, as the station
    // journals it; and the same journal torn inside its last chunk.
    v1::SessionRecord record;
    training::RunScriptedCase(cases[0], training::DefaultEndoscopeSpec(), {}, "expert", 0.6,
                              1'700'000'000'000, &record);
    const std::vector<training::InputSample> samples =
        training::DecodeInputSamples(record.input_log().encoded());
    std::vector<std::string> chunks;
    for (std::size_t at = 0; at < samples.size(); at += 250) {
      chunks.push_back(training::EncodeInputSamples(
          {samples.begin() + at, samples.begin() + std::min(at + 250, samples.size())}));
    }
    // The header as the station's journal keeper builds it.
    const training::CaseRun run =
        training::PrepareCaseRun(cases[0], training::DefaultEndoscopeSpec(), {}, 0.6);
    v1::SessionRecord header =
        training::RecordHeader(run.config, record.uuid(), record.start_unix_ms());
    *header.mutable_replay_setup() = record.replay_setup();
    const std::string journal = sync::EncodeSessionJournal(header, chunks);
    seeds.push_back(journal);
    seeds.push_back(journal.substr(0, journal.size() - 7));
    seeds.push_back(sync::EncodeSessionJournal(header, {}));
  } else if (target == "can_frame") {
    using namespace ves::haptics;  // NOLINT
    const can_frame frames[] = {
        EncodeNmt({}),
        EncodeSync(7),
        EncodeEmcy({kDeviceNodeId, EmcyCode::kCanBusOff, 0x11, {1, 2, 3, 4, 5}}),
        EncodeMotorPdo({1.5, -2.25}),
        EncodeEncoderPdo({123456, -654}),
        EncodeSensorPdo({2.5, -0.01, 9, kStatusOperational}),
        EncodeHeartbeat({kDeviceNodeId, NmtState::kOperational}),
        EncodeBusError({true, false, true, false}),
    };
    std::string all;
    for (const can_frame& f : frames) {
      seeds.push_back(Bytes(&f, sizeof f));
      all += Bytes(&f, sizeof f);
    }
    std::string log = "\n";
    for (const can_frame& f : frames) log += FormatCandumpLine(1700000000.25, "vcan0", f) + "\n";
    seeds.push_back(all + log);
  }
  return seeds;
}

}  // namespace ves::fuzz
