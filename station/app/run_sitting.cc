#include "station/app/run_sitting.h"

#include <algorithm>
#include <exception>
#include <filesystem>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "station/app/run_lesson.h"
#include "station/app/scope_file.h"
#include "station/app/session_commit.h"
#include "station/render/render_error.h"
#include "station/sync/case_cache.h"
#include "station/sync/lesson_cache.h"
#include "station/sync/session_journal.h"
#include "station/training/case_model.h"
#include "station/training/sitting.h"

namespace ves::station {
namespace {

constexpr const char* kName = kRunName;

// An interactive sitting's records, each committed to the outbox as soon as
// its session ends (marked as the lesson's attempt first, on a lesson), so
// that a station that crashes or loses power later loses none of them. A
// record whose commit fails is held and tried again at the end.
class SittingRecords {
 public:
  SittingRecords(const RunOptions& o, const sync::StationPaths& paths,
                 sync::LessonCache* lessons)
      : o_(o), paths_(paths), lessons_(lessons) {}

  void Keep(EndedSession ended) {
    ves::v1::SessionRecord& record = ended.record;
    sitting_.Add(record, ended.result);
    // Every repeat is an attempt. The aids were enforced: a wireframe-free
    // lesson cannot have used the wireframe view.
    if (o_.lesson_plan) {
      record.set_lesson_id(o_.lesson_plan->lesson.lesson_id());
      PrintStationVerdict(o_.lesson_plan->lesson, record, /*wireframe_used=*/false, std::cout);
      try {  // called from the training screen's loop: nothing may escape it
        lessons_->AddAwaited({record.uuid(), record.lesson_id()});
      } catch (const std::exception& error) {
        std::cerr << kName << ": the server's verdict on session " << record.uuid()
                  << " will not be awaited: " << error.what() << "\n";
      }
    }
    uuids_.push_back(record.uuid());
    if (!CommitRecord(paths_, record)) {
      std::cerr << kName << ": session " << record.uuid()
                << " is kept in memory and committed again when the run ends\n";
      held_.push_back(std::move(record));
      return;
    }
    DeleteJournal(record.uuid());
  }
  // At the end: the held records committed; false when one still fails.
  bool CommitHeld() {
    for (const auto& record : held_) {
      if (!CommitRecord(paths_, record)) return false;
      DeleteJournal(record.uuid());
    }
    held_.clear();
    return true;
  }
  const std::vector<std::string>& uuids() const { return uuids_; }
  // Every session kept, with its result: the sitting's summary.
  const training::Sitting& sitting() const { return sitting_; }

 private:
  // The record is in the outbox: its journal is no longer needed.
  void DeleteJournal(const std::string& uuid) {
    std::error_code ignored;
    std::filesystem::remove(sync::JournalPath(paths_.journal(), uuid), ignored);
  }

  const RunOptions& o_;
  const sync::StationPaths& paths_;
  sync::LessonCache* lessons_;
  std::vector<std::string> uuids_;
  std::vector<ves::v1::SessionRecord> held_;
  training::Sitting sitting_;
};

struct ScopeChoice {
  std::string name;
  ves::v1::EndoscopeSpec spec;
};

// The scopes the panel offers: --scope FILE first when given, then the adult
// colonoscope in its long (1.68 m) and intermediate (1.33 m) lengths.
std::vector<ScopeChoice> ScopeChoices(const RunOptions& o) {
  std::vector<ScopeChoice> scopes;
  if (!o.scope_path.empty()) {
    scopes.push_back({std::filesystem::path(o.scope_path).filename().string(),
                      ReadScopeFile(o.scope_path)});
  }
  scopes.push_back({"adult 1.68 m", training::DefaultEndoscopeSpec()});
  ves::v1::EndoscopeSpec intermediate = training::DefaultEndoscopeSpec();
  intermediate.set_working_length_m(1.33);
  scopes.push_back({"adult 1.33 m", intermediate});
  return scopes;
}

// The panel's case list: every case in the offline cache, the running one included.
InteractiveChoices CaseAndScopeChoices(const sync::CaseCache& cache, const std::string& case_id,
                                       const std::vector<ScopeChoice>& scopes) {
  InteractiveChoices choices;
  for (const sync::CachedCase& entry : cache.List()) {
    if (std::find(choices.case_names.begin(), choices.case_names.end(), entry.id) ==
        choices.case_names.end()) {
      choices.case_names.push_back(entry.id);
    }
  }
  const auto it = std::find(choices.case_names.begin(), choices.case_names.end(), case_id);
  if (it == choices.case_names.end()) choices.case_names.push_back(case_id);
  choices.current_case = static_cast<int>(
      std::find(choices.case_names.begin(), choices.case_names.end(), case_id) -
      choices.case_names.begin());
  for (const ScopeChoice& scope : scopes) choices.scope_names.push_back(scope.name);
  return choices;
}

}  // namespace

InteractiveDevice OpenInteractiveDevice(const RunOptions& o) {
  InteractiveDevice device;
  device.can_log = o.can_log;
  device.gamepad = o.gamepad;
  if (!o.can_interface.empty()) device.can_bus = haptics::CanBus::OpenSocketCan(o.can_interface);
  return device;
}

int RunSitting(const RunOptions& o, const sync::StationPaths& paths, ObtainedCase obtained,
               training::CaseRun run, InteractiveDevice device) {
  // Without a lesson the panel offers the cached cases and the scopes; a
  // switch ends the run and starts the chosen one (the device comes up again).
  std::vector<ScopeChoice> scopes;
  InteractiveChoices choices;
  if (!o.lesson_plan) {
    try {
      scopes = ScopeChoices(o);
      choices = CaseAndScopeChoices(sync::CaseCache(paths.cases()), obtained.entry.id, scopes);
    } catch (const std::exception& error) {
      std::cerr << kName << ": " << error.what() << "\n";
      return kExitUsage;
    }
  }
  std::optional<sync::LessonCache> lessons;
  if (o.lesson_plan) lessons.emplace(paths.lessons());
  SittingRecords sitting(o, paths, lessons ? &*lessons : nullptr);
  InteractiveResult interactive;
  for (;;) {
    try {
      const InteractiveLiveTarget live{o.live ? o.server : std::nullopt, obtained.entry.id,
                                       obtained.entry.version};
      interactive = RunInteractive(
          run, obtained.colon_case, o.seconds, std::move(device),
          o.lesson_plan ? &o.lesson_plan->lesson.aids() : nullptr,
          o.lesson_plan ? nullptr : &choices, &live,
          [&sitting](EndedSession ended) { sitting.Keep(std::move(ended)); },
          paths.journal(), &sitting.sitting());
    } catch (const render::RenderError& error) {  // no EGL/OpenGL ES here
      // One line that says what to do (the error names what is missing).
      std::cerr << kName << ": the views cannot render (" << error.what()
                << "): install the GPU's or Mesa's EGL and OpenGL ES 3 drivers "
                   "(deploy/install-deps.sh), or run --headless\n";
      if (sitting.uuids().empty()) return kExitFailed;
      break;
    } catch (const std::exception& error) {  // no display, the device did not come up
      std::cerr << kName << ": " << error.what() << "\n";
      if (sitting.uuids().empty()) return kExitFailed;
      break;  // what the earlier runs recorded is already committed
    }
    std::cout << interactive.device_report << "\n" << interactive.live_report;
    for (auto& ended : interactive.records) sitting.Keep(std::move(ended));
    if (!interactive.next_case || !interactive.next_scope) break;
    try {
      choices.current_case = *interactive.next_case;
      choices.current_scope = *interactive.next_scope;
      sync::CaseCache cache(paths.cases());
      const std::string& next_id = choices.case_names.at(choices.current_case);
      const std::optional<sync::CachedCase> entry = cache.FindLatest(next_id);
      if (!entry) throw std::runtime_error("case '" + next_id + "' left the offline cache");
      obtained = ObtainedCase{*entry, cache.Load(entry->sha256_hex), false};
      const ScopeChoice& next_scope = scopes.at(choices.current_scope);
      run = training::PrepareCaseRun(obtained.colon_case, next_scope.spec, {}, o.seconds);
      run.config.trainee_id = o.trainee_id;
      run.config.station_id = o.station_id;
      run.config.case_sha256_hex = obtained.entry.sha256_hex;
      device = OpenInteractiveDevice(o);
      std::cout << "switched to case " << entry->id << " v" << entry->version << " sha256="
                << entry->sha256_hex.substr(0, 16) << "…, scope " << next_scope.name << "\n";
    } catch (const std::exception& error) {
      std::cerr << kName << ": cannot switch: " << error.what() << "\n";
      break;
    }
  }
  if (sitting.uuids().empty()) {
    std::cout << sitting.sitting().Report();
    return kExitOk;
  }
  if (!sitting.CommitHeld()) return kExitFailed;
  KillAfterCommitIfAsked();
  if (!DeliverCommitted(o, paths, sitting.uuids())) return kExitFailed;
  if (lessons && o.server) {
    CollectServerVerdicts(*o.server, *lessons, sitting.uuids().back(), o.verdict_wait_s,
                          std::cout);
  }
  // Every session of the sitting, not only the last (the summary lines as
  // `ves-station replay` prints them), then the best and the last.
  std::cout << sitting.sitting().Report();
  if (interactive.result.diverged) {
    std::cerr << kName << ": the model diverged: the session did not run to its end\n";
    return kExitFailed;
  }
  return kExitOk;
}

}  // namespace ves::station
