#include "station/app/haptic_session.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

namespace ves::station {

SessionModelSource::SessionModelSource(training::SessionRunner* runner,
                                       const haptics::SeqLock<ModelControls>* controls,
                                       double coupling_stiffness_N_per_m)
    : runner_(runner),
      controls_(controls),
      coupling_("SessionModelSource", coupling_stiffness_N_per_m) {
  if (runner_ == nullptr || controls_ == nullptr) {
    throw std::invalid_argument("SessionModelSource needs a runner and a controls hand-over");
  }
}

void SessionModelSource::Start(std::int64_t start_unix_ms, double device_insertion_m,
                               double device_roll_rad) {
  coupling_.MapOnto(runner_->state().inserted_m, device_insertion_m);
  roll_offset_rad_ = runner_->state().roll_rad - device_roll_rad;
  have_previous_ = false;
  armed_ = false;
  runner_->Start(start_unix_ms);
}

void SessionModelSource::Arm(double device_insertion_m, double device_roll_rad) {
  if (runner_->session().state() != training::SessionState::kReady) {
    throw std::logic_error("SessionModelSource::Arm: the session is not ready");
  }
  coupling_.MapOnto(runner_->state().inserted_m, device_insertion_m);
  roll_offset_rad_ = runner_->state().roll_rad - device_roll_rad;
  have_previous_ = false;
  armed_ = true;
}

haptics::BaseResponse SessionModelSource::Update(double insertion_m, double roll_rad,
                                                 double /*dt_s*/) {
  if (before_update_) before_update_(insertion_m, roll_rad);
  haptics::BaseResponse response;
  response.update_count = ++updates_;
  stepped_ = false;
  if (armed_ &&
      coupling_.ModelInsertion_m(insertion_m) - runner_->state().inserted_m >= kStartInsertion_m) {
    // The first insertion past the anus: the session's clock starts now.
    armed_ = false;
    const std::int64_t start_unix_ms =
        now_unix_ms_ ? now_unix_ms_()
                     : std::chrono::duration_cast<std::chrono::milliseconds>(
                           std::chrono::system_clock::now().time_since_epoch())
                           .count();
    runner_->Start(start_unix_ms);
    if (on_start_) on_start_(start_unix_ms);
  }
  if (runner_->session().state() != training::SessionState::kRunning) return response;
  if (have_previous_) {
    encoder_travel_m_ += std::abs(insertion_m - previous_insertion_m_);
    roll_travel_rad_ += std::abs(roll_rad - previous_roll_rad_);
  }
  have_previous_ = true;
  previous_insertion_m_ = insertion_m;
  previous_roll_rad_ = roll_rad;

  ModelControls controls;
  controls_->Load(&controls);
  training::InputSample sample;
  sample.thrust_mode = training::ThrustMode::kForce;
  sample.insertion_m = coupling_.ModelInsertion_m(insertion_m);
  sample.push_force_N = coupling_.CalcPushForce_N(insertion_m, runner_->state().inserted_m);
  sample.roll_rad = roll_rad + roll_offset_rad_;
  sample.knob_up_rad = controls.knob_up_rad;
  sample.knob_right_rad = controls.knob_right_rad;
  sample.view_mode = controls.view_mode;
  sample.fluoroscopy_on = controls.fluoroscopy_on;
  sample.abdominal_press = controls.abdominal_press;
  sample.patient_position = controls.patient_position;
  runner_->Step(sample);  // quantizes to the log's resolution first; cannot throw on finite input
  if (runner_->diverged()) {
    response.thrust_force_N = std::numeric_limits<double>::quiet_NaN();
    return response;
  }
  stepped_ = true;
  ++model_steps_;
  // The reaction to what the model got (quantized).
  const training::InputSample& logged = runner_->session().inputs().back();
  response = haptics::VirtualCoupling::CalcReaction(
      logged.push_force_N, runner_->output().roll_torque_Nm, response.update_count);
  if (after_step_) after_step_(*runner_);
  return response;
}

std::string DeviceReportLine(const std::string& device, const std::string& bus,
                             const haptics::DeviceCounters& counters,
                             const SessionModelSource& source,
                             const haptics::SafetyMonitor& safety) {
  char line[512];
  std::snprintf(line, sizeof(line),
                "device=%s bus=%s frames_sent=%llu frames_received=%llu lost_frames=%llu "
                "malformed_frames=%llu bus_errors=%llu model_steps=%llu encoder_travel_m=%.4f "
                "roll_travel_rad=%.4f transient_faults=%llu hard_faults=%llu fault=%s",
                device.c_str(), bus.c_str(),
                static_cast<unsigned long long>(counters.frames_sent),
                static_cast<unsigned long long>(counters.frames_received),
                static_cast<unsigned long long>(counters.lost_frames),
                static_cast<unsigned long long>(counters.malformed_frames),
                static_cast<unsigned long long>(counters.bus_errors),
                static_cast<unsigned long long>(source.model_steps()), source.encoder_travel_m(),
                source.roll_encoder_travel_rad(),
                static_cast<unsigned long long>(safety.transient_faults()),
                static_cast<unsigned long long>(safety.hard_faults()),
                haptics::ToString(safety.fault()));
  return line;
}

ves::v1::StationHealth MakeStationHealth(const std::string& device,
                                         const haptics::DeviceCounters& counters,
                                         const haptics::SafetyMonitor& safety,
                                         const haptics::LoopStats* loop, double period_s) {
  return MakeStationHealth(device, TakeHealthFigures(counters, safety, loop), period_s);
}

HealthFigures TakeHealthFigures(const haptics::DeviceCounters& counters,
                                const haptics::SafetyMonitor& safety,
                                const haptics::LoopStats* loop) {
  HealthFigures f;
  f.counters = counters;
  f.hard_faults = safety.hard_faults();
  f.transient_faults = safety.transient_faults();
  if (loop != nullptr && loop->cycles > 0) {
    f.loop_cycles = loop->cycles;
    f.loop_overruns = loop->overruns;
    f.loop_cycle_p99_us = static_cast<double>(loop->cycle_end.PercentileNs(0.99)) / 1000.0;
  }
  return f;
}

ves::v1::StationHealth MakeStationHealth(const std::string& device, const HealthFigures& f,
                                         double period_s) {
  ves::v1::StationHealth h;
  h.set_device(device);
  h.set_loop_budget_us(period_s * 1e6);
  if (f.loop_cycles > 0) {
    h.set_loop_cycles(f.loop_cycles);
    h.set_loop_cycle_p99_us(f.loop_cycle_p99_us);
    h.set_loop_overruns(f.loop_overruns);
  }
  h.set_hard_faults(f.hard_faults);
  h.set_transient_faults(f.transient_faults);
  h.set_can_bus_errors(f.counters.bus_errors);
  h.set_can_lost_frames(f.counters.lost_frames);
  h.set_can_send_failures(f.counters.send_failures);
  h.set_can_malformed_frames(f.counters.malformed_frames);
  return h;
}

haptics::HandProfile HandForSample(const training::InputSample& sample, double model_offset_m) {
  haptics::HandProfile hand;
  if (sample.thrust_mode == training::ThrustMode::kForce) {
    hand.thrust.drive = haptics::HandDrive::kForce;
    hand.thrust.offset = sample.push_force_N;
  } else {
    hand.thrust.drive = haptics::HandDrive::kPosition;
    hand.thrust.offset = sample.insertion_m - model_offset_m;
  }
  hand.roll.drive = haptics::HandDrive::kPosition;
  hand.roll.offset = sample.roll_rad;
  return hand;
}

}  // namespace ves::station
