#include "station/app/journal_recovery.h"

#include <filesystem>
#include <iomanip>
#include <iostream>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include "station/app/run_options.h"
#include "station/sync/lesson_cache.h"
#include "station/sync/outbox.h"
#include "station/sync/session_journal.h"
#include "station/training/input_log.h"
#include "station/training/case_run.h"
#include "station/training/session.h"

namespace ves::station {
namespace {

constexpr const char* kName = kRunName;

// The inputs of a journal, chunk by chunk up to the first that does not
// decode (written while the station died); *complete false then.
std::vector<training::InputSample> JournaledInputs(const sync::JournalContents& journal,
                                                   bool* complete) {
  std::vector<training::InputSample> inputs;
  *complete = !journal.torn_tail;
  for (const std::string& chunk : journal.chunks) {
    try {
      const std::vector<training::InputSample> part = training::DecodeInputSamples(chunk);
      inputs.insert(inputs.end(), part.begin(), part.end());
    } catch (const training::InputLogError&) {
      *complete = false;
      break;
    }
  }
  return inputs;
}

}  // namespace

void RecoverInterruptedSessions(const sync::StationPaths& paths) {
  sync::RemoveStaleJournalParts(paths.journal());
  const std::vector<std::filesystem::path> journals = sync::ListJournals(paths.journal());
  if (journals.empty()) return;
  std::optional<sync::Outbox> outbox;
  try {
    outbox.emplace(paths.outbox_db());
  } catch (const std::exception& error) {
    std::cerr << kName << ": " << journals.size()
              << " interrupted session(s) wait in the journal: cannot open the outbox: "
              << error.what() << "\n";
    return;
  }
  for (const std::filesystem::path& path : journals) {
    if (sync::JournalInUse(path)) {
      std::cout << "session " << path.stem().string()
                << " is still running in another station process: its journal is left alone\n";
      continue;
    }
    try {
      const sync::JournalContents journal = sync::ReadSessionJournal(path);
      const std::string& uuid = journal.header.uuid();
      std::error_code ignored;
      if (outbox->Find(uuid)) {  // its record was stored before the journal was deleted
        std::filesystem::remove(path, ignored);
        continue;
      }
      bool complete = true;
      const std::vector<training::InputSample> inputs = JournaledInputs(journal, &complete);
      if (inputs.empty()) {  // it had not stepped: nothing to record, as in a live run
        std::filesystem::remove(path, ignored);
        continue;
      }
      const ves::v1::SessionRecord record = training::RecoverSession(journal.header, inputs);
      outbox->Commit(record);
      std::filesystem::remove(path, ignored);
      if (!record.lesson_id().empty()) {
        // A lesson's attempt, like a live one: its verdict is awaited.
        try {
          sync::LessonCache(paths.lessons()).AddAwaited({uuid, record.lesson_id()});
        } catch (const std::exception& error) {
          std::cerr << kName << ": the server's verdict on session " << uuid
                    << " will not be awaited: " << error.what() << "\n";
        }
      }
      std::cout << "session " << uuid << " recovered from the journal of an interrupted run ("
                << std::fixed << std::setprecision(1) << record.metrics().duration_s()
                << " s of inputs" << (complete ? "" : ", its last chunk torn") << ", outcome "
                << training::OutcomeName(static_cast<training::Outcome>(record.outcome()))
                << "): committed to the outbox\n"
                << std::defaultfloat;
    } catch (const std::exception& error) {  // JournalError, ReplayError, InputLogError, disk
      std::error_code moved;
      const std::filesystem::path aside = paths.journal() / "unreadable" / path.filename();
      std::filesystem::create_directories(aside.parent_path(), moved);
      if (!moved) std::filesystem::rename(path, aside, moved);
      std::cerr << kName << ": cannot recover '" << path.string() << "': " << error.what()
                << (moved ? " (left where it is)" : "; set aside as " + aside.string()) << "\n";
    }
  }
}

}  // namespace ves::station
