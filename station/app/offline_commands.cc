// ves-station import-case / export-case / status: the station's offline case
// library (the paper's CD-ROM), its pending uploads and lesson verdicts.
#include <boost/program_options.hpp>

#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <string_view>

#include "patient_db/case_format.h"
#include "patient_db/case_problem.h"
#include "patient_db/limits.h"
#include "station/app/case_argument.h"
#include "station/app/case_preview.h"
#include "station/app/command_line.h"
#include "station/app/commands.h"
#include "station/sync/case_cache.h"
#include "station/sync/lesson_cache.h"
#include "station/sync/outbox.h"
#include "station/sync/session_journal.h"
#include "station/sync/station_paths.h"
#include "station/training/session.h"

namespace ves::station {
namespace po = boost::program_options;
namespace {

// The offline commands' line: `options` plus --help and --data-dir.
std::optional<int> ParseOfflineArgs(std::string_view name, std::string_view usage,
                                    const CommandArgs& args, po::options_description& options,
                                    const po::positional_options_description& positional,
                                    po::variables_map* vm) {
  options.add_options()("help,h", "show this help")(
      "data-dir", po::value<std::string>()->default_value(""),
      "station data folder (default $VES_STATION_DIR or ~/.ves-station)");
  return ParseCommandLine(name, usage, args, options, vm, positional);
}

// Text from the outbox or the server, safe for the terminal.
std::string Shown(const std::string& text) { return patient_db::PrintableExcerpt(text, 256); }

// How many of the stored sessions `status` lists (the newest).
constexpr std::size_t kStatusSessions = 50;

// "2026-12-07 14:31" in the station's local time.
std::string LocalTime(int64_t unix_ms) {
  const std::time_t seconds = static_cast<std::time_t>(unix_ms / 1000);
  std::tm local{};
  char text[32] = "-";
  if (localtime_r(&seconds, &local) != nullptr) {
    std::strftime(text, sizeof(text), "%Y-%m-%d %H:%M", &local);
  }
  return text;
}

sync::StationPaths Paths(const po::variables_map& vm) {
  return sync::ResolveStationPaths(vm["data-dir"].as<std::string>());
}

}  // namespace

namespace {

// The import's preview (docs/case-format.md); a station without GL still
// imports, and says why there is no picture.
void WritePreview(const ves::v1::ColonCase& colon_case, const std::filesystem::path& dir) {
  constexpr int kWidth = 640;
  constexpr int kHeight = 720;
  const std::filesystem::path path = dir / (colon_case.id() + ".png");
  try {
    std::filesystem::create_directories(dir);
    const cv::Mat image = RenderCasePreview(colon_case, kWidth, kHeight);
    if (!cv::imwrite(path.string(), image)) throw std::runtime_error("cannot write the file");
    std::cout << "preview " << path.string() << "\n";
  } catch (const std::exception& error) {
    std::cerr << "ves-station: no preview " << path.string() << ": " << error.what() << "\n";
  }
}

}  // namespace

int RunImportCaseCommand(const CommandArgs& args) {
  po::options_description options("options");
  options.add_options()("file", po::value<std::vector<std::string>>()->required(),
                        "case files: bundle (.vescase), textproto, CSV or 3D Slicer markups")(
      "radius-mm", po::value<double>(), "CSV/markups: constant lumen radius (mm)")(
      "region", po::value<std::string>(),
      "CSV/markups: region of the whole centerline (rectum, sigmoid, ..., cecum)")(
      "id", po::value<std::string>(), "CSV/markups: case id (default: from the file name)")(
      "title", po::value<std::string>(), "CSV/markups: title")(
      "preview", po::value<std::string>(),
      "write DIR/<id>.png for each imported case: AP fluoroscopy of the colon at rest with its "
      "regions labelled");
  po::positional_options_description positional;
  positional.add("file", -1);
  po::variables_map vm;
  if (auto stop = ParseOfflineArgs(
          "ves-station import-case",
          "usage: ves-station import-case FILE... [--radius-mm R] [--region NAME] [--id ID]\n"
          "                               [--title T] [--preview DIR] [--data-dir DIR]\n\n"
          "Puts cases into the station's offline cache. FILE is any format `ves-admin case\n"
          "convert` reads (docs/case-format.md): a bundle (.vescase, the paper's CD-ROM), a\n"
          "textproto, a centerline CSV or a 3D Slicer markups file (.mrk.json, its Radius\n"
          "measurement or a <stem>.radius.csv sidecar, region landmarks in "
          "<stem>.regions.mrk.json).",
          args, options, positional, &vm)) {
    return *stop;
  }
  patient_db::ImportOptions import;
  if (vm.count("radius-mm")) import.radius_mm = vm["radius-mm"].as<double>();
  if (vm.count("region")) {
    import.region = patient_db::ParseRegionName(vm["region"].as<std::string>());
    if (!import.region) {
      std::cerr << "ves-station import-case: --region '" << vm["region"].as<std::string>()
                << "' is not a region (rectum, sigmoid, descending, splenic-flexure, "
                   "transverse, hepatic-flexure, ascending, cecum)\n";
      return 2;
    }
  }
  if (vm.count("id")) import.id = vm["id"].as<std::string>();
  if (vm.count("title")) import.title = vm["title"].as<std::string>();
  try {
    sync::CaseCache cache(Paths(vm).cases());
    int failures = 0;
    // What the import changed on its own (a centreline reversed to start at
    // the anus), said whether or not the file is then refused.
    std::vector<patient_db::CaseProblem> warnings;
    import.warnings = &warnings;
    const auto say_warnings = [&warnings] {
      for (const auto& warning : warnings) {
        std::cerr << "ves-station: warning: " << warning.ToString() << "\n";
      }
      warnings.clear();
    };
    for (const auto& file : vm["file"].as<std::vector<std::string>>()) {
      try {
        // A bundle is stored as it is (its hash checked); every other format
        // is read, validated and stored as a bundle.
        const bool bundle = patient_db::CaseFileKindOf(file) == patient_db::CaseFileKind::kBundle;
        const auto entry = bundle ? cache.ImportBundleFile(file)
                                  : cache.Put(patient_db::LoadCaseFile(file, import));
        say_warnings();
        std::cout << "imported " << entry.id << " v" << entry.version << " sha256=" << entry.sha256_hex
                  << "\n";
        if (vm.count("preview")) {
          WritePreview(cache.Load(entry.sha256_hex), vm["preview"].as<std::string>());
        }
      } catch (const std::exception& error) {
        say_warnings();
        std::cerr << "ves-station: import refused: " << error.what() << "\n";
        ++failures;
      }
    }
    return failures == 0 ? 0 : 2;
  } catch (const std::exception& error) {
    std::cerr << "ves-station: " << error.what() << "\n";
    return 1;
  }
}

int RunExportCaseCommand(const CommandArgs& args) {
  po::options_description options("options");
  options.add_options()("case", po::value<std::string>()->required(), "case id or SHA-256")(
      "out,o", po::value<std::string>()->required(), "bundle file to write (*.vescase)");
  po::positional_options_description positional;
  positional.add("case", 1);
  po::variables_map vm;
  if (auto stop =
          ParseOfflineArgs("ves-station export-case",
                           "usage: ves-station export-case ID -o FILE.vescase [--data-dir DIR]",
                           args, options, positional, &vm)) {
    return *stop;
  }
  try {
    sync::CaseCache cache = OpenCaseCache(Paths(vm), std::cout);
    const auto entry =
        cache.ExportBundleFile(vm["case"].as<std::string>(), vm["out"].as<std::string>());
    std::cout << "exported " << entry.id << " v" << entry.version << " to "
              << vm["out"].as<std::string>() << "\n";
    return 0;
  } catch (const std::exception& error) {
    std::cerr << "ves-station: " << error.what() << "\n";
    return 1;
  }
}

int RunStatusCommand(const CommandArgs& args) {
  po::options_description options("options");
  po::variables_map vm;
  if (auto stop =
          ParseOfflineArgs("ves-station status", "usage: ves-station status [--data-dir DIR]", args,
                           options, {}, &vm)) {
    return *stop;
  }
  try {
    const auto paths = Paths(vm);
    sync::CaseCache cache = OpenCaseCache(paths, std::cout);
    std::vector<std::string> damaged;
    const auto cases = cache.List(&damaged);
    std::cout << "data folder: " << paths.root.string() << "\n";
    std::cout << "cached cases: " << cases.size() << "\n";
    for (const auto& entry : cases) {
      std::cout << "  " << entry.id << " v" << entry.version << "  " << entry.title
                << "  sha256=" << entry.sha256_hex.substr(0, 16) << "…\n";
    }
    for (const auto& problem : damaged) std::cout << "  DAMAGED " << problem << "\n";
    sync::Outbox outbox(paths.outbox_db());
    // The station's sessions, delivered or not: when, who, what, how it went.
    const std::size_t stored_count = outbox.StoredCount();
    std::cout << "sessions stored: " << stored_count;
    if (stored_count > kStatusSessions) std::cout << " (the last " << kStatusSessions << ")";
    std::cout << "\n";
    for (const auto& stored : outbox.Stored(kStatusSessions)) {
      std::cout << "  ";
      if (!stored.readable) {
        std::cout << Shown(stored.uuid) << "  unreadable  " << stored.state << "\n";
        continue;
      }
      const ves::v1::SessionRecord& record = stored.record;
      char score[32];
      std::snprintf(score, sizeof(score), "%.1f", record.score());
      std::cout << LocalTime(record.start_unix_ms()) << "  trainee=" << Shown(record.trainee_id())
                << "  case=" << Shown(record.case_id()) << "  outcome="
                << training::OutcomeName(static_cast<training::Outcome>(record.outcome()))
                << "  score=" << score << "  " << stored.state << "  " << Shown(stored.uuid)
                << "\n";
    }
    const auto pending = outbox.Pending();
    std::cout << "pending uploads: " << pending.size() << "\n";
    for (const auto& upload : pending) {
      std::cout << "  " << upload.uuid << "  trainee=" << Shown(upload.record.trainee_id())
                << "  case=" << Shown(upload.record.case_id()) << "  attempts=" << upload.attempts
                << (upload.last_error.empty() ? "" : "  last error: " + Shown(upload.last_error))
                << "\n";
    }
    // Refused by the server as invalid, or unreadable: kept, never retried,
    // and never in the way of the pending ones.
    const auto set_aside = outbox.SetAside();
    std::cout << "set aside: " << set_aside.size() << "\n";
    for (const auto& record : set_aside) {
      std::cout << "  " << Shown(record.uuid) << "  attempts=" << record.attempts
                << "  reason: " << Shown(record.reason) << "\n";
    }
    // Journals (docs/station-run.md, "Journal"): the session a station is
    // running, or one it was running when it died, which the next run
    // recovers into the outbox.
    const auto journals = sync::ListJournals(paths.journal());
    std::cout << "sessions in the journal: " << journals.size()
              << (journals.empty() ? "" : " (running now, or interrupted: the next `ves-station run` "
                                          "recovers them into the outbox)")
              << "\n";
    for (const auto& journal : journals) {
      std::cout << "  " << journal.stem().string()
                << (sync::JournalInUse(journal) ? "  running" : "  interrupted") << "\n";
    }
    const auto unreadable = sync::ListJournals(paths.journal() / "unreadable");
    if (!unreadable.empty()) {
      std::cout << "  unrecoverable, kept in " << (paths.journal() / "unreadable").string() << ": "
                << unreadable.size() << "\n";
    }
    // Lesson sessions: the server judges them from their replay; until the
    // station has fetched that verdict (ves-station sync) it is awaited.
    sync::LessonCache lessons(paths.lessons());
    const auto awaited = lessons.Awaited();
    std::cout << "lesson verdicts awaited: " << awaited.size() << "\n";
    for (const auto& session : awaited) {
      std::cout << "  " << session.session_uuid << "  lesson=" << session.lesson_id << "\n";
    }
    std::vector<std::string> damaged_verdicts;
    const auto verdicts = lessons.Verdicts(&damaged_verdicts);
    std::cout << "lesson verdicts received: " << verdicts.size() << "\n";
    for (const auto& verdict : verdicts) {
      std::cout << "  " << verdict.session_uuid() << "  trainee=" << verdict.trainee_id()
                << "  lesson=" << verdict.lesson_id() << "  "
                << (verdict.passed() ? "PASSED" : verdict.rejected() ? "REJECTED" : "FAILED")
                << "  score=" << verdict.score()
                << "\n";
    }
    for (const auto& problem : damaged_verdicts) std::cout << "  DAMAGED " << problem << "\n";
    return 0;
  } catch (const std::exception& error) {
    std::cerr << "ves-station: " << error.what() << "\n";
    return 1;
  }
}

}  // namespace ves::station
