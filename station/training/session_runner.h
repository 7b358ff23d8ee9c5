#pragma once

#include <cstdint>
#include <functional>

#include "station/model/model.h"
#include "station/training/observer.h"
#include "station/training/session.h"

namespace ves::training {

// The operator's input as the model takes it (one named conversion).
model::StepInput ToStepInput(const InputSample& input);

// Drives the model with an operator's inputs and feeds the session: the one
// input path shared by a person at the device, the scripted operators and
// replay. Each Step quantizes the input to the log's resolution first, so the
// model sees exactly what the log will hold and replay is exact.
class SessionRunner {
 public:
  // Throws std::invalid_argument when params are invalid or dt differs from the config's.
  SessionRunner(model::ModelParams params, SessionConfig config);

  void Start(std::int64_t start_unix_ms) { session_.Start(start_unix_ms); }
  // One model step while running. A non-finite model state aborts the session
  // (diverged() turns true). Returns the observation of this step.
  const StepObservation& Step(const InputSample& input);
  // Repeat training: the model back to its initial state, the session to ready.
  void Repeat();

  const Session& session() const { return session_; }
  Session& session() { return session_; }
  const model::ModelParams& params() const { return params_; }
  const model::ModelState& state() const { return state_; }
  const model::StepOutput& output() const { return output_; }
  const StepObservation& observation() const { return observation_; }
  bool diverged() const { return diverged_; }

 private:
  model::ModelParams params_;
  model::ModelState initial_state_;
  model::ModelState state_;
  model::Scratch scratch_;
  model::StepOutput output_;
  Observer observer_;
  Session session_;
  StepObservation observation_;
  bool diverged_{false};
};

}  // namespace ves::training
