#include "station/training/session_runner.h"

#include <stdexcept>
#include <string>

namespace ves::training {

model::StepInput ToStepInput(const InputSample& in) {
  model::StepInput s;
  s.thrust_mode = in.thrust_mode;
  s.insertion_m = in.insertion_m;
  s.push_force_N = in.push_force_N;
  s.roll_rad = in.roll_rad;
  s.knob_up_rad = in.knob_up_rad;
  s.knob_right_rad = in.knob_right_rad;
  const auto press = [&s](model::Region region) {
    s.abdominal_pressure[static_cast<std::size_t>(region)] = 1.0;
  };
  switch (in.abdominal_press) {
    case AbdominalPress::kNone: break;
    case AbdominalPress::kLeftLowerQuadrant:
      // Over the sigmoid apex; a mobile descending colon lies under the same hand.
      press(model::Region::kSigmoid);
      press(model::Region::kDescending);
      break;
    case AbdominalPress::kMidAbdomen: press(model::Region::kTransverse); break;
  }
  switch (in.patient_position) {
    case PatientPosition::kSupine: s.patient_position = model::PatientPosition::kSupine; break;
    case PatientPosition::kLeftLateral:
      s.patient_position = model::PatientPosition::kLeftLateral;
      break;
    case PatientPosition::kRightLateral:
      s.patient_position = model::PatientPosition::kRightLateral;
      break;
  }
  return s;
}

SessionRunner::SessionRunner(model::ModelParams params, SessionConfig config)
    : params_(std::move(params)),
      initial_state_(model::MakeInitialState(params_)),
      state_(initial_state_),
      scratch_(model::MakeScratch(params_)),
      output_(model::MakeStepOutput(params_)),
      observer_(params_),
      session_(std::move(config)) {
  if (params_.dt_s != session_.config().dt_s) {
    throw std::invalid_argument("session runner: model dt_s " + std::to_string(params_.dt_s) +
                                " differs from the session's " +
                                std::to_string(session_.config().dt_s));
  }
}

const StepObservation& SessionRunner::Step(const InputSample& input) {
  InputSample sample = Quantize(input);
  sample.tick = session_.steps();
  if (session_.state() != SessionState::kRunning) {
    throw std::logic_error("session runner: Step when the session is not running");
  }
  model::Step(params_, ToStepInput(sample), &state_, &scratch_, &output_);
  if (!output_.finite) {
    // The step that diverged is not logged: its replay ends one step earlier,
    // also as aborted.
    diverged_ = true;
    session_.Abort();
    return observation_;
  }
  observation_ = observer_.Observe(sample, state_, output_);
  session_.Record(sample, observation_);
  return observation_;
}

void SessionRunner::Repeat() {
  state_ = initial_state_;
  observer_.Reset();
  diverged_ = false;
  session_.Repeat();
}

}  // namespace ves::training
