#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "patient_db/store.h"
#include "server/services.h"
#include "server/web_api.h"
#include "ves/v1/lesson.pb.h"

// Proficiency, cohorts and reports for supervisors (docs/web.md,
// "Proficiency", "Cohorts", "Export"): what the trainee list, the group page
// and the printable report show, read after the call that admits them. The
// routes are CohortRoutes() (server/web_routes.h).
namespace ves::server {

// Curricula read once per request (a group's trainees share theirs).
class CurriculumCache {
 public:
  explicit CurriculumCache(patient_db::Store* store) : store_(store) {}
  // nullptr when it cannot be read or parsed.
  const v1::Curriculum* Get(const std::string& curriculum_id);

 private:
  patient_db::Store* store_;
  std::map<std::string, std::optional<v1::Curriculum>> curricula_;
};

// One trainee's progress over each assigned curriculum, in assignment order:
// [{"curriculum_id", "title", "lessons", "passed", "proficient"}]. A lesson
// is passed once it has its required_passes passing verdicts (the rule of
// GetNextLesson); proficient: every lesson of the curriculum passed. With
// `detail`, each also has "lesson_progress": every lesson's title, attempts,
// passes, required passes, best score and completed.
nlohmann::json CurriculaProgressJson(patient_db::Store& store, CurriculumCache& curricula,
                                     const std::string& trainee_id, bool detail = false);
// The same from the trainee's assignments and verdicts read beforehand (the
// trainee list reads them for its whole page at once).
nlohmann::json CurriculaProgressJson(CurriculumCache& curricula,
                                     const std::vector<patient_db::AssignmentRow>& assignments,
                                     const std::vector<patient_db::LessonVerdictRow>& verdicts,
                                     bool detail = false);

// Figures of a set of sessions (a trainee's lesson attempts or practice
// runs): attempts, cecum_reached, best_score and last_score (of the latest
// start; null with none), last_unix_ms, and the medians of time to cecum
// (over the runs that reached it), pain, loop and X-ray time (over the runs
// that stored them); a median with no run to take it from is null. Pure.
nlohmann::json RunFiguresJson(const std::vector<const patient_db::SessionRow*>& runs);

// The band the scripted expert's runs of a case span in the institution
// (the newest kMaxExpertBandRuns with operator "expert"): {"runs": n,
// "score": [min, max], "time_to_cecum_s", "pain_s", "loop_s": the same or
// null when no run has it}; null with no run.
inline constexpr int kMaxExpertBandRuns = 50;
nlohmann::json ExpertBandJson(patient_db::Store& store, const std::string& institution,
                              const std::string& case_id);

// The median of `v`; null when empty.
nlohmann::json MedianOf(std::vector<double> v);

}  // namespace ves::server
