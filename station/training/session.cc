#include "station/training/session.h"

#include <algorithm>
#include <stdexcept>

namespace ves::training {

const char* OutcomeName(Outcome outcome) {
  switch (outcome) {
    case Outcome::kCecumReached:
      return "cecum_reached";
    case Outcome::kAborted:
      return "aborted";
    case Outcome::kTimedOut:
      return "timed_out";
    default:
      return "none";
  }
}

Session::Session(SessionConfig config) : config_(std::move(config)), metrics_(config_.thresholds) {
  if (!(config_.dt_s > 0.0 && config_.dt_s < 1.0)) {
    throw std::invalid_argument("session: dt_s must be in (0, 1) s, got " +
                                std::to_string(config_.dt_s));
  }
  if (!(config_.time_limit_s > 0.0)) {
    throw std::invalid_argument("session: time_limit_s must be > 0, got " +
                                std::to_string(config_.time_limit_s));
  }
  if (!(config_.thresholds.cecum_arc_m > 0.0)) {
    throw std::invalid_argument("session: thresholds.cecum_arc_m must be > 0, got " +
                                std::to_string(config_.thresholds.cecum_arc_m));
  }
  // The whole run's log up front: Record runs on the haptic loop's thread,
  // which must not reallocate (a 10-minute session at 1 kHz is ~600k samples).
  // Pages are only touched as the log grows; capped at an hour.
  constexpr double kReserveLimit_s = 3600.0;
  inputs_.reserve(
      static_cast<size_t>(std::min(config_.time_limit_s, kReserveLimit_s) / config_.dt_s) + 2);
}

void Session::Start(std::int64_t start_unix_ms) {
  if (state_ != SessionState::kReady) throw std::logic_error("session: Start when not ready");
  start_unix_ms_ = start_unix_ms;
  state_ = SessionState::kRunning;
}

void Session::Record(const InputSample& input, const StepObservation& observation) {
  if (state_ != SessionState::kRunning) throw std::logic_error("session: Record when not running");
  InputSample logged = Quantize(input);
  logged.tick = inputs_.size();
  inputs_.push_back(logged);
  metrics_.Add(observation);
  if (metrics_.cecum_reached()) {
    outcome_ = Outcome::kCecumReached;
    state_ = SessionState::kFinished;
  } else if (observation.t_s >= config_.time_limit_s - 0.5 * config_.dt_s) {
    outcome_ = Outcome::kTimedOut;
    state_ = SessionState::kFinished;
  }
}

void Session::Abort() {
  if (state_ != SessionState::kRunning) throw std::logic_error("session: Abort when not running");
  outcome_ = Outcome::kAborted;
  state_ = SessionState::kFinished;
}

void Session::Repeat() {
  state_ = SessionState::kReady;
  outcome_ = Outcome::kNone;
  ++repeat_count_;
  metrics_ = MetricsAccumulator(config_.thresholds);
  inputs_.clear();
}

double Session::score() const {
  return CalcScore(metrics(), config_.difficulty, config_.thresholds.cecum_arc_m, config_.score);
}

v1::SessionRecord Session::ToRecord(const std::string& uuid, std::int64_t end_unix_ms) const {
  if (state_ != SessionState::kFinished) {
    throw std::logic_error("session: ToRecord before the session finished");
  }
  v1::SessionRecord r = RecordHeader(config_, uuid, start_unix_ms_);
  r.set_end_unix_ms(end_unix_ms);
  r.set_outcome(static_cast<v1::Outcome>(outcome_));
  *r.mutable_metrics() = ToProto(metrics());
  r.set_score(score());
  if (repeat_count_ > 0) {
    Event repeat{.kind = EventKind::kRepeat,
                 .value = static_cast<double>(repeat_count_),
                 .detail = "repeat training on the same case and scope"};
    *r.add_events() = ToProto(repeat);
  }
  for (const Event& e : metrics_.Events()) *r.add_events() = ToProto(e);
  *r.mutable_input_log() = MakeInputLog(inputs_, config_.dt_s);
  return r;
}

v1::SessionRecord RecordHeader(const SessionConfig& config, const std::string& uuid,
                               std::int64_t start_unix_ms) {
  v1::SessionRecord r;
  r.set_uuid(uuid);
  r.set_trainee_id(config.trainee_id);
  r.set_case_id(config.case_id);
  r.set_case_version(config.case_version);
  r.set_case_sha256_hex(config.case_sha256_hex);
  r.set_station_id(config.station_id);
  r.set_start_unix_ms(start_unix_ms);
  r.mutable_input_log()->set_dt_s(config.dt_s);
  *r.mutable_scope() = config.scope;
  r.set_operator_kind(config.operator_kind);
  r.set_lesson_id(config.lesson_id);
#ifdef VES_VERSION
  r.set_software_version(VES_VERSION);
#endif
  return r;
}

v1::SessionMetrics ToProto(const Metrics& m) {
  v1::SessionMetrics p;
  p.set_duration_s(m.duration_s);
  p.set_completed(m.completed);
  p.set_time_to_cecum_s(m.time_to_cecum_s);
  p.set_peak_insertion_force_n(m.peak_insertion_force_N);
  p.set_mean_insertion_force_n(m.mean_insertion_force_N);
  p.set_excessive_force_episodes(m.excessive_force_episodes);
  p.set_excessive_force_s(m.excessive_force_s);
  p.set_pain_s(m.pain_s);
  p.set_peak_stretch_m(m.peak_stretch_m);
  p.set_loop_s(m.loop_s);
  p.set_loop_count(m.loop_count);
  p.set_redout_s(m.redout_s);
  p.set_mucosa_seen_fraction(m.mucosa_seen_fraction);
  p.set_xray_s(m.xray_s);
  p.set_tip_path_m(m.tip_path_m);
  p.set_max_insertion_m(m.max_insertion_m);
  p.set_max_tip_arc_m(m.max_tip_arc_m);
  p.set_inserted_at_cecum_m(m.inserted_at_cecum_m);
  p.set_damage_events(m.damage_events);
  p.set_damage_impulse_n_s(m.damage_impulse_N_s);
  p.set_press_llq_s(m.press_llq_s);
  p.set_press_mid_s(m.press_mid_s);
  p.set_left_lateral_s(m.left_lateral_s);
  p.set_right_lateral_s(m.right_lateral_s);
  p.set_position_changes(m.position_changes);
  return p;
}

Metrics FromProto(const v1::SessionMetrics& p) {
  Metrics m;
  m.duration_s = p.duration_s();
  m.completed = p.completed();
  m.time_to_cecum_s = p.time_to_cecum_s();
  m.peak_insertion_force_N = p.peak_insertion_force_n();
  m.mean_insertion_force_N = p.mean_insertion_force_n();
  m.excessive_force_episodes = p.excessive_force_episodes();
  m.excessive_force_s = p.excessive_force_s();
  m.pain_s = p.pain_s();
  m.peak_stretch_m = p.peak_stretch_m();
  m.loop_s = p.loop_s();
  m.loop_count = p.loop_count();
  m.redout_s = p.redout_s();
  m.mucosa_seen_fraction = p.mucosa_seen_fraction();
  m.xray_s = p.xray_s();
  m.tip_path_m = p.tip_path_m();
  m.max_insertion_m = p.max_insertion_m();
  m.max_tip_arc_m = p.max_tip_arc_m();
  m.inserted_at_cecum_m = p.inserted_at_cecum_m();
  m.damage_events = p.damage_events();
  m.damage_impulse_N_s = p.damage_impulse_n_s();
  m.press_llq_s = p.press_llq_s();
  m.press_mid_s = p.press_mid_s();
  m.left_lateral_s = p.left_lateral_s();
  m.right_lateral_s = p.right_lateral_s();
  m.position_changes = p.position_changes();
  return m;
}

v1::SessionEvent ToProto(const Event& e) {
  v1::SessionEvent p;
  p.set_t_s(e.t_s);
  p.set_kind(static_cast<v1::EventKind>(e.kind));
  p.set_duration_s(e.duration_s);
  p.set_arc_m(e.arc_m);
  p.set_value(e.value);
  p.set_detail(e.detail);
  return p;
}

}  // namespace ves::training
