#include "station/app/run_interactive.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "patient_db/case_geometry.h"
#include "patient_db/case_regions.h"
#include "station/app/haptic_session.h"
#include "station/app/live_publish.h"
#include "station/app/run_sync.h"
#include "station/app/run_views.h"
#include "station/haptics/candump_log.h"
#include "station/haptics/haptic_loop.h"
#include "station/haptics/keyboard_push.h"
#include "station/haptics/realtime.h"
#include "station/haptics/seqlock.h"
#include "station/haptics/sim_rig.h"
#include "station/haptics/simulated_ball_drive.h"
#include "station/haptics/spsc_ring.h"
#include "station/haptics/ves4_device.h"
#include "station/render/model_scene.h"
#include "station/sync/session_journal.h"
#include "station/training/replay.h"
#include "station/training/session_runner.h"
#include "station/training/uuid.h"
#include "station/ui/gamepad.h"
#include "station/ui/training_screen.h"
#include "station/ui/training_window.h"

namespace ves::station {
namespace {

// The keys' insertion target leads the scope by at most two key steps: a
// held key against a blocked scope does not wind up a push that goes on
// after the key is released.
constexpr double kKeyLead_m = 0.010;
// The screen is shown at most at a display's refresh rate, and at 10 Hz
// once nothing has moved for a second (a session over, the trainee reading
// the results: the force gauge still moves). The views are rendered only
// when the model published a new state or a view's controls changed. An
// idle screen took a whole core redrawing the same picture
// (docs/station-ui.md, "CPU").
constexpr std::chrono::steady_clock::duration kScreenPeriod = ui::kRunningScreenPeriod;
constexpr std::chrono::steady_clock::duration kIdleScreenPeriod = std::chrono::milliseconds(100);
constexpr std::chrono::steady_clock::duration kIdleAfter = std::chrono::seconds(1);

// UI -> simulated hand: where the keyboard wants the scope (device coordinates).
struct HandTarget {
  double insertion_m{0.0};
  double roll_rad{0.0};
};

// A session's UUID as a fixed, NUL-terminated array, which the loop thread
// can copy without allocating.
using UuidChars = std::array<char, 40>;
UuidChars UuidCharsOf(const std::string& uuid) {
  UuidChars chars{};
  std::memcpy(chars.data(), uuid.data(), std::min(uuid.size(), chars.size() - 1));
  return chars;
}

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

// For people: "cecum reached", "time limit reached", "aborted".
std::string OutcomeText(training::Outcome outcome) {
  switch (outcome) {
    case training::Outcome::kCecumReached: return "cecum reached";
    case training::Outcome::kTimedOut: return "time limit reached";
    case training::Outcome::kAborted: return "aborted";
    case training::Outcome::kNone: break;
  }
  return "-";
}

// The simulated hand on the keyboard's target: it follows no faster than a
// person pushes a colonoscope, with a force that ramps and is bounded to what
// a hand gives (haptics::KeyboardPush, docs/station-ui.md).
class KeyboardHand {
 public:
  KeyboardHand(const haptics::SeqLock<HandTarget>* target, double period_s)
      : target_(target), push_(haptics::KeyboardPushCurve{}, period_s) {}
  void Move(haptics::SimulatedBallDrive* device) {
    HandTarget target;
    target_->Load(&target);
    device->set_hand(push_.Next(target.insertion_m, target.roll_rad, device->plant().insertion_m));
  }

 private:
  const haptics::SeqLock<HandTarget>* target_;
  haptics::KeyboardPush push_;
};

// Loop thread -> UI thread, for the journal of the running session: a
// session's start (its UUID and start time) or one logged input.
struct JournalEntry {
  bool starts{false};
  UuidChars uuid{};
  std::int64_t start_unix_ms{0};
  training::InputSample sample;
};
// 8 s at 1 kHz: the UI thread drains it every frame.
constexpr std::size_t kJournalRingEntries = 8192;

// The UI thread's side of the journal: one file per session
// (sync::SessionJournalWriter) holding its record's header and its inputs in
// chunks of a quarter second. A failure (a full disk, inputs dropped while
// the screen stalled) ends the journaling of that session, said once; its
// record is still stored when it ends, as without a journal.
class JournalKeeper {
 public:
  JournalKeeper(std::filesystem::path dir, const training::CaseRun& run,
                const ves::v1::ColonCase& colon_case, double time_limit_s)
      : dir_(std::move(dir)), header_(training::RecordHeader(run.config, "", 0)) {
    *header_.mutable_replay_setup() = training::MakeReplaySetup(colon_case, {}, time_limit_s);
  }

  // The session's record is in the outbox (and its journal deleted): its
  // writer and lock go.
  void Release(const std::string& uuid) {
    if (writer_ && writer_->uuid() == uuid) {
      writer_.reset();
      pending_.clear();
    }
    std::erase_if(retired_, [&](const auto& w) { return w->uuid() == uuid; });
  }

  void Take(const JournalEntry& entry) {
    if (entry.starts) {
      Flush();
      // The ended session's journal stays locked until its record is
      // committed (Release): a `sync` meanwhile must not recover it too.
      if (writer_) retired_.push_back(std::move(writer_));
      pending_.clear();
      next_tick_ = 0;
      header_.set_uuid(entry.uuid.data());
      header_.set_start_unix_ms(entry.start_unix_ms);
      try {
        writer_ = std::make_unique<sync::SessionJournalWriter>(dir_, header_);
      } catch (const std::exception& error) {
        Fail(error.what());
      }
      return;
    }
    if (!writer_) return;
    if (entry.sample.tick != next_tick_) {
      Fail("inputs from " + std::to_string(next_tick_) + " on were dropped (the screen stalled)");
      return;
    }
    ++next_tick_;
    pending_.push_back(entry.sample);
    if (pending_.size() >= kChunkSamples) Flush();
  }

 private:
  static constexpr std::size_t kChunkSamples = 250;

  void Flush() {
    if (!writer_ || pending_.empty()) return;
    try {
      writer_->Append(training::EncodeInputSamples(pending_));
      pending_.clear();
    } catch (const std::exception& error) {
      Fail(error.what());
    }
  }
  void Fail(const std::string& why) {
    std::cerr << "ves-station: session " << header_.uuid() << " is no longer journaled (" << why
              << "); its record is still stored when it ends\n";
    writer_.reset();
    pending_.clear();
  }

  std::filesystem::path dir_;
  ves::v1::SessionRecord header_;
  std::unique_ptr<sync::SessionJournalWriter> writer_;
  std::vector<std::unique_ptr<sync::SessionJournalWriter>> retired_;  // ended, not yet committed
  std::vector<training::InputSample> pending_;
  std::uint64_t next_tick_{0};
};

// The session side of the loop thread: repeats asked for by the UI, records
// of ended sessions, publication of the model state to the UI.
//
// Records are handed to the UI thread as soon as a session ends, so that the
// station can commit each one to its outbox at once instead of holding the
// sitting's sessions in memory until the trainee quits. A session that ends
// on its own (cecum, time limit) is built into a record on the UI thread:
// the loop thread no longer steps its model, so reading it there is safe
// under record_mutex_, which the loop thread only try_locks. One finished by
// a repeat is built on the loop thread, as the repeat restarts the model.
class LoopSession {
 public:
  LoopSession(const training::CaseRun& run, const ves::v1::ColonCase& colon_case,
              double time_limit_s, const haptics::SeqLock<ModelControls>* controls,
              std::mutex* published_mutex, Published* published)
      : runner_(run.params, run.config),
        source_(&runner_, controls),
        colon_case_(colon_case),
        time_limit_s_(time_limit_s),
        published_mutex_(published_mutex),
        published_(published) {
    source_.set_before_update([this](double insertion_m, double roll_rad) {
      // An armed session does not step: it is shown ready once the UI is not
      // reading (try_lock), with the model back at the anus.
      if (ready_publication_due_) ready_publication_due_ = !Publish();
      const bool finished = runner_.session().state() == training::SessionState::kFinished;
      // A session that just ended is shown as over (once the UI is not
      // reading: try_lock), though no model step publishes it any more.
      if (finished && !final_published_) final_published_ = Publish();
      if (finished && !ended_.load(std::memory_order_relaxed)) {
        // Once per session: the station's health as it ended, for the record
        // the UI thread builds (plain values, no allocation here).
        ended_health_ = HealthNow();
        ended_.store(true, std::memory_order_release);
      }
      const std::uint32_t requested = repeat_requests_.load(std::memory_order_acquire);
      if (requested == repeats_done_) return;
      std::unique_lock<std::mutex> lock(record_mutex_, std::try_to_lock);
      if (!lock.owns_lock()) return;  // the UI is building a record: repeat next cycle
      repeats_done_ = requested;
      if (!kept_) KeepRecord(HealthNow());
      runner_.Repeat();
      kept_ = false;
      ended_.store(false, std::memory_order_release);
      session_uuid_ = training::NewUuidV4();  // a one-off, like KeepRecord's record
      final_published_ = false;
      // Clean: the new session starts at its first insertion (on_start).
      source_.Arm(insertion_m, roll_rad);
      ready_publication_due_ = true;
    });
    source_.set_clock(NowUnixMs);
    source_.set_on_start([this](std::int64_t start_unix_ms) {
      start_ms_ = start_unix_ms;
      JournalStart();
    });
    source_.set_after_step([this](const training::SessionRunner& runner) {
      // A full ring drops the input; the keeper sees the gap in the ticks.
      journal_ring_.Push(JournalEntry{.sample = runner.session().inputs().back()});
      if (++steps_since_publish_ >= kPublishSteps && Publish()) steps_since_publish_ = 0;
    });
  }

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
  std::vector<EndedSession> TakeEndedRecords() {
    std::vector<EndedSession> taken;
    if (!ended_.load(std::memory_order_acquire) && !handed_over_.load(std::memory_order_acquire)) {
      return taken;
    }
    std::lock_guard<std::mutex> lock(record_mutex_);
    if (ended_.load(std::memory_order_acquire) && !kept_) KeepRecord(ended_health_);
    taken.swap(ready_);
    handed_over_.store(false, std::memory_order_release);
    return taken;
  }
  // After the loop stopped (its thread joined): the records not yet taken,
  // the current session's included.
  InteractiveResult Finish() {
    std::lock_guard<std::mutex> lock(record_mutex_);
    if (!kept_) KeepRecord(HealthNow());
    InteractiveResult result;
    result.records = std::move(ready_);
    result.result = last_result_;
    return result;
  }
  SessionModelSource* source() { return &source_; }

 private:
  bool Publish() {
    std::unique_lock<std::mutex> lock(*published_mutex_, std::try_to_lock);
    if (!lock.owns_lock()) return false;
    const training::Session& session = runner_.session();
    const training::Metrics metrics = session.metrics();
    published_->state = runner_.state();
    published_->output = runner_.output();
    PanelNumbers& numbers = published_->numbers;
    numbers.state = session.state();
    numbers.outcome = session.outcome();
    numbers.score =
        session.state() == training::SessionState::kFinished ? session.score() : 0.0;
    numbers.elapsed_s = metrics.duration_s;
    numbers.time_limit_s = session.config().time_limit_s;
    numbers.excessive_wall_force_N = session.config().thresholds.excessive_wall_force_N;
    numbers.damage_wall_force_N = session.config().thresholds.damage_wall_force_N;
    numbers.damage_penalty_points = session.config().score.damage_penalty_points;
    ui::TrackScoreFigures(metrics, runner_.observation().max_wall_force_N, &numbers.score_figures);
    numbers.session_uuid = UuidCharsOf(session_uuid_);
    numbers.live = LiveFiguresOf(runner_);
    ++published_->sequence;
    return true;
  }

  // A new session's start, to the journal (the thread that starts it).
  void JournalStart() {
    JournalEntry entry;
    entry.starts = true;
    entry.uuid = UuidCharsOf(session_uuid_);
    entry.start_unix_ms = start_ms_;
    journal_ring_.Push(entry);
  }

  // The station's health figures now: on the loop thread, or once it stopped.
  HealthFigures HealthNow() const { return health_source_ ? health_source_() : HealthFigures{}; }

  // The current session's record, with the station's health as it ended,
  // into ready_ (aborted first if it still runs); once per session. Under
  // record_mutex_.
  void KeepRecord(const HealthFigures& health) {
    kept_ = true;
    training::Session& session = runner_.session();
    if (session.steps() == 0) return;
    if (session.state() == training::SessionState::kRunning) session.Abort();
    last_result_ = training::ResultOf(runner_);
    const auto duration_ms =
        static_cast<std::int64_t>(std::llround(last_result_.metrics.duration_s * 1e3));
    // The uuid its live stream used: the server's live view and record agree.
    ves::v1::SessionRecord record = session.ToRecord(session_uuid_, start_ms_ + duration_ms);
    *record.mutable_replay_setup() = training::MakeReplaySetup(colon_case_, {}, time_limit_s_);
    if (health_to_record_) *record.mutable_station_health() = health_to_record_(health);
    ready_.push_back(EndedSession{std::move(record), last_result_});
    handed_over_.store(true, std::memory_order_release);
  }

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
  std::string session_uuid_{training::NewUuidV4()};
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

// Device bring-up: the bus (SocketCAN to the real VES-IV, or a socketpair to
// the simulated one served on the loop's thread, its hand on the keyboard),
// the driver, the candump log.
class InteractiveRig {
 public:
  InteractiveRig(InteractiveDevice device, double period_s,
                 const haptics::SeqLock<HandTarget>* hand_target)
      : simulated_(!device.can_bus.has_value()), keyboard_hand_(hand_target, period_s) {
    std::optional<haptics::CanBus> device_end;
    haptics::CanBus host_end = [&] {
      if (!simulated_) return std::move(*device.can_bus);
      auto [host, sim] = haptics::CanBus::CreateSocketPair();
      device_end.emplace(std::move(sim));
      return std::move(host);
    }();
    bus_name_ = simulated_ ? "socketpair" : host_end.name();
    haptics::SimulatedBallDriveOptions device_options;
    device_options.period_s = period_s;
    haptics::Ves4DeviceOptions driver_options;
    driver_options.period_s = period_s;
    driver_ = std::make_unique<haptics::Ves4Device>(std::move(host_end), device_options.params,
                                                    driver_options);
    if (!device.can_log.empty()) {
      recorder_ = std::make_unique<haptics::CanFrameRecorder>(
          device.can_log, simulated_ ? "sim0" : bus_name_,
          haptics::MonotonicToEpochOffsetSeconds());
      driver_->SetRecorder(recorder_.get());
    }
    device_ = driver_.get();
    if (simulated_) {
      // Served on the loop's thread: it answers every SYNC in time, as the
      // real device's own hardware does (haptics::InlineSimulatedDevice).
      simulated_device_ =
          std::make_unique<haptics::SimulatedBallDrive>(std::move(*device_end), device_options);
      inline_device_ =
          std::make_unique<haptics::InlineSimulatedDevice>(driver_.get(), simulated_device_.get());
      inline_device_->set_before_service(
          [this](double, haptics::SimulatedBallDrive* sim) { keyboard_hand_.Move(sim); });
      device_ = inline_device_.get();
    }
    if (!haptics::BringUpDevice(device_, &initial_state_, 2.0)) {
      throw std::runtime_error("the VES-IV on " + bus_name_ +
                               " did not become operational within 2 s");
    }
  }

  haptics::HapticDevice* device() { return device_; }
  const haptics::DeviceState& initial_state() const { return initial_state_; }
  bool simulated() const { return simulated_; }
  const std::string& bus_name() const { return bus_name_; }
  std::string label() const { return simulated_ ? "sim" : "can:" + bus_name_; }
  void CloseLog() {
    if (recorder_) recorder_->Close();
  }

 private:
  bool simulated_;
  std::string bus_name_;
  KeyboardHand keyboard_hand_;
  std::unique_ptr<haptics::Ves4Device> driver_;
  std::unique_ptr<haptics::CanFrameRecorder> recorder_;
  std::unique_ptr<haptics::SimulatedBallDrive> simulated_device_;
  std::unique_ptr<haptics::InlineSimulatedDevice> inline_device_;
  haptics::HapticDevice* device_{nullptr};
  haptics::DeviceState initial_state_;
};

// The device line of the screen: force feedback on, fading in, paused by a
// transient fault (clears by itself) or in the safe state (r re-arms).
void DescribeDevice(const haptics::HapticSnapshot& snapshot, const std::string& label,
                    ui::ScreenModel* screen) {
  const haptics::SafetyFault fault = snapshot.fault;
  if (fault == haptics::SafetyFault::kNone) {
    screen->device_status =
        snapshot.output_scale < 1.0 ? ui::DeviceStatus::kRecovering : ui::DeviceStatus::kOk;
    screen->device_text = label + (snapshot.output_scale < 1.0 ? ", force fading back in"
                                                               : ", force feedback on");
  } else if (haptics::IsTransient(fault)) {
    screen->device_status = ui::DeviceStatus::kRecovering;
    screen->device_text = label + ", force paused: " + haptics::ToString(fault) +
                          " (recovers by itself)";
  } else {
    screen->device_status = ui::DeviceStatus::kSafe;
    screen->device_text =
        label + ", SAFE STATE: " + haptics::ToString(fault) + " - no force; r re-arms";
  }
}

// Everything the screen shows besides the views, from the latest
// publication of the loop and the device's snapshot.
void FillScreenModel(const PanelNumbers& numbers, const haptics::HapticSnapshot& snapshot,
                     const model::ModelState& state, const ves::v1::ColonCase& colon_case,
                     const std::string& device_label, ui::ScreenModel* screen) {
  switch (numbers.state) {
    case training::SessionState::kReady: screen->phase = ui::SessionPhase::kReady; break;
    case training::SessionState::kRunning: screen->phase = ui::SessionPhase::kRunning; break;
    case training::SessionState::kFinished: screen->phase = ui::SessionPhase::kOver; break;
  }
  screen->outcome = OutcomeText(numbers.outcome);
  screen->score = numbers.score;
  screen->elapsed_s = numbers.elapsed_s;
  screen->time_limit_s = numbers.time_limit_s;
  screen->inserted_m = state.inserted_m;
  screen->tip_arc_m = state.tip_arc_m;
  screen->tip_region = patient_db::RegionName(patient_db::CalcRegionAt(colon_case, state.tip_arc_m));
  screen->roll_rad = state.roll_rad;
  screen->hand_force_N = snapshot.force_N;
  screen->score_figures = numbers.score_figures;
  screen->excessive_wall_force_N = numbers.excessive_wall_force_N;
  screen->damage_wall_force_N = numbers.damage_wall_force_N;
  screen->damage_penalty_points = numbers.damage_penalty_points;
  DescribeDevice(snapshot, device_label, screen);
}

// The device line at the end of a run: what went over the bus, the safety
// monitor's counts and the loop's timing.
std::string InteractiveReport(InteractiveRig& rig, const haptics::HapticCycle& cycle,
                              const haptics::HapticLoop& loop, const SessionModelSource& source) {
  std::string report = DeviceReportLine(rig.label(), rig.bus_name(), rig.device()->counters(),
                                        source, cycle.safety());
  const haptics::LoopStats& stats = loop.stats();
  char timing[240];
  std::snprintf(timing, sizeof(timing),
                " loop_cycles=%llu overruns=%llu station_stalls=%llu p99_period_error_us=%.0f "
                "p99_cycle_end_us=%.0f",
                static_cast<unsigned long long>(stats.cycles),
                static_cast<unsigned long long>(stats.overruns),
                static_cast<unsigned long long>(cycle.safety().stalls()),
                static_cast<double>(stats.period_error.PercentileNs(0.99)) / 1000.0,
                static_cast<double>(stats.cycle_end.PercentileNs(0.99)) / 1000.0);
  return report + timing;
}

// The 1 kHz side: the session's model in the coupled mode behind the
// device, running and armed; stopped (and the CAN log closed) by Stop() or
// the destructor.
class CoupledLoop {
 public:
  CoupledLoop(const training::CaseRun& run, const ves::v1::ColonCase& colon_case,
              double time_limit_s, InteractiveRig* rig)
      : rig_(rig),
        period_s_(run.params.dt_s),
        session_(run, colon_case, time_limit_s, &model_controls_, &published_mutex_, &published_),
        cycle_(rig->device(), session_.source(), CycleOptionsFor(run.params.dt_s)),
        loop_(&cycle_, LoopOptionsFor(run.params.dt_s)) {
    session_.SetHealth(
        [this] {
          return TakeHealthFigures(rig_->device()->counters(), cycle_.safety(), &loop_.stats());
        },
        [label = rig->label(), period_s = period_s_](const HealthFigures& figures) {
          return MakeStationHealth(label, figures, period_s);
        });
    session_.Start(rig->initial_state().insertion_m, rig->initial_state().roll_rad);
    cycle_.SetInitialDeviceState(rig->initial_state());
    loop_.Start();
    if (!loop_.ArmAfter(20, 2.0)) {
      Stop();
      throw std::runtime_error("the haptic loop did not start");
    }
  }
  ~CoupledLoop() { Stop(); }

  void Stop() {
    loop_.Stop();
    rig_->CloseLog();
  }
  // UI thread: copies the loop's latest publication when there is a new one.
  bool TakePublication(std::uint64_t* sequence, model::ModelState* state,
                       model::StepOutput* output, PanelNumbers* numbers) {
    // Only copies under the lock (the loop skips a publication meanwhile).
    std::lock_guard<std::mutex> lock(published_mutex_);
    if (published_.sequence == *sequence) return false;
    *state = published_.state;
    *output = published_.output;
    *numbers = published_.numbers;
    *sequence = published_.sequence;
    return true;
  }
  haptics::HapticSnapshot Latest() const {
    haptics::HapticSnapshot snapshot;
    loop_.latest().Load(&snapshot);
    return snapshot;
  }
  // What the operator does, to the loop: the model's controls (knobs, view,
  // X-ray) and repeats; a repeat re-arms a fault that needs it.
  void SetControls(const ModelControls& controls) { model_controls_.Store(controls); }
  void Repeat(haptics::SafetyFault fault) {
    session_.RequestRepeat();
    // A transient fault clears by itself; a hard one needs the re-arm.
    if (fault != haptics::SafetyFault::kNone && !haptics::IsTransient(fault)) {
      loop_.RequestRearm();
    }
  }
  // UI thread: the records of sessions that ended since the last call.
  std::vector<EndedSession> TakeEndedRecords() { return session_.TakeEndedRecords(); }
  // UI thread: the running session's new inputs to the journal (null: none kept).
  void DrainJournal(JournalKeeper* keeper) { session_.DrainJournal(keeper); }
  // After Stop().
  InteractiveResult Finish() {
    InteractiveResult result = session_.Finish();
    result.device_report = InteractiveReport(*rig_, cycle_, loop_, *session_.source());
    return result;
  }

 private:
  static haptics::CycleOptions CycleOptionsFor(double period_s) {
    haptics::CycleOptions options;
    options.period_s = period_s;
    options.control.mode = haptics::ControlMode::kCoupled;
    return options;
  }
  static haptics::LoopOptions LoopOptionsFor(double period_s) {
    haptics::LoopOptions options;
    options.period_s = period_s;
    return options;
  }

  InteractiveRig* rig_;
  double period_s_;
  haptics::SeqLock<ModelControls> model_controls_;
  std::mutex published_mutex_;
  Published published_;
  LoopSession session_;
  haptics::HapticCycle cycle_;
  haptics::HapticLoop loop_;
};

// What the two views show besides the model's state.
struct ViewControls {
  training::ViewMode view_mode{};
  bool fluoroscopy_visible{false};
  FluoroscopyControls fluoro;
  bool operator==(const ViewControls&) const = default;
};

ViewControls ViewControlsOf(const ui::ControlState& c) {
  return {
      c.view_mode, c.fluoroscopy_visible,
      FluoroscopyControls{c.fluoro_yaw_rad, c.fluoro_pitch_rad, c.fluoro_zoom, c.damage_display}};
}

// The training screen on the UI thread until the trainee quits or picks
// another case or scope: composes the screen from the loop's latest
// publication, polls keys and mouse, hands the controls to the loop and the
// keyboard's hand target to the simulated hand. Returns the chosen case and
// scope when the run is to switch.
struct ScreenExit {
  std::optional<int> next_case;
  std::optional<int> next_scope;
};

ScreenExit RunTrainingScreen(const training::CaseRun& run, const ves::v1::ColonCase& colon_case,
                             const ves::v1::LessonAids* lesson_aids,
                             const InteractiveChoices* choices, const std::string& device_label,
                             ui::TrainingWindow* window, SessionViews* views, CoupledLoop* loop,
                             haptics::SeqLock<HandTarget>* hand, InteractiveLive* live,
                             JournalKeeper* journal, const training::Sitting* sitting,
                             ui::EvdevGamepad* gamepad,
                             const std::function<void(EndedSession)>& keep) {
  ui::ControlState controls;
  // A lesson's aids that are off stay off, whatever the keys and panel ask.
  auto enforce_aids = [lesson_aids](ui::ControlState* c) {
    if (lesson_aids == nullptr) return;
    if (!lesson_aids->fluoroscopy_allowed()) c->fluoroscopy_visible = false;
    if (!lesson_aids->wireframe_allowed() && c->view_mode == training::ViewMode::kWireframe) {
      c->view_mode = training::ViewMode::kFlat;
    }
  };
  enforce_aids(&controls);
  ui::ScreenModel screen;
  training::Sitting own_sitting;
  screen.case_names = {colon_case.id()};
  screen.scope_names = {"default"};
  screen.fluoroscopy_allowed = lesson_aids == nullptr || lesson_aids->fluoroscopy_allowed();
  if (choices != nullptr && !choices->case_names.empty() && !choices->scope_names.empty()) {
    screen.case_names = choices->case_names;
    screen.scope_names = choices->scope_names;
    controls.case_choice = choices->current_case;
    controls.scope_choice = choices->current_scope;
  }
  render::SceneGeometry scene;
  model::ModelState shown_state;
  model::StepOutput shown_output;
  PanelNumbers numbers;
  std::uint64_t shown_sequence = 0;
  cv::Mat endoscope;
  cv::Mat fluoroscopy;
  std::optional<ViewControls> rendered_with;  // the controls of the views shown; none yet
  auto next_screen = std::chrono::steady_clock::now();
  auto last_activity = next_screen;  // a new state, a view change or an input
  auto last_gamepad_poll = next_screen;
  while (!controls.quit_requested) {
    const bool fresh =
        loop->TakePublication(&shown_sequence, &shown_state, &shown_output, &numbers);
    loop->DrainJournal(journal);  // before the records: an ended session's inputs are all in
    for (auto& session : loop->TakeEndedRecords()) {
      // The debrief of the session that just ended, with the sitting's best
      // and last (the caller's sitting, which keep() adds it to; else this
      // run's own).
      screen.debrief = session.result.debrief;
      if (sitting == nullptr) own_sitting.Add(session.record, session.result);
      keep(std::move(session));
      screen.sitting_line = ui::SittingLine(sitting != nullptr ? *sitting : own_sitting);
    }
    if (fresh) render::FillSceneFromModel(run.params, shown_state, &shown_output, {}, &scene);
    const haptics::HapticSnapshot snapshot = loop->Latest();
    FillScreenModel(numbers, snapshot, shown_state, colon_case, device_label, &screen);
    const ViewControls wanted = ViewControlsOf(controls);
    const bool views_changed = fresh || rendered_with != wanted;
    const auto now = std::chrono::steady_clock::now();
    if (views_changed) last_activity = now;
    if (views_changed && shown_sequence > 0) {
      endoscope = views->Endoscope(scene, wanted.view_mode);
      fluoroscopy =
          wanted.fluoroscopy_visible ? views->Fluoroscopy(scene, wanted.fluoro) : cv::Mat();
      rendered_with = wanted;
    }
    if (fresh) {
      // Built here, not in the loop: the 1 kHz thread only copied plain values.
      live->OnPublication(
          numbers.session_uuid.data(), numbers.state == training::SessionState::kRunning,
          numbers.live.t_s, [&] { return MakeLiveFrame(shown_state, numbers.live); },
          [&] { return EncodeLiveJpeg(endoscope); });
    } else {
      live->Poll();
    }
    if (now >= next_screen) {
      window->Show(ui::ComposeScreen(window->layout(), endoscope, fluoroscopy, screen, controls));
      const auto period = now - last_activity < kIdleAfter ? kScreenPeriod : kIdleScreenPeriod;
      next_screen += period;
      if (next_screen < now) next_screen = now + period;  // fell behind: no burst
    }
    // Nothing is due before the next screen; a key or a click ends the wait
    // at once (waitKeyEx).
    const auto until_screen = std::chrono::duration_cast<std::chrono::milliseconds>(
        next_screen - std::chrono::steady_clock::now());
    const int wait_ms = static_cast<int>(std::clamp<std::int64_t>(until_screen.count(), 1, 100));
    if (window->Poll(wait_ms, screen, &controls) > 0) {
      last_activity = std::chrono::steady_clock::now();
      next_screen = last_activity;  // show the key's effect at once
    }
    if (gamepad != nullptr) {
      // The controller's axes held since the last frame move the hand and knobs.
      const auto polled = std::chrono::steady_clock::now();
      if (gamepad->Poll()) last_activity = polled;
      ui::ApplyGamepad(gamepad->axes(),
                       std::chrono::duration<double>(polled - last_gamepad_poll).count(),
                       ui::GamepadRates{}, ui::KeyboardHand{}, &controls);
      last_gamepad_poll = polled;
    }
    enforce_aids(&controls);
    if (controls.repeat_requested && choices != nullptr &&
        (controls.case_choice != choices->current_case ||
         controls.scope_choice != choices->current_scope)) {
      // Another case or scope: this run ends, the caller starts that one.
      return {controls.case_choice, controls.scope_choice};
    }
    if (controls.repeat_requested) {
      // The hand stays where it is; the new session maps the model onto it
      // and starts clean (X-ray off, C-arm home) at its first insertion.
      controls.repeat_requested = false;
      ui::StartClean(&controls);
      enforce_aids(&controls);
      loop->Repeat(snapshot.fault);
    }
    controls.hand_insertion_m = std::clamp(controls.hand_insertion_m, snapshot.insertion_m - kKeyLead_m,
                                           snapshot.insertion_m + kKeyLead_m);
    hand->Store(HandTarget{controls.hand_insertion_m, controls.hand_roll_rad});
    loop->SetControls(ModelControls{controls.knob_up_rad, controls.knob_right_rad,
                                    controls.view_mode, controls.fluoroscopy_visible,
                                    controls.abdominal_press, controls.patient_position});
  }
  return {};
}

}  // namespace

InteractiveResult RunInteractive(const training::CaseRun& run,
                                 const ves::v1::ColonCase& colon_case, double time_limit_s,
                                 InteractiveDevice device, const ves::v1::LessonAids* lesson_aids,
                                 const InteractiveChoices* choices,
                                 const InteractiveLiveTarget* live_target,
                                 const SessionEndedCallback& on_session_ended,
                                 const std::filesystem::path& journal_dir,
                                 const training::Sitting* sitting) {
  ui::TrainingWindow window;  // throws first when there is no display
  std::optional<ui::EvdevGamepad> gamepad;
  if (!device.gamepad.empty()) gamepad.emplace(device.gamepad);
  SessionViews views(run.params, colon_case);
  haptics::SeqLock<HandTarget> hand;
  InteractiveRig rig(std::move(device), run.params.dt_s, &hand);
  InteractiveLive live(live_target ? live_target->server : std::nullopt, run.config.trainee_id,
                       live_target ? live_target->case_id : colon_case.id(),
                       live_target ? live_target->case_version : 0);
  std::optional<JournalKeeper> journal;
  if (!journal_dir.empty()) journal.emplace(journal_dir, run, colon_case, time_limit_s);
  CoupledLoop loop(run, colon_case, time_limit_s, &rig);
  // Records of sessions that end while the screen runs: to the caller at
  // once (its journal locked until then), or kept for the result.
  std::vector<EndedSession> ended;
  const auto keep = [&](EndedSession session) {
    if (on_session_ended) {
      const std::string uuid = session.record.uuid();
      on_session_ended(std::move(session));
      if (journal) journal->Release(uuid);
    } else {
      ended.push_back(std::move(session));
    }
  };
  const ScreenExit exit = RunTrainingScreen(run, colon_case, lesson_aids, choices, rig.label(),
                                            &window, &views, &loop, &hand, &live,
                                            journal ? &*journal : nullptr, sitting,
                                            gamepad ? &*gamepad : nullptr, keep);
  loop.Stop();
  InteractiveResult result = loop.Finish();
  if (on_session_ended) {
    // The last session's too, while the journal keeper still holds its lock.
    for (auto& session : result.records) keep(std::move(session));
    result.records.clear();
  }
  result.records.insert(result.records.begin(), std::make_move_iterator(ended.begin()),
                        std::make_move_iterator(ended.end()));
  std::ostringstream live_report;
  live.Finish(live_report);
  result.live_report = live_report.str();
  result.next_case = exit.next_case;
  result.next_scope = exit.next_scope;
  return result;
}

}  // namespace ves::station
