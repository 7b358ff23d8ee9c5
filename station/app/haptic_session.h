#pragma once

// The training session behind the haptic device (DESIGN.md §3, coupled mode):
// the 1 kHz HapticCycle asks SessionModelSource for the model's base response
// once per period with the device's encoder readings; the source steps the
// session's model (SessionRunner, so the session logs exactly what the model
// was given) and returns the force and torque the motors render to the hand.
//
// Thrust goes through the virtual coupling (haptics::VirtualCoupling):
// F_c = k_c·(x_device + offset − x_model) pushes the model's base
// (ThrustMode::kForce) and the hand feels −F_c. Roll is prescribed by the roll
// encoder. The logged InputSample holds F_c as push_force_N (what the model
// used), the encoder insertion mapped into the model (insertion_m, for the
// record) and the encoder roll, plus the knobs, view mode and fluoroscopy that
// pass straight from the operator to the model: replay is the model alone.
#include <cstdint>
#include <functional>
#include <string>

#include "station/haptics/base_response.h"
#include "station/haptics/device.h"
#include "station/haptics/hand_profile.h"
#include "station/haptics/haptic_loop.h"
#include "station/haptics/safety_monitor.h"
#include "station/haptics/seqlock.h"
#include "station/haptics/virtual_coupling.h"
#include "station/training/input_log.h"
#include "station/training/session_runner.h"
#include "ves/v1/session.pb.h"

namespace ves::station {

// Operator -> model, handed to the loop thread through a SeqLock (trivially
// copyable): what the hands do at the scope's control section, not at the
// device.
struct ModelControls {
  double knob_up_rad{0.0};
  double knob_right_rad{0.0};
  training::ViewMode view_mode{training::ViewMode::kTextured};
  bool fluoroscopy_on{false};
  training::AbdominalPress abdominal_press{training::AbdominalPress::kNone};
  training::PatientPosition patient_position{training::PatientPosition::kSupine};
};

class SessionModelSource final : public haptics::BaseResponseSource {
 public:
  static constexpr double kCouplingStiffness_N_per_m =
      haptics::VirtualCoupling::kDefaultStiffness_N_per_m;

  // Neither pointer may be null; both must outlive the source.
  SessionModelSource(training::SessionRunner* runner,
                     const haptics::SeqLock<ModelControls>* controls,
                     double coupling_stiffness_N_per_m = kCouplingStiffness_N_per_m);

  // How far past the anus the scope must first go in for an armed session
  // to start: 2 mm, far above the encoders' noise (micrometres) and a
  // fraction of one push (the keyboard's is 5 mm).
  static constexpr double kStartInsertion_m = 0.002;

  // Starts the runner's session (it must be ready) with the model's insertion
  // and roll mapped onto the device's present readings.
  void Start(std::int64_t start_unix_ms, double device_insertion_m, double device_roll_rad);
  // The interactive start (docs/station-run.md, "A sitting"): the model is
  // mapped onto the device's present readings as by Start, but the session
  // (it must be ready) starts only at the first insertion past the anus, when
  // the device has moved the scope kStartInsertion_m in from there; until
  // then Update steps nothing, logs nothing and renders no force, so the
  // clock does not run while the window opens or the trainee reads. The
  // session then starts at `now_unix_ms()` and on_start (if set) is called,
  // both on the loop thread.
  void Arm(double device_insertion_m, double device_roll_rad);
  bool armed() const { return armed_; }
  // Set before the loop starts. The clock defaults to the system's.
  void set_clock(std::function<std::int64_t()> now_unix_ms) { now_unix_ms_ = std::move(now_unix_ms); }
  void set_on_start(std::function<void(std::int64_t start_unix_ms)> hook) {
    on_start_ = std::move(hook);
  }

  // Loop thread. While the session runs: one model step. Otherwise an idle
  // response (no force) whose update count still advances: the model thread
  // is alive, there is just no session to render. The readings are finite:
  // HapticCycle::Run checks them where they enter and calls no source with a
  // non-finite one. Never throws; a diverged model gives NaN, which the
  // safety monitor trips on.
  haptics::BaseResponse Update(double insertion_m, double roll_rad, double dt_s) override;

  // Called on the loop thread before each Update with the encoder readings
  // (repeat handling) and after each model step (hand-over to other threads).
  // Set before the loop starts; may be empty.
  void set_before_update(std::function<void(double insertion_m, double roll_rad)> hook) {
    before_update_ = std::move(hook);
  }
  void set_after_step(std::function<void(const training::SessionRunner&)> hook) {
    after_step_ = std::move(hook);
  }

  double insertion_offset_m() const { return coupling_.insertion_offset_m(); }  // model − device
  bool stepped() const { return stepped_; }  // whether the last Update stepped the model
  std::uint64_t model_steps() const { return model_steps_; }
  // Distance the insertion encoder moved while a session ran (sum of |Δx|).
  double encoder_travel_m() const { return encoder_travel_m_; }
  double roll_encoder_travel_rad() const { return roll_travel_rad_; }

 private:
  training::SessionRunner* runner_;
  const haptics::SeqLock<ModelControls>* controls_;
  haptics::VirtualCoupling coupling_;
  double roll_offset_rad_{0.0};
  std::function<void(double, double)> before_update_;
  std::function<void(const training::SessionRunner&)> after_step_;
  std::function<std::int64_t()> now_unix_ms_;
  std::function<void(std::int64_t)> on_start_;
  bool armed_{false};
  std::uint64_t updates_{0};
  std::uint64_t model_steps_{0};
  bool stepped_{false};
  bool have_previous_{false};
  double previous_insertion_m_{0.0};
  double previous_roll_rad_{0.0};
  double encoder_travel_m_{0.0};
  double roll_travel_rad_{0.0};
};

// One line of key=value pairs saying what went over the bus, e.g.
// `device=sim bus=socketpair frames_sent=... encoder_travel_m=... transient_faults=0
// hard_faults=0 fault=none`.
std::string DeviceReportLine(const std::string& device, const std::string& bus,
                             const haptics::DeviceCounters& counters,
                             const SessionModelSource& source,
                             const haptics::SafetyMonitor& safety);

// The station's health over one haptic run, for the records it produced
// (SessionRecord.station_health): the driver's CAN counters and the safety
// monitor's fault counts; the loop's timing when a real-time loop ran (`loop`
// null: headless, simulated time, loop_cycles 0). `device` is "sim" or
// "can:IFACE".
ves::v1::StationHealth MakeStationHealth(const std::string& device,
                                         const haptics::DeviceCounters& counters,
                                         const haptics::SafetyMonitor& safety,
                                         const haptics::LoopStats* loop, double period_s);

// The same figures as plain values taken at one moment: the 1 kHz thread
// takes them (no allocation; the loop's p99 is read from its histogram) and
// another thread turns them into a record's StationHealth.
struct HealthFigures {
  haptics::DeviceCounters counters;
  std::uint64_t hard_faults{0};
  std::uint64_t transient_faults{0};
  std::uint64_t loop_cycles{0};  // 0: no real-time loop ran
  std::uint64_t loop_overruns{0};
  double loop_cycle_p99_us{0.0};
};
HealthFigures TakeHealthFigures(const haptics::DeviceCounters& counters,
                                const haptics::SafetyMonitor& safety,
                                const haptics::LoopStats* loop);
ves::v1::StationHealth MakeStationHealth(const std::string& device, const HealthFigures& figures,
                                         double period_s);

// The simulated hand for a scripted operator's sample (headless): in the
// force mode the hand pushes the scope with push_force_N; in the position
// mode it grips and pulls toward insertion_m − model_offset_m (device
// coordinates). Roll is always the hand turning the scope toward roll_rad.
haptics::HandProfile HandForSample(const training::InputSample& sample, double model_offset_m);

}  // namespace ves::station
