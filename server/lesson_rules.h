#pragma once

#include <string>
#include <vector>

#include "patient_db/store.h"
#include "ves/v1/lesson.pb.h"

// The rules of curricula that need no storage or network (docs/lessons.md):
// what a well-formed curriculum is, and a trainee's progress and next lesson
// from the server's verdicts. Pure functions, tested on their own.
namespace ves::server {

// The first problem of a curriculum as "field: value: message", or "" when
// well-formed: ids 1..128 printable characters, at least one lesson, lesson
// ids unique, a case id per lesson, a time limit in (0, 3600] s, required
// passes <= 100, prerequisites naming earlier lessons, thresholds finite and
// not negative, fractions <= 1.
std::string CheckCurriculum(const ves::v1::Curriculum& curriculum);

struct Progress {
  std::vector<ves::v1::LessonProgress> lessons;  // every assigned lesson, in order
  bool has_next = false;
  ves::v1::Lesson next;      // the first lesson not completed whose prerequisites are
  std::string next_curriculum_id;
  std::string next_curriculum_title;
  uint32_t next_number = 0;  // 1-based within its curriculum
  uint32_t next_count = 0;
  uint32_t next_passes = 0;
};

// `assigned` in assignment order (a curriculum assigned twice counts once);
// `verdicts` of the trainee, any order. A lesson is completed once it has
// required_passes passing verdicts; attempts count every verdict.
Progress CalcProgress(const std::vector<ves::v1::Curriculum>& assigned,
                      const std::vector<patient_db::LessonVerdictRow>& verdicts);

}  // namespace ves::server
