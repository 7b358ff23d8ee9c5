#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "station/training/input_log.h"
#include "station/training/metrics.h"
#include "station/training/score.h"
#include "ves/v1/case.pb.h"
#include "ves/v1/endoscope.pb.h"
#include "ves/v1/session.pb.h"

namespace ves::training {

enum class SessionState { kReady, kRunning, kFinished };
// Same numbering as ves.v1.Outcome.
enum class Outcome : int { kNone = 0, kCecumReached = 1, kAborted = 2, kTimedOut = 3 };

const char* OutcomeName(Outcome outcome);  // "cecum_reached", "aborted", "timed_out", "none"

// Who, what and under which rules a session runs.
struct SessionConfig {
  std::string trainee_id;
  std::string station_id;
  std::string operator_kind{"human"};  // "human", "novice", "expert"
  std::string lesson_id;
  std::string case_id;
  std::uint32_t case_version{0};
  std::string case_sha256_hex;
  v1::Difficulty difficulty{v1::DIFFICULTY_UNSPECIFIED};
  v1::EndoscopeSpec scope;
  double dt_s{0.001};          // the model rate
  double time_limit_s{600.0};  // running longer than this times out
  MetricThresholds thresholds;
  ScoreParams score;
};

// One training session (DESIGN.md §5): ready -> running -> finished (cecum
// reached | aborted | timed out). Fed once per model step with the operator's
// input and what the model did; keeps the input log and the metrics. "Repeat
// training" (paper §4.4) takes it back to ready on the same case and scope.
// The model itself is driven by the caller (SessionRunner), so this class is
// testable on constructed observations.
class Session {
 public:
  // Throws std::invalid_argument on a non-positive dt_s or time limit.
  explicit Session(SessionConfig config);

  // ready -> running; throws std::logic_error in any other state.
  void Start(std::int64_t start_unix_ms);
  // One model step while running (std::logic_error otherwise): logs the
  // (quantized) input, accumulates the observation, then finishes the session
  // when the cecum is reached or the time limit passed.
  void Record(const InputSample& input, const StepObservation& observation);
  // running -> finished (aborted); throws std::logic_error when not running.
  void Abort();
  // Any state -> ready, same case and scope: clears the log and the metrics.
  void Repeat();

  SessionState state() const { return state_; }
  Outcome outcome() const { return outcome_; }
  int repeat_count() const { return repeat_count_; }
  std::uint64_t steps() const { return inputs_.size(); }
  const SessionConfig& config() const { return config_; }
  const MetricsAccumulator& accumulator() const { return metrics_; }
  const std::vector<InputSample>& inputs() const { return inputs_; }
  Metrics metrics() const { return metrics_.Result(); }
  double score() const;

  // The result (finished sessions only, std::logic_error otherwise), with the
  // given UUID (NewUuidV4() for a new record).
  v1::SessionRecord ToRecord(const std::string& uuid, std::int64_t end_unix_ms) const;

 private:
  SessionConfig config_;
  SessionState state_{SessionState::kReady};
  Outcome outcome_{Outcome::kNone};
  int repeat_count_{0};
  std::int64_t start_unix_ms_{0};
  MetricsAccumulator metrics_;
  std::vector<InputSample> inputs_;
};

// Who, what and when of a session's record, without its outcome, results or
// inputs (input_log carries only dt_s): the start of Session::ToRecord, and
// the header of the station's journal of a running session.
v1::SessionRecord RecordHeader(const SessionConfig& config, const std::string& uuid,
                               std::int64_t start_unix_ms);

v1::SessionMetrics ToProto(const Metrics& metrics);
Metrics FromProto(const v1::SessionMetrics& metrics);
v1::SessionEvent ToProto(const Event& event);

}  // namespace ves::training
