#include "station/app/coupled_loop.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <utility>

#include "station/app/run_sync.h"
#include "station/training/uuid.h"

namespace ves::station {
namespace {

haptics::CycleOptions CycleOptionsFor(double period_s) {
  haptics::CycleOptions options;
  options.period_s = period_s;
  options.control.mode = haptics::ControlMode::kCoupled;
  return options;
}

haptics::LoopOptions LoopOptionsFor(double period_s) {
  haptics::LoopOptions options;
  options.period_s = period_s;
  return options;
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

}  // namespace

LoopSession::LoopSession(const training::CaseRun& run, const ves::v1::ColonCase& colon_case,
                         double time_limit_s, const haptics::SeqLock<ModelControls>* controls,
                         std::mutex* published_mutex, Published* published)
    : runner_(run.params, run.config),
      source_(&runner_, controls),
      colon_case_(colon_case),
      time_limit_s_(time_limit_s),
      published_mutex_(published_mutex),
      published_(published),
      session_uuid_(training::NewUuidV4()) {
  source_.set_before_update(
      [this](double insertion_m, double roll_rad) { BeforeUpdate(insertion_m, roll_rad); });
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

void LoopSession::BeforeUpdate(double insertion_m, double roll_rad) {
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
}

std::vector<EndedSession> LoopSession::TakeEndedRecords() {
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

InteractiveResult LoopSession::Finish() {
  std::lock_guard<std::mutex> lock(record_mutex_);
  if (!kept_) KeepRecord(HealthNow());
  InteractiveResult result;
  result.records = std::move(ready_);
  result.result = last_result_;
  return result;
}

bool LoopSession::Publish() {
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

void LoopSession::JournalStart() {
  JournalEntry entry;
  entry.starts = true;
  entry.uuid = UuidCharsOf(session_uuid_);
  entry.start_unix_ms = start_ms_;
  journal_ring_.Push(entry);
}

void LoopSession::KeepRecord(const HealthFigures& health) {
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

CoupledLoop::CoupledLoop(const training::CaseRun& run, const ves::v1::ColonCase& colon_case,
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

bool CoupledLoop::TakePublication(std::uint64_t* sequence, model::ModelState* state,
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

void CoupledLoop::Repeat(haptics::SafetyFault fault) {
  session_.RequestRepeat();
  // A transient fault clears by itself; a hard one needs the re-arm.
  if (fault != haptics::SafetyFault::kNone && !haptics::IsTransient(fault)) {
    loop_.RequestRearm();
  }
}

InteractiveResult CoupledLoop::Finish() {
  InteractiveResult result = session_.Finish();
  result.device_report = InteractiveReport(*rig_, cycle_, loop_, *session_.source());
  return result;
}

}  // namespace ves::station
