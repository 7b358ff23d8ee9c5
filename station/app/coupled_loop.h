#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "station/app/haptic_session.h"
#include "station/app/interactive_rig.h"
#include "station/app/journal_keeper.h"
#include "station/app/live_publish.h"
#include "station/app/run_interactive.h"
#include "station/haptics/haptic_cycle.h"
#include "station/haptics/haptic_loop.h"
#include "station/haptics/seqlock.h"
#include "station/haptics/spsc_ring.h"
#include "station/model/model.h"
#include "station/training/case_run.h"
#include "station/training/replay.h"
#include "station/training/session_runner.h"
#include "station/ui/training_screen.h"
#include "ves/v1/case.pb.h"

// The 1 kHz side of an interactive run (docs/station-run.md, "Threads"): the
// session's model in the coupled mode behind the device (CoupledLoop), and
// what its thread hands the UI thread (LoopSession): the published model
// state, the journal's entries and the records of ended sessions.
namespace ves::station {

// Loop -> UI: the model's state every kPublishSteps steps, copied under a
// mutex the loop thread only try_locks (same sizes each time: no allocation),
// so a slow UI frame never stalls the haptic loop (it skips a publication).
struct PanelNumbers {
  training::SessionState state{training::SessionState::kReady};
  training::Outcome outcome{training::Outcome::kNone};
  double score{0.0};  // when finished
  double elapsed_s{0.0};
  double time_limit_s{0.0};
  // What the score weighs, live (ui/score_panel.h), and its thresholds.
  ui::ScoreFigures score_figures;
  double excessive_wall_force_N{4.0};
  double damage_wall_force_N{14.0};
  double damage_penalty_points{10.0};
  // For live proctoring (the UI thread streams them): the session's uuid
  // (the record's) and the figures of its latest step; fixed sizes, so the
  // loop copies them without allocating.
  UuidChars session_uuid{};
  LiveFigures live;
};
struct Published {
  model::ModelState state;
  model::StepOutput output;
  PanelNumbers numbers;
  std::uint64_t sequence{0};
};

// The session side of the loop thread: repeats asked for by the UI, records
// of ended sessions, publication of the model state to the UI.
//
// Records are handed to the UI thread as soon as a session ends, so that the
// station can commit each one to its outbox at once. A session that ends on
// its own (cecum, time limit) is built into a record on the UI thread: the
// loop thread no longer steps its model, so reading it there is safe under
// record_mutex_, which the loop thread only try_locks. One finished by a
// repeat is built on the loop thread, as the repeat restarts the model.
class LoopSession {
 public:
  LoopSession(const training::CaseRun& run, const ves::v1::ColonCase& colon_case,
              double time_limit_s, const haptics::SeqLock<ModelControls>* controls,
              std::mutex* published_mutex, Published* published);

  // Before Start: where the station's health figures come from (called on
  // the loop thread, and on the UI thread once the loop stopped) and how
  // they become a record's StationHealth.
  void SetHealth(std::function<HealthFigures()> source,
                 std::function<ves::v1::StationHealth(const HealthFigures&)> to_record) {
    health_source_ = std::move(source);
    health_to_record_ = std::move(to_record);
  }
  // The first session, armed: it starts at the first insertion past the anus.
  void Start(double device_insertion_m, double device_roll_rad) {
    source_.Arm(device_insertion_m, device_roll_rad);
    ready_publication_due_ = !Publish();
  }
  // UI thread, each frame: what the journal is to hold since the last call.
  void DrainJournal(JournalKeeper* keeper) {
    JournalEntry entry;
    while (journal_ring_.Pop(&entry)) {
      if (keeper != nullptr) keeper->Take(entry);
    }
  }
  // UI thread: the loop finishes the current session and starts another.
  void RequestRepeat() { repeat_requests_.fetch_add(1, std::memory_order_acq_rel); }
  // UI thread, each frame: the records of the sessions that ended since the
  // last call, oldest first (usually none).
  std::vector<EndedSession> TakeEndedRecords();
  // After the loop stopped (its thread joined): the records not yet taken,
  // the current session's included.
  InteractiveResult Finish();
  SessionModelSource* source() { return &source_; }

 private:
  // The loop thread, before each model update: publications due, the end of
  // a session noted, a repeat carried out.
  void BeforeUpdate(double insertion_m, double roll_rad);
  bool Publish();
  // A new session's start, to the journal (the thread that starts it).
  void JournalStart();
  // The station's health figures now: on the loop thread, or once it stopped.
  HealthFigures HealthNow() const { return health_source_ ? health_source_() : HealthFigures{}; }
  // The current session's record, with the station's health as it ended,
  // into ready_ (aborted first if it still runs); once per session. Under
  // record_mutex_.
  void KeepRecord(const HealthFigures& health);

  static constexpr int kPublishSteps = ui::kPanelPublishSteps;  // ~60 Hz to the UI at 1 kHz
  training::SessionRunner runner_;
  SessionModelSource source_;
  const ves::v1::ColonCase& colon_case_;
  double time_limit_s_;
  std::mutex* published_mutex_;
  Published* published_;
  std::atomic<std::uint32_t> repeat_requests_{0};
  std::uint32_t repeats_done_{0};
  int steps_since_publish_{0};
  bool final_published_{false};
  bool ready_publication_due_{false};
  std::int64_t start_ms_{0};
  std::string session_uuid_;
  std::function<HealthFigures()> health_source_;
  std::function<ves::v1::StationHealth(const HealthFigures&)> health_to_record_;
  // The session has ended (set by the loop thread with ended_health_).
  std::atomic<bool> ended_{false};
  HealthFigures ended_health_;
  std::atomic<bool> handed_over_{false};  // ready_ has records
  std::mutex record_mutex_;
  bool kept_{false};  // the current session's record is in ready_ (or it had no step)
  std::vector<EndedSession> ready_;
  training::RunResult last_result_;
  haptics::SpscRing<JournalEntry> journal_ring_{kJournalRingEntries};
};

// The 1 kHz side: the session's model in the coupled mode behind the
// device, running and armed; stopped (and the CAN log closed) by Stop() or
// the destructor. The constructor throws std::runtime_error when the loop
// does not start.
class CoupledLoop {
 public:
  CoupledLoop(const training::CaseRun& run, const ves::v1::ColonCase& colon_case,
              double time_limit_s, InteractiveRig* rig);
  ~CoupledLoop() { Stop(); }

  void Stop() {
    loop_.Stop();
    rig_->CloseLog();
  }
  // UI thread: copies the loop's latest publication when there is a new one.
  bool TakePublication(std::uint64_t* sequence, model::ModelState* state,
                       model::StepOutput* output, PanelNumbers* numbers);
  haptics::HapticSnapshot Latest() const {
    haptics::HapticSnapshot snapshot;
    loop_.latest().Load(&snapshot);
    return snapshot;
  }
  // What the operator does, to the loop: the model's controls (knobs, view,
  // X-ray) and repeats; a repeat re-arms a fault that needs it.
  void SetControls(const ModelControls& controls) { model_controls_.Store(controls); }
  void Repeat(haptics::SafetyFault fault);
  // UI thread: the records of sessions that ended since the last call.
  std::vector<EndedSession> TakeEndedRecords() { return session_.TakeEndedRecords(); }
  // UI thread: the running session's new inputs to the journal (null: none kept).
  void DrainJournal(JournalKeeper* keeper) { session_.DrainJournal(keeper); }
  // After Stop(): the records not yet taken and the device line
  // (DeviceReportLine and the loop's timing).
  InteractiveResult Finish();

 private:
  InteractiveRig* rig_;
  double period_s_;
  haptics::SeqLock<ModelControls> model_controls_;
  std::mutex published_mutex_;
  Published published_;
  LoopSession session_;
  haptics::HapticCycle cycle_;
  haptics::HapticLoop loop_;
};

}  // namespace ves::station
