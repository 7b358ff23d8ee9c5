#include "server/session_check.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <cmath>
#include <cstdio>

#include "patient_db/limits.h"
#include "station/training/input_log.h"
#include "station/training/lesson_gate.h"

namespace ves::server {
namespace {

using google::protobuf::FieldDescriptor;
using google::protobuf::Message;

std::string FormatDouble(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return std::to_string(v);
}

// The first non-finite double or float anywhere in `m`, as "path = value".
std::string FindNonFinite(const Message& m, const std::string& path) {
  const auto* d = m.GetDescriptor();
  const auto* r = m.GetReflection();
  for (int i = 0; i < d->field_count(); ++i) {
    const FieldDescriptor* f = d->field(i);
    const std::string name = path + "." + f->name();
    const bool is_double = f->cpp_type() == FieldDescriptor::CPPTYPE_DOUBLE;
    const bool is_float = f->cpp_type() == FieldDescriptor::CPPTYPE_FLOAT;
    const bool is_message = f->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE;
    if (f->is_repeated()) {
      const int n = r->FieldSize(m, f);
      for (int k = 0; k < n; ++k) {
        const std::string item = name + "[" + std::to_string(k) + "]";
        double v = 0;
        if (is_double) v = r->GetRepeatedDouble(m, f, k);
        if (is_float) v = r->GetRepeatedFloat(m, f, k);
        if ((is_double || is_float) && !std::isfinite(v)) return item + " = " + FormatDouble(v);
        if (is_message) {
          std::string found = FindNonFinite(r->GetRepeatedMessage(m, f, k), item);
          if (!found.empty()) return found;
        }
      }
      continue;
    }
    double v = 0;
    if (is_double) v = r->GetDouble(m, f);
    if (is_float) v = r->GetFloat(m, f);
    if ((is_double || is_float) && !std::isfinite(v)) return name + " = " + FormatDouble(v);
    if (is_message && r->HasField(m, f)) {
      std::string found = FindNonFinite(r->GetMessage(m, f), name);
      if (!found.empty()) return found;
    }
  }
  return {};
}

std::string Num(double v) {
  char text[40];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

// "field = value: must be in [lo, hi] unit", or empty.
std::string InRange(const std::string& field, double v, double lo, double hi,
                    const std::string& unit = "") {
  if (v >= lo && v <= hi) return {};
  return field + " = " + Num(v) + ": must be in [" + Num(lo) + ", " + Num(hi) + "]" +
         (unit.empty() ? "" : " " + unit);
}

std::string CheckId(const std::string& field, const std::string& value) {
  if (patient_db::IsPrintableId(value)) return {};
  return field + " = '" + patient_db::PrintableExcerpt(value, 32) + "': must be 1.." +
         std::to_string(patient_db::kMaxIdBytes) + " bytes of printable UTF-8";
}

// Durations inside the session, the consistency of outcome, completion and
// time to the cecum, and the other metrics' ranges (docs/scoring.md).
std::string CheckMetrics(const ves::v1::SessionRecord& r) {
  constexpr double kTolerance_s = 1e-3;
  const auto& m = r.metrics();
  const double d = m.duration_s();
  std::string p = InRange("record.metrics.duration_s", d, 0.0, kMaxSessionDuration_s, "s");
  if (!p.empty()) return p;
  const double wall_s = static_cast<double>(r.end_unix_ms() - r.start_unix_ms()) * 1e-3;
  if (std::abs(wall_s - d) > 1.0) {
    return "record.metrics.duration_s = " + Num(d) + ": end_unix_ms - start_unix_ms is " +
           Num(wall_s) + " s";
  }
  if (m.completed() != (r.outcome() == ves::v1::OUTCOME_CECUM_REACHED)) {
    return std::string("record.metrics.completed = ") + (m.completed() ? "true" : "false") +
           ": contradicts outcome " + ves::v1::Outcome_Name(r.outcome());
  }
  if (m.completed()) {
    if (!(m.time_to_cecum_s() > 0.0 && m.time_to_cecum_s() <= d + kTolerance_s)) {
      return "record.metrics.time_to_cecum_s = " + Num(m.time_to_cecum_s()) +
             ": must be in (0, duration_s " + Num(d) + "] when completed";
    }
  } else if (m.time_to_cecum_s() != 0.0) {
    return "record.metrics.time_to_cecum_s = " + Num(m.time_to_cecum_s()) +
           ": must be 0 when not completed";
  }
  const std::pair<const char*, double> within_session[] = {
      {"excessive_force_s", m.excessive_force_s()},
      {"pain_s", m.pain_s()},
      {"loop_s", m.loop_s()},
      {"redout_s", m.redout_s()},
      {"xray_s", m.xray_s()},
      {"press_llq_s", m.press_llq_s()},
      {"press_mid_s", m.press_mid_s()},
      {"left_lateral_s", m.left_lateral_s()},
      {"right_lateral_s", m.right_lateral_s()}};
  for (const auto& [name, value] : within_session) {
    p = InRange(std::string("record.metrics.") + name, value, 0.0, d + kTolerance_s,
                "s (0 to duration_s)");
    if (!p.empty()) return p;
  }
  const std::pair<const char*, std::pair<double, double>> ranges[] = {
      {"peak_insertion_force_N", {m.peak_insertion_force_n(), kMaxForce_N}},
      {"mean_insertion_force_N", {m.mean_insertion_force_n(), kMaxForce_N}},
      {"peak_stretch_m", {m.peak_stretch_m(), kMaxLength_m}},
      {"tip_path_m", {m.tip_path_m(), kMaxTipPath_m}},
      {"max_insertion_m", {m.max_insertion_m(), kMaxLength_m}},
      {"max_tip_arc_m", {m.max_tip_arc_m(), kMaxLength_m}},
      {"mucosa_seen_fraction", {m.mucosa_seen_fraction(), 1.0}},
      {"damage_impulse_N_s", {m.damage_impulse_n_s(), kMaxDamageImpulse_N_s}}};
  for (const auto& [name, value_max] : ranges) {
    p = InRange(std::string("record.metrics.") + name, value_max.first, 0.0, value_max.second);
    if (!p.empty()) return p;
  }
  if (m.mean_insertion_force_n() > m.peak_insertion_force_n() + 1e-9) {
    return "record.metrics.mean_insertion_force_N = " + Num(m.mean_insertion_force_n()) +
           ": more than peak_insertion_force_N " + Num(m.peak_insertion_force_n());
  }
  // Episodes last at least a step: no more of them than steps.
  const double max_episodes = d / 1e-4 + 1.0;
  const std::pair<const char*, uint32_t> counts[] = {
      {"excessive_force_episodes", m.excessive_force_episodes()},
      {"loop_count", m.loop_count()},
      {"damage_events", m.damage_events()},
      {"position_changes", m.position_changes()}};
  for (const auto& [name, n] : counts) {
    if (n > max_episodes) {
      return std::string("record.metrics.") + name + " = " + std::to_string(n) +
             ": more episodes than a " + Num(d) + " s session has steps";
    }
  }
  return {};
}

std::string CheckEvents(const ves::v1::SessionRecord& r) {
  const double d = r.metrics().duration_s();
  const double max_events = 100.0 + kEventsPerSecond * d;
  if (r.events_size() > max_events) {
    return "record.events: " + std::to_string(r.events_size()) + " events, more than " +
           Num(std::floor(max_events)) + " for a " + Num(d) + " s session";
  }
  for (int i = 0; i < r.events_size(); ++i) {
    const auto& e = r.events(i);
    const std::string at = "record.events[" + std::to_string(i) + "]";
    if (!ves::v1::EventKind_IsValid(e.kind()) || e.kind() == ves::v1::EVENT_KIND_UNSPECIFIED) {
      return at + ".kind = " + std::to_string(e.kind()) + ": not an EventKind";
    }
    std::string p = InRange(at + ".t_s", e.t_s(), 0.0, d + 1e-3, "s");
    if (p.empty()) p = InRange(at + ".duration_s", e.duration_s(), 0.0, d + 1e-3, "s");
    if (p.empty()) p = InRange(at + ".arc_m", e.arc_m(), -kMaxLength_m, kMaxLength_m, "m");
    if (p.empty()) p = InRange(at + ".value", e.value(), -kMaxEventValue, kMaxEventValue);
    if (!p.empty()) return p;
  }
  return {};
}

// The log is not decoded here (that costs what the judge budgets); its
// header's sample count must match the record's and fit the duration.
std::string CheckInputLog(const ves::v1::SessionRecord& r) {
  if (!r.has_input_log()) return "record.input_log: missing (every session keeps its input log)";
  const auto& log = r.input_log();
  // Older stations' logs (version 1) are still judged: the decoder reads them.
  const std::string_view encoding = training::InputLogEncodingOf(log.format_version());
  if (encoding.empty() || log.encoding() != encoding) {
    return "record.input_log.encoding = '" + patient_db::PrintableExcerpt(log.encoding(), 32) +
           "' version " + std::to_string(log.format_version()) + ": must be " +
           training::kInputLogEncoding + " version " +
           std::to_string(training::kInputLogFormatVersion) + " (or delta-zlib-v1 version 1)";
  }
  std::string p = InRange("record.input_log.dt_s", log.dt_s(), training::kMinJudgedDt_s,
                          training::kMaxJudgedDt_s, "s");
  if (!p.empty()) return p;
  const double max_samples = r.metrics().duration_s() / log.dt_s() + 2.0;
  if (static_cast<double>(log.sample_count()) > max_samples) {
    return "record.input_log.sample_count = " + std::to_string(log.sample_count()) +
           ": more than the " + Num(std::floor(max_samples)) + " steps of a " +
           Num(r.metrics().duration_s()) + " s session at dt_s " + Num(log.dt_s());
  }
  uint64_t in_header = 0;
  try {
    in_header = training::PeekInputSampleCount(log.encoded());
  } catch (const training::InputLogError& error) {
    return std::string("record.input_log.encoded: ") + error.what();
  }
  if (in_header != log.sample_count()) {
    return "record.input_log.sample_count = " + std::to_string(log.sample_count()) +
           ": the encoded log's header says " + std::to_string(in_header);
  }
  return {};
}

// What the station says of itself: bounded, consistent counts; the loop's
// timing only with loop cycles to time.
std::string CheckStationHealth(const ves::v1::SessionRecord& r) {
  if (!r.has_station_health()) return {};
  const auto& h = r.station_health();
  const std::string at = "record.station_health";
  bool device_ok = !h.device().empty() && h.device().size() <= kMaxDeviceNameBytes;
  for (const char c : h.device()) {
    device_ok =
        device_ok && ((c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                      c == ':' || c == '.' || c == '_' || c == '-');
  }
  if (!device_ok) {
    return at + ".device = '" + patient_db::PrintableExcerpt(h.device(), 40) + "': must be 1.." +
           std::to_string(kMaxDeviceNameBytes) + " of letters, digits and : . _ - (sim, can:IFACE)";
  }
  for (const auto& [name, get] : kStationHealthCounts) {
    const uint64_t n = (h.*get)();
    if (n > kMaxHealthCount) {
      return at + "." + name + " = " + std::to_string(n) + ": more than " +
             std::to_string(kMaxHealthCount);
    }
  }
  std::string p = InRange(at + ".loop_budget_us", h.loop_budget_us(), 0.0, kMaxLoopBudget_us, "us");
  if (p.empty()) {
    p = InRange(at + ".loop_cycle_p99_us", h.loop_cycle_p99_us(), 0.0, kMaxLoopTime_us, "us");
  }
  if (!p.empty()) return p;
  if (h.loop_cycles() == 0 && (h.loop_cycle_p99_us() != 0.0 || h.loop_overruns() != 0)) {
    return at + ".loop_cycle_p99_us = " + Num(h.loop_cycle_p99_us()) +
           ", loop_overruns = " + std::to_string(h.loop_overruns()) +
           ": must be 0 when loop_cycles is 0";
  }
  if (h.loop_overruns() > h.loop_cycles()) {
    return at + ".loop_overruns = " + std::to_string(h.loop_overruns()) +
           ": more than loop_cycles " + std::to_string(h.loop_cycles());
  }
  if (h.loop_cycles() > 0 && !(h.loop_budget_us() > 0.0)) {
    return at + ".loop_budget_us = " + Num(h.loop_budget_us()) + ": must be > 0 with loop cycles";
  }
  return {};
}

}  // namespace

bool IsSoftwareVersion(const std::string& text) {
  if (text.empty() || text.size() > kMaxSoftwareVersionBytes) return false;
  for (const char c : text) {
    const bool ok = (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                    c == '.' || c == '+' || c == '-' || c == '_' || c == '~';
    if (!ok) return false;
  }
  return true;
}

bool IsLowerCaseUuid(const std::string& text) {
  if (text.size() != 36) return false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (i == 8 || i == 13 || i == 18 || i == 23) {
      if (c != '-') return false;
    } else if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) {
      return false;
    }
  }
  return true;
}

std::string CheckSessionRecord(const ves::v1::SessionRecord& record, int64_t now_unix_ms) {
  std::string p = patient_db::CheckMessageLimits(record, "record");
  if (!p.empty()) return p;
  if (!IsLowerCaseUuid(record.uuid())) {
    return "record.uuid = '" + patient_db::PrintableExcerpt(record.uuid(), 40) +
           "': must be a lower-case RFC 4122 UUID";
  }
  p = CheckId("record.trainee_id", record.trainee_id());
  if (p.empty()) p = CheckId("record.case_id", record.case_id());
  if (p.empty()) p = CheckId("record.station_id", record.station_id());
  if (!p.empty()) return p;
  if (record.case_version() == 0) return "record.case_version = 0: must be >= 1";
  // Empty in records of builds that did not set it; otherwise shown on the
  // stations page, so a plain version string.
  if (!record.software_version().empty() && !IsSoftwareVersion(record.software_version())) {
    return "record.software_version = '" +
           patient_db::PrintableExcerpt(record.software_version(), 40) + "': must be 1.." +
           std::to_string(kMaxSoftwareVersionBytes) + " of letters, digits and . + - _ ~";
  }
  if (!record.case_sha256_hex().empty() && record.case_sha256_hex().size() != 64) {
    return "record.case_sha256_hex = '" + record.case_sha256_hex() +
           "': must be 64 hex digits (or empty)";
  }
  std::string non_finite = FindNonFinite(record, "record");
  if (!non_finite.empty()) return non_finite + ": must be finite";
  p = InRange("record.score", record.score(), 0.0, 100.0);
  if (!p.empty()) return p;
  if (record.outcome() != ves::v1::OUTCOME_CECUM_REACHED &&
      record.outcome() != ves::v1::OUTCOME_ABORTED &&
      record.outcome() != ves::v1::OUTCOME_TIMED_OUT) {
    return "record.outcome = " + std::to_string(record.outcome()) +
           ": must be OUTCOME_CECUM_REACHED, OUTCOME_ABORTED or OUTCOME_TIMED_OUT";
  }
  if (record.start_unix_ms() < kMinSessionStartUnixMs ||
      record.start_unix_ms() > now_unix_ms + kMaxClockSkewMs) {
    return "record.start_unix_ms = " + std::to_string(record.start_unix_ms()) +
           ": must be between 2020-01-01 and a day after the server's clock";
  }
  if (record.end_unix_ms() < record.start_unix_ms()) {
    return "record.end_unix_ms = " + std::to_string(record.end_unix_ms()) +
           ": before start_unix_ms " + std::to_string(record.start_unix_ms());
  }
  p = CheckMetrics(record);
  if (p.empty()) p = CheckStationHealth(record);
  if (p.empty()) p = CheckEvents(record);
  if (p.empty()) p = CheckInputLog(record);
  if (!p.empty()) return p;
  if (record.has_replay_setup()) {
    const auto& setup = record.replay_setup();
    p = InRange("record.replay_setup.time_limit_s", setup.time_limit_s(), 1e-3, 3600.0, "s");
    if (!p.empty()) return p;
    if (record.metrics().duration_s() > setup.time_limit_s() + 1e-3) {
      return "record.metrics.duration_s = " + Num(record.metrics().duration_s()) +
             ": longer than replay_setup.time_limit_s " + Num(setup.time_limit_s());
    }
    if (setup.segment_count() > kMaxSegmentCount) {
      return "record.replay_setup.segment_count = " + std::to_string(setup.segment_count()) +
             ": more than " + std::to_string(kMaxSegmentCount);
    }
  }
  if (record.scope().link_count() > kMaxScopeLinks) {
    return "record.scope.link_count = " + std::to_string(record.scope().link_count()) +
           ": more than " + std::to_string(kMaxScopeLinks);
  }
  return {};
}

}  // namespace ves::server
