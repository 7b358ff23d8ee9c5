// What an uploaded SessionRecord must satisfy; each problem names its field.
#include "server/session_check.h"

#include <gtest/gtest.h>

#include <google/protobuf/descriptor.h>

#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "station/training/input_log.h"

namespace ves::server {
namespace {

constexpr int64_t kNow = 1'750'000'000'000;  // 2025-06

// A plausible record: 300 s, cecum reached at 200 s, a 1000-step log.
ves::v1::SessionRecord Valid() {
  ves::v1::SessionRecord r;
  r.set_uuid("0f8fad5b-d9cb-469f-a165-70867728950e");
  r.set_trainee_id("t1");
  r.set_case_id("standard-adult");
  r.set_case_version(1);
  r.set_station_id("station-1");
  r.set_start_unix_ms(kNow - 3'600'000);
  r.set_end_unix_ms(r.start_unix_ms() + 300'000);
  r.set_outcome(ves::v1::OUTCOME_CECUM_REACHED);
  r.set_score(80);
  auto* m = r.mutable_metrics();
  m->set_duration_s(300);
  m->set_completed(true);
  m->set_time_to_cecum_s(200);
  m->set_pain_s(3);
  m->set_peak_insertion_force_n(9);
  m->set_mean_insertion_force_n(2);
  m->set_mucosa_seen_fraction(0.7);
  auto* e = r.add_events();
  e->set_kind(ves::v1::EVENT_KIND_LOOP);
  e->set_t_s(12);
  e->set_value(1);
  std::vector<training::InputSample> samples(1000);
  for (size_t i = 0; i < samples.size(); ++i) samples[i].tick = i;
  *r.mutable_input_log() = training::MakeInputLog(samples, 0.001);
  return r;
}

std::string Check(const ves::v1::SessionRecord& r) { return CheckSessionRecord(r, kNow); }

TEST(CheckSessionRecord, ValidRecordPasses) { EXPECT_EQ(Check(Valid()), ""); }

TEST(CheckSessionRecord, NonFiniteValuesAreNamedWithTheirPath) {
  auto r = Valid();
  r.mutable_metrics()->set_pain_s(std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(Check(r), "record.metrics.pain_s = nan: must be finite");
  r = Valid();
  r.add_events()->set_arc_m(-std::numeric_limits<double>::infinity());
  EXPECT_EQ(Check(r), "record.events[1].arc_m = -inf: must be finite");
  r = Valid();
  r.mutable_scope()->set_outer_diameter_m(std::numeric_limits<double>::infinity());
  EXPECT_EQ(Check(r), "record.scope.outer_diameter_m = inf: must be finite");
}

TEST(CheckSessionRecord, IdentityAndRangesAreChecked) {
  auto r = Valid();
  r.set_uuid("0F8FAD5B-D9CB-469F-A165-70867728950E");  // upper case
  EXPECT_NE(Check(r).find("record.uuid"), std::string::npos);
  r = Valid();
  r.set_trainee_id("");
  EXPECT_NE(Check(r).find("record.trainee_id"), std::string::npos);
  r = Valid();
  r.set_score(100.5);
  EXPECT_NE(Check(r).find("record.score"), std::string::npos);
  r = Valid();
  r.set_end_unix_ms(r.start_unix_ms() - 1);
  EXPECT_NE(Check(r).find("record.end_unix_ms"), std::string::npos);
}

// What a probe stored before these checks existed (issue #20, finding 5).
TEST(CheckSessionRecord, ImplausibleRecordsAreRefusedNamingTheField) {
  struct Case {
    const char* expect;
    void (*edit)(ves::v1::SessionRecord*);
  };
  const Case cases[] = {
      {"record.metrics.pain_s = -5: must be in [0, 300.001]",
       [](ves::v1::SessionRecord* r) { r->mutable_metrics()->set_pain_s(-5); }},
      {"record.metrics.duration_s = -1: must be in [0, 14400] s",
       [](ves::v1::SessionRecord* r) { r->mutable_metrics()->set_duration_s(-1); }},
      {"record.metrics.time_to_cecum_s = -1: must be in (0, duration_s 300] when completed",
       [](ves::v1::SessionRecord* r) { r->mutable_metrics()->set_time_to_cecum_s(-1); }},
      {"record.outcome = 99: must be OUTCOME_CECUM_REACHED, OUTCOME_ABORTED or OUTCOME_TIMED_OUT",
       [](ves::v1::SessionRecord* r) { r->set_outcome(static_cast<ves::v1::Outcome>(99)); }},
      {"record.start_unix_ms = -999999999999999: must be between 2020-01-01",
       [](ves::v1::SessionRecord* r) { r->set_start_unix_ms(-999'999'999'999'999); }},
      {"record.start_unix_ms = ",
       [](ves::v1::SessionRecord* r) {
         r->set_start_unix_ms(kNow + 2 * kMaxClockSkewMs);
         r->set_end_unix_ms(r->start_unix_ms() + 300'000);
       }},
      {"record.metrics.completed = false: contradicts outcome OUTCOME_CECUM_REACHED",
       [](ves::v1::SessionRecord* r) { r->mutable_metrics()->set_completed(false); }},
      {"record.metrics.duration_s = 300: end_unix_ms - start_unix_ms is 3600 s",
       [](ves::v1::SessionRecord* r) { r->set_end_unix_ms(r->start_unix_ms() + 3'600'000); }},
      {"record.metrics.mucosa_seen_fraction = 1.5: must be in [0, 1]",
       [](ves::v1::SessionRecord* r) { r->mutable_metrics()->set_mucosa_seen_fraction(1.5); }},
      {"record.metrics.mean_insertion_force_N = 10: more than peak_insertion_force_N 9",
       [](ves::v1::SessionRecord* r) { r->mutable_metrics()->set_mean_insertion_force_n(10); }},
      {"record.events[0].kind = 0: not an EventKind",
       [](ves::v1::SessionRecord* r) { r->mutable_events(0)->set_kind({}); }},
      {"record.events[0].t_s = 400: must be in [0, 300.001] s",
       [](ves::v1::SessionRecord* r) { r->mutable_events(0)->set_t_s(400); }},
      {"record.case_version = 0: must be >= 1",
       [](ves::v1::SessionRecord* r) { r->set_case_version(0); }},
      {"record.station_id = '': must be 1..128 bytes of printable UTF-8",
       [](ves::v1::SessionRecord* r) { r->set_station_id(""); }},
      {"record.input_log: missing",
       [](ves::v1::SessionRecord* r) { r->clear_input_log(); }},
      {"record.input_log.dt_s = 1e-06: must be in [0.0001, 0.01] s",
       [](ves::v1::SessionRecord* r) { r->mutable_input_log()->set_dt_s(1e-6); }},
      {"record.metrics.press_llq_s = 301: must be in [0, 300.001] s",
       [](ves::v1::SessionRecord* r) { r->mutable_metrics()->set_press_llq_s(301); }},
      {"record.metrics.press_mid_s = -1: must be in [0, 300.001] s",
       [](ves::v1::SessionRecord* r) { r->mutable_metrics()->set_press_mid_s(-1); }},
      {"record.metrics.left_lateral_s = 400: must be in [0, 300.001] s",
       [](ves::v1::SessionRecord* r) { r->mutable_metrics()->set_left_lateral_s(400); }},
      {"record.metrics.right_lateral_s = 300.5: must be in [0, 300.001] s",
       [](ves::v1::SessionRecord* r) { r->mutable_metrics()->set_right_lateral_s(300.5); }},
      {"record.metrics.position_changes = 4000000: more episodes than a 300 s session has steps",
       [](ves::v1::SessionRecord* r) { r->mutable_metrics()->set_position_changes(4'000'000); }},
      {"record.input_log.encoding = 'delta-zlib-v1' version 2: must be delta-zlib-v2 version 2 "
       "(or delta-zlib-v1 version 1)",
       [](ves::v1::SessionRecord* r) { r->mutable_input_log()->set_encoding("delta-zlib-v1"); }},
      {"record.input_log.encoding = 'delta-zlib-v3' version 3: must be",
       [](ves::v1::SessionRecord* r) {
         r->mutable_input_log()->set_format_version(3);
         r->mutable_input_log()->set_encoding("delta-zlib-v3");
       }},
  };
  for (const Case& c : cases) {
    auto r = Valid();
    c.edit(&r);
    EXPECT_EQ(Check(r).rfind(c.expect, 0), 0u) << "got: " << Check(r);
  }
}

// Sample and event counts are bounded by the session's duration, before the
// log is decoded: the header's count is read, not the data.
TEST(CheckSessionRecord, CountsAreBoundedByTheDuration) {
  auto r = Valid();
  r.mutable_input_log()->set_sample_count(20'000'000);
  EXPECT_EQ(Check(r).rfind("record.input_log.sample_count = 20000000: more than the 300002 steps "
                           "of a 300 s session",
                           0),
            0u)
      << Check(r);
  r = Valid();
  r.mutable_input_log()->set_sample_count(999);  // the header says 1000
  EXPECT_EQ(Check(r), "record.input_log.sample_count = 999: the encoded log's header says 1000");
  r = Valid();
  r.mutable_input_log()->set_encoded("VIL1");
  EXPECT_NE(Check(r).find("record.input_log.encoded: input log: truncated header"),
            std::string::npos);
  r = Valid();
  r.mutable_metrics()->set_duration_s(1);
  r.mutable_metrics()->set_time_to_cecum_s(1);
  r.mutable_metrics()->set_pain_s(0);
  r.set_end_unix_ms(r.start_unix_ms() + 1000);
  r.clear_events();
  for (int i = 0; i < 121; ++i) r.add_events()->set_kind(ves::v1::EVENT_KIND_PAIN);
  r.mutable_input_log()->set_sample_count(1000);
  EXPECT_EQ(Check(r).rfind("record.events: 121 events, more than 120 for a 1 s session", 0), 0u)
      << Check(r);
}

// Stations before format 2 upload version 1 logs (no abdominal press, no
// patient position): still accepted, and judged by their replay.
TEST(CheckSessionRecord, AVersion1InputLogIsStillAccepted) {
  auto r = Valid();
  std::vector<training::InputSample> samples(1000);
  for (size_t i = 0; i < samples.size(); ++i) samples[i].tick = i;
  *r.mutable_input_log() = training::MakeInputLog(samples, 0.001, 1);
  ASSERT_EQ(r.input_log().encoding(), "delta-zlib-v1");
  EXPECT_EQ(Check(r), "");
}

TEST(CheckSessionRecord, StringsAreBoundedAndPrintable) {
  auto r = Valid();
  r.set_station_id(std::string(9 << 20, 's'));  // 9 MiB
  EXPECT_EQ(Check(r).rfind("record.station_id = 'ssss", 0), 0u) << Check(r).substr(0, 200);
  EXPECT_NE(Check(r).find(": 9437184 bytes, more than 128"), std::string::npos);
  EXPECT_LT(Check(r).size(), 200u);  // the message does not echo the value
  r = Valid();
  r.set_station_id("st\xff\xfe");
  EXPECT_NE(Check(r).find("record.station_id = 'st\\xff\\xfe': not valid UTF-8"),
            std::string::npos)
      << Check(r);
  r = Valid();
  r.set_trainee_id("t\x1b[31mred");
  EXPECT_NE(Check(r).find("control character U+001B"), std::string::npos) << Check(r);
}

// A real-time run's health: 10 minutes of 1 kHz periods on a CAN bus.
ves::v1::SessionRecord WithHealth() {
  auto r = Valid();
  r.set_software_version("0.1.0");
  auto* h = r.mutable_station_health();
  h->set_device("can:can0");
  h->set_loop_cycles(600'000);
  h->set_loop_cycle_p99_us(412.5);
  h->set_loop_budget_us(1000);
  h->set_loop_overruns(3);
  h->set_hard_faults(1);
  h->set_can_bus_errors(2);
  return r;
}

// Every counter StationHealth has is in the one list that the check and the
// web API go through, under its own name, and each one is bounded.
TEST(CheckSessionRecord, EveryStationHealthCounterIsListedAndBounded) {
  const google::protobuf::Descriptor* d = ves::v1::StationHealth::descriptor();
  int counters = 0;
  for (int i = 0; i < d->field_count(); ++i) {
    const google::protobuf::FieldDescriptor* f = d->field(i);
    if (f->cpp_type() != google::protobuf::FieldDescriptor::CPPTYPE_UINT64) continue;
    ++counters;
    bool listed = false;
    for (const auto& count : kStationHealthCounts) listed = listed || f->name() == count.name;
    EXPECT_TRUE(listed) << f->name() << " is not in kStationHealthCounts";
    auto r = WithHealth();
    r.mutable_station_health()->GetReflection()->SetUInt64(r.mutable_station_health(), f,
                                                           kMaxHealthCount + 1);
    EXPECT_NE(Check(r).find("record.station_health." + std::string(f->name()) + " = "),
              std::string::npos)
        << Check(r);
  }
  EXPECT_EQ(counters, static_cast<int>(std::size(kStationHealthCounts)));
}

TEST(CheckSessionRecord, StationHealthIsBoundedNamingTheField) {
  EXPECT_EQ(Check(WithHealth()), "");
  auto headless = WithHealth();  // simulated time: no loop timing
  headless.mutable_station_health()->set_loop_cycles(0);
  headless.mutable_station_health()->set_loop_cycle_p99_us(0);
  headless.mutable_station_health()->set_loop_overruns(0);
  EXPECT_EQ(Check(headless), "");

  struct Case {
    const char* expect;
    void (*spoil)(ves::v1::StationHealth*);
  };
  const Case cases[] = {
      {"record.station_health.loop_cycle_p99_us = nan: must be finite",
       [](ves::v1::StationHealth* h) {
         h->set_loop_cycle_p99_us(std::numeric_limits<double>::quiet_NaN());
       }},
      {"record.station_health.loop_cycle_p99_us = -1: must be in [0, 10000000] us",
       [](ves::v1::StationHealth* h) { h->set_loop_cycle_p99_us(-1); }},
      {"record.station_health.loop_budget_us = inf: must be finite",
       [](ves::v1::StationHealth* h) {
         h->set_loop_budget_us(std::numeric_limits<double>::infinity());
       }},
      {"record.station_health.hard_faults = 18446744073709551615: more than 1000000000",
       [](ves::v1::StationHealth* h) { h->set_hard_faults(UINT64_MAX); }},
      {"record.station_health.can_lost_frames = 1000000001: more than 1000000000",
       [](ves::v1::StationHealth* h) { h->set_can_lost_frames(1'000'000'001); }},
      {"record.station_health.loop_overruns = 600001: more than loop_cycles 600000",
       [](ves::v1::StationHealth* h) { h->set_loop_overruns(600'001); }},
      {"record.station_health.loop_cycle_p99_us = 412.5, loop_overruns = 3: must be 0 when "
       "loop_cycles is 0",
       [](ves::v1::StationHealth* h) { h->set_loop_cycles(0); }},
      {"record.station_health.device = '': must be 1..32 of letters",
       [](ves::v1::StationHealth* h) { h->set_device(""); }},
      {"record.station_health.device = 'can:<b>': must be 1..32 of letters",
       [](ves::v1::StationHealth* h) { h->set_device("can:<b>"); }},
  };
  for (const Case& c : cases) {
    auto r = WithHealth();
    c.spoil(r.mutable_station_health());
    EXPECT_EQ(Check(r).rfind(c.expect, 0), 0u) << Check(r);
  }
}

TEST(CheckSessionRecord, SoftwareVersionIsAPlainVersionString) {
  auto r = WithHealth();
  r.set_software_version("0.2.0-rc1+g1a2b3c");
  EXPECT_EQ(Check(r), "");
  r.set_software_version("");  // records of builds that did not set it
  EXPECT_EQ(Check(r), "");
  r.set_software_version(std::string(65, '1'));
  EXPECT_EQ(Check(r).rfind("record.software_version = '1111", 0), 0u) << Check(r);
  EXPECT_NE(Check(r).find("must be 1..64 of letters, digits and . + - _ ~"), std::string::npos);
  r.set_software_version("0.1.0\x1b[2J");
  EXPECT_EQ(Check(r).rfind("record.software_version = '0.1.0\\x1b[2J'", 0), 0u) << Check(r);
  r.set_software_version("0.1 <script>");
  EXPECT_EQ(Check(r).rfind("record.software_version = '0.1 <script>'", 0), 0u) << Check(r);
}

TEST(IsLowerCaseUuid, Shape) {
  EXPECT_TRUE(IsLowerCaseUuid("0f8fad5b-d9cb-469f-a165-70867728950e"));
  EXPECT_FALSE(IsLowerCaseUuid("0f8fad5b-d9cb-469f-a165-70867728950"));
  EXPECT_FALSE(IsLowerCaseUuid("0f8fad5bxd9cb-469f-a165-70867728950e"));
  EXPECT_FALSE(IsLowerCaseUuid("0f8fad5b-d9cb-469f-a165-70867728950g"));
}

}  // namespace
}  // namespace ves::server
