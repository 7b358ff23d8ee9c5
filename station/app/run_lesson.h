#pragma once

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <stdexcept>
#include <string>

#include "station/app/run_sync.h"
#include "station/sync/lesson_cache.h"
#include "station/training/input_log.h"
#include "ves/v1/lesson.pb.h"
#include "ves/v1/session.pb.h"

// `ves-station run --lesson next` (docs/lessons.md, docs/station-run.md): the
// trainee's next lesson from the server (cached for offline use), its case
// verified by the lesson's hash before the run, the aids enforced on every
// input, the pass criteria before the start and the verdicts after: the
// station's own at once, the server's (authoritative, from its replay) when
// it arrives.
namespace ves::station {

// Why a lesson cannot start: no lesson, or its case cannot be verified.
class LessonRefused : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct LessonPlan {
  ves::v1::Lesson lesson;
  std::string curriculum_id;
  std::string curriculum_title;
  uint32_t number{0};
  uint32_t count{0};
  uint32_t passes{0};
  bool from_server{false};
};

// The trainee's next lesson: asked of the server when there is one (and the
// answer cached), else the cached answer. Throws LessonRefused when there is
// none to run.
LessonPlan ObtainNextLesson(const std::optional<sync::ServerEndpoint>& endpoint,
                            const std::string& trainee_id, sync::LessonCache& cache,
                            std::ostream& log);

// The lesson's case, checked against the lesson's hash before anything runs:
// the cached file of that hash (verified on read), else — with a server — a
// download, accepted only when it has that hash. Throws LessonRefused naming
// the lesson, the case and both hashes.
ObtainedCase ObtainLessonCase(const std::optional<sync::ServerEndpoint>& endpoint,
                              const ves::v1::Lesson& lesson, sync::CaseCache& cache,
                              std::ostream& log);

// The lesson, its aids, time limit and pass criteria, before the start.
void PrintLessonBrief(const LessonPlan& plan, double time_limit_s, std::ostream& out);

// Aids off mean off: fluoroscopy forced off; the wireframe view replaced by
// flat polygons.
training::InputSample ApplyLessonAids(const ves::v1::LessonAids& aids,
                                      training::InputSample sample);

// The station's verdict on its own run (criteria on the record's metrics).
void PrintStationVerdict(const ves::v1::Lesson& lesson, const ves::v1::SessionRecord& record,
                         bool wireframe_used, std::ostream& out);

// Asks the server for the verdict of every lesson session still awaited,
// waiting up to `wait_s` for `wait_for_uuid` ("*": all; "": none) while the server
// replays it; prints and caches each that arrived. Never throws for an
// unreachable server (they stay awaited). Returns how many arrived.
int CollectServerVerdicts(const sync::ServerEndpoint& endpoint, sync::LessonCache& cache,
                          const std::string& wait_for_uuid, double wait_s, std::ostream& out);

}  // namespace ves::station
