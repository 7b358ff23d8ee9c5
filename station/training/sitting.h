#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "station/training/replay.h"
#include "ves/v1/session.pb.h"

namespace ves::training {

// One recorded session of a sitting, as the trainee's summary shows it.
struct SittingSession {
  std::string uuid;
  std::string case_id;
  Outcome outcome{Outcome::kNone};
  double score{0.0};
  std::string summary;  // SummaryLine of its result: what `replay` prints for it
  Debrief debrief;      // its score split into the weighed parts
};

// A trainee's sitting at an interactive station (docs/station-run.md, "A
// sitting"): the sessions recorded from the first start to the quit, in
// order, across repeats and case switches. Only sessions that went in past
// the anus are records, so only those are here.
class Sitting {
 public:
  void Add(const v1::SessionRecord& record, const RunResult& result);

  const std::vector<SittingSession>& sessions() const { return sessions_; }
  // Index of the best session (highest score; the earliest of equal ones),
  // nullopt when there is none.
  std::optional<std::size_t> best() const;
  // For the terminal at the quit: one line per session, numbered from 1,
  // with its case and summary line and under it the debrief (DebriefText),
  // then the best and the last:
  //   sitting: 2 sessions
  //     1. standard-adult  outcome=cecum_reached ... score=38.0/100
  //          cecum 50.0 of 50.0 (reached in 151.2 s)
  //          pain 9.1 of 10.0 (pain 1.0 s): at 41.2 s for 1.0 s in the sigmoid
  //          ...
  //     2. paper-sigmoid  outcome=aborted ... score=3.5/100
  //          ...
  //   best: 1 (38.0/100); last: 2 (3.5/100)
  // or "sitting: no session went in past the anus: nothing recorded".
  std::string Report() const;

 private:
  std::vector<SittingSession> sessions_;
};

}  // namespace ves::training
