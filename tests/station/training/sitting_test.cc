// A sitting's summary (station/training/sitting.h): every recorded session,
// in order, and the best and the last (issue #48: only the last was printed).
#include "station/training/sitting.h"

#include <gtest/gtest.h>

#include <string>

namespace ves::training {
namespace {

struct Made {
  v1::SessionRecord record;
  RunResult result;
};

Made Session(const std::string& uuid, const std::string& case_id, Outcome outcome, double score,
             double pain_s) {
  Made made;
  made.record.set_uuid(uuid);
  made.record.set_case_id(case_id);
  made.result.outcome = outcome;
  made.result.score = score;
  made.result.metrics.pain_s = pain_s;
  made.result.deepest_region = "sigmoid";
  return made;
}

size_t Occurrences(const std::string& text, const std::string& needle) {
  size_t count = 0;
  for (size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) {
    ++count;
  }
  return count;
}

TEST(Sitting, TheReportListsEverySessionInOrderWithItsSummaryLineThenTheBestAndTheLast) {
  Sitting sitting;
  const Made sessions[] = {Session("u1", "standard-adult", Outcome::kCecumReached, 38.0, 4.0),
                           Session("u2", "standard-adult", Outcome::kAborted, 12.5, 1.0),
                           Session("u3", "paper-sigmoid", Outcome::kCecumReached, 38.0, 2.0),
                           Session("u4", "paper-sigmoid", Outcome::kTimedOut, 5.0, 0.0)};
  for (const Made& made : sessions) sitting.Add(made.record, made.result);
  ASSERT_EQ(sitting.sessions().size(), 4u);
  EXPECT_EQ(sitting.sessions()[2].uuid, "u3");
  EXPECT_EQ(sitting.sessions()[2].case_id, "paper-sigmoid");
  // Two equal best scores: the earlier is the best.
  ASSERT_TRUE(sitting.best().has_value());
  EXPECT_EQ(*sitting.best(), 0u);

  const std::string report = sitting.Report();
  EXPECT_EQ(report.rfind("sitting: 4 sessions\n", 0), 0u) << report;
  size_t previous = 0;
  for (size_t i = 0; i < 4; ++i) {
    const std::string line = "  " + std::to_string(i + 1) + ". " + sessions[i].record.case_id() +
                             "  " + SummaryLine(sessions[i].result) + "\n";
    const size_t at = report.find(line);
    ASSERT_NE(at, std::string::npos) << line << report;
    EXPECT_GT(at, previous) << "out of order: " << report;
    previous = at;
  }
  EXPECT_EQ(Occurrences(report, "outcome="), 4u) << report;
  EXPECT_NE(report.find("\nbest: 1 (38.0/100); last: 4 (5.0/100)\n"), std::string::npos)
      << report;
}

TEST(Sitting, ASittingWithoutASessionSaysNothingWasRecorded) {
  const Sitting sitting;
  EXPECT_FALSE(sitting.best().has_value());
  EXPECT_EQ(sitting.Report(), "sitting: no session went in past the anus: nothing recorded\n");
}

}  // namespace
}  // namespace ves::training
