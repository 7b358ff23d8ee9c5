#include "station/app/interactive_rig.h"

#include <optional>
#include <stdexcept>
#include <utility>

#include "station/haptics/can_bus.h"

namespace ves::station {

InteractiveRig::InteractiveRig(InteractiveDevice device, double period_s,
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

}  // namespace ves::station
