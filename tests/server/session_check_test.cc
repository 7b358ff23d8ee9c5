// What an uploaded SessionRecord must satisfy; each problem names its field.
#include "server/session_check.h"

#include <gtest/gtest.h>

#include <limits>

namespace ves::server {
namespace {

ves::v1::SessionRecord Valid() {
  ves::v1::SessionRecord r;
  r.set_uuid("0f8fad5b-d9cb-469f-a165-70867728950e");
  r.set_trainee_id("t1");
  r.set_case_id("standard-adult");
  r.set_start_unix_ms(1000);
  r.set_end_unix_ms(2000);
  r.set_score(80);
  r.mutable_metrics()->set_pain_s(3);
  r.add_events()->set_value(1);
  return r;
}

TEST(CheckSessionRecord, ValidRecordPasses) { EXPECT_EQ(CheckSessionRecord(Valid()), ""); }

TEST(CheckSessionRecord, NonFiniteValuesAreNamedWithTheirPath) {
  auto r = Valid();
  r.mutable_metrics()->set_pain_s(std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(CheckSessionRecord(r), "record.metrics.pain_s = nan: must be finite");
  r = Valid();
  r.add_events()->set_arc_m(-std::numeric_limits<double>::infinity());
  EXPECT_EQ(CheckSessionRecord(r), "record.events[1].arc_m = -inf: must be finite");
  r = Valid();
  r.mutable_scope()->set_outer_diameter_m(std::numeric_limits<double>::infinity());
  EXPECT_EQ(CheckSessionRecord(r), "record.scope.outer_diameter_m = inf: must be finite");
}

TEST(CheckSessionRecord, IdentityAndRangesAreChecked) {
  auto r = Valid();
  r.set_uuid("0F8FAD5B-D9CB-469F-A165-70867728950E");  // upper case
  EXPECT_NE(CheckSessionRecord(r).find("record.uuid"), std::string::npos);
  r = Valid();
  r.set_trainee_id("");
  EXPECT_NE(CheckSessionRecord(r).find("record.trainee_id"), std::string::npos);
  r = Valid();
  r.set_score(100.5);
  EXPECT_NE(CheckSessionRecord(r).find("record.score"), std::string::npos);
  r = Valid();
  r.set_end_unix_ms(999);
  EXPECT_NE(CheckSessionRecord(r).find("record.end_unix_ms"), std::string::npos);
}

TEST(IsLowerCaseUuid, Shape) {
  EXPECT_TRUE(IsLowerCaseUuid("0f8fad5b-d9cb-469f-a165-70867728950e"));
  EXPECT_FALSE(IsLowerCaseUuid("0f8fad5b-d9cb-469f-a165-70867728950"));
  EXPECT_FALSE(IsLowerCaseUuid("0f8fad5bxd9cb-469f-a165-70867728950e"));
  EXPECT_FALSE(IsLowerCaseUuid("0f8fad5b-d9cb-469f-a165-70867728950g"));
}

}  // namespace
}  // namespace ves::server
