#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "ves/v1/session.pb.h"

// What the server requires of an uploaded SessionRecord before it is stored
// (docs/server.md, "Limits" and "Plausibility of a session record"). Pure: no
// store, no gRPC, so any front end checks records the same way. That the case
// exists and is visible to the trainee's institution needs the store: the
// handler checks it after this.
namespace ves::server {

// Bounds of a plausible record (docs/server.md).
inline constexpr int64_t kMinSessionStartUnixMs = 1'577'836'800'000;  // 2020-01-01 UTC
inline constexpr int64_t kMaxClockSkewMs = 24 * 3600 * 1000;          // a start this far ahead
inline constexpr double kMaxSessionDuration_s = 4 * 3600.0;
inline constexpr double kMaxForce_N = 1e4;
inline constexpr double kMaxLength_m = 10.0;       // insertion, arc, stretch
inline constexpr double kMaxTipPath_m = 1e4;
inline constexpr double kMaxDamageImpulse_N_s = 1e6;
inline constexpr double kMaxEventValue = 1e9;
inline constexpr int kEventsPerSecond = 20;        // events: 100 + this many per second of session
inline constexpr uint32_t kMaxScopeLinks = 1000;
inline constexpr uint32_t kMaxSegmentCount = 20000;
// Station health (record.station_health) and the build that made the record.
inline constexpr std::size_t kMaxSoftwareVersionBytes = 64;
inline constexpr std::size_t kMaxDeviceNameBytes = 32;
inline constexpr uint64_t kMaxHealthCount = 1'000'000'000;  // ~11.6 days of 1 kHz periods
inline constexpr double kMaxLoopTime_us = 1e7;              // a 10 s stall
inline constexpr double kMaxLoopBudget_us = 1e5;            // a 10 Hz loop

// The counters of StationHealth, by name: checked here, shown by the web API
// (server/web_api.cc), one list so a new counter cannot be missed in either.
struct StationHealthCount {
  const char* name;
  uint64_t (ves::v1::StationHealth::*get)() const;
};
inline constexpr StationHealthCount kStationHealthCounts[] = {
    {"loop_cycles", &ves::v1::StationHealth::loop_cycles},
    {"loop_overruns", &ves::v1::StationHealth::loop_overruns},
    {"hard_faults", &ves::v1::StationHealth::hard_faults},
    {"transient_faults", &ves::v1::StationHealth::transient_faults},
    {"can_bus_errors", &ves::v1::StationHealth::can_bus_errors},
    {"can_lost_frames", &ves::v1::StationHealth::can_lost_frames},
    {"can_send_failures", &ves::v1::StationHealth::can_send_failures},
    {"can_malformed_frames", &ves::v1::StationHealth::can_malformed_frames}};

// The version charset: letters, digits and . + - _ ~ (e.g. "0.1.0",
// "0.2.0-rc1+g1a2b3c"), 1..kMaxSoftwareVersionBytes.
bool IsSoftwareVersion(const std::string& text);

// Empty when acceptable; otherwise one line naming the field and the value,
// e.g. "record.metrics.pain_s = nan: must be finite" or
// "record.metrics.time_to_cecum_s = -1: must be in (0, duration_s 300] when completed".
// `now_unix_ms` bounds the start time (a clock at most kMaxClockSkewMs ahead).
std::string CheckSessionRecord(const ves::v1::SessionRecord& record, int64_t now_unix_ms);

// Lower-case RFC 4122 text form: 8-4-4-4-12 hex digits.
bool IsLowerCaseUuid(const std::string& text);

}  // namespace ves::server
