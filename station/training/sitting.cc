#include "station/training/sitting.h"

#include <cstdio>

namespace ves::training {

void Sitting::Add(const v1::SessionRecord& record, const RunResult& result) {
  sessions_.push_back(SittingSession{record.uuid(), record.case_id(), result.outcome,
                                     result.score, SummaryLine(result), result.debrief});
}

std::optional<std::size_t> Sitting::best() const {
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < sessions_.size(); ++i) {
    if (!best || sessions_[i].score > sessions_[*best].score) best = i;
  }
  return best;
}

std::string Sitting::Report() const {
  if (sessions_.empty()) return "sitting: no session went in past the anus: nothing recorded\n";
  std::string report = "sitting: " + std::to_string(sessions_.size()) +
                       (sessions_.size() == 1 ? " session\n" : " sessions\n");
  for (std::size_t i = 0; i < sessions_.size(); ++i) {
    report += "  " + std::to_string(i + 1) + ". " + sessions_[i].case_id + "  " +
              sessions_[i].summary + "\n" + DebriefText(sessions_[i].debrief, "       ");
  }
  const auto number_and_score = [&](std::size_t i) {
    char text[64];
    std::snprintf(text, sizeof(text), "%zu (%.1f/100)", i + 1, sessions_[i].score);
    return std::string(text);
  };
  report += "best: " + number_and_score(*best()) +
            "; last: " + number_and_score(sessions_.size() - 1) + "\n";
  return report;
}

}  // namespace ves::training
