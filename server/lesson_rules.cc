#include "server/lesson_rules.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

namespace ves::server {
namespace {

bool IsId(const std::string& s) {
  if (s.empty() || s.size() > 128) return false;
  for (char c : s) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return false;
  }
  return true;
}

constexpr int kMaxInsertedLimit_m = 5;  // no colonoscope is near this long

std::string CheckThresholds(const ves::v1::PassCriteria& p, const std::string& at) {
  const std::pair<bool, std::pair<double, const char*>> values[] = {
      {p.has_max_time_to_cecum_s(), {p.max_time_to_cecum_s(), "max_time_to_cecum_s"}},
      {p.has_max_pain_s(), {p.max_pain_s(), "max_pain_s"}},
      {p.has_max_xray_s(), {p.max_xray_s(), "max_xray_s"}},
      {p.has_min_score(), {p.min_score(), "min_score"}},
      {p.has_max_loop_s(), {p.max_loop_s(), "max_loop_s"}},
      {p.has_max_excessive_force_s(), {p.max_excessive_force_s(), "max_excessive_force_s"}},
      {p.has_min_max_tip_arc_m(), {p.min_max_tip_arc_m(), "min_max_tip_arc_m"}},
      {p.has_min_mucosa_seen_fraction(),
       {p.min_mucosa_seen_fraction(), "min_mucosa_seen_fraction"}},
      {p.has_max_peak_insertion_force_n(),
       {p.max_peak_insertion_force_n(), "max_peak_insertion_force_N"}},
      {p.has_max_inserted_at_cecum_m(),
       {p.max_inserted_at_cecum_m(), "max_inserted_at_cecum_m"}},
  };
  for (const auto& [has, value] : values) {
    if (has && (!std::isfinite(value.first) || value.first < 0)) {
      return at + ".pass." + value.second + " = " + std::to_string(value.first) +
             ": must be finite and >= 0";
    }
  }
  if (p.has_min_mucosa_seen_fraction() && p.min_mucosa_seen_fraction() > 1) {
    return at + ".pass.min_mucosa_seen_fraction = " +
           std::to_string(p.min_mucosa_seen_fraction()) + ": must be <= 1";
  }
  // A limit of 0 could never be met, one past kMaxInsertedLimit_m never
  // bites: either is a mistake in the file.
  if (p.has_max_inserted_at_cecum_m() &&
      (p.max_inserted_at_cecum_m() <= 0 || p.max_inserted_at_cecum_m() > kMaxInsertedLimit_m)) {
    return at + ".pass.max_inserted_at_cecum_m = " + std::to_string(p.max_inserted_at_cecum_m()) +
           ": must be in (0, " + std::to_string(kMaxInsertedLimit_m) + "] m";
  }
  if (p.has_min_score() && p.min_score() > 100) {
    return at + ".pass.min_score = " + std::to_string(p.min_score()) + ": must be <= 100";
  }
  return {};
}

}  // namespace

std::string CheckCurriculum(const ves::v1::Curriculum& c) {
  if (!IsId(c.curriculum_id())) {
    return "curriculum_id = '" + c.curriculum_id() + "': must be 1..128 printable characters";
  }
  if (c.lessons().empty()) return "lessons: a curriculum needs at least one lesson";
  std::set<std::string> earlier;
  for (int i = 0; i < c.lessons_size(); ++i) {
    const ves::v1::Lesson& l = c.lessons(i);
    const std::string at = "lessons[" + std::to_string(i) + "]";
    if (!IsId(l.lesson_id())) {
      return at + ".lesson_id = '" + l.lesson_id() + "': must be 1..128 printable characters";
    }
    if (earlier.count(l.lesson_id())) {
      return at + ".lesson_id = '" + l.lesson_id() + "': used twice";
    }
    if (!IsId(l.case_ref().case_id())) {
      return at + ".case_ref.case_id = '" + l.case_ref().case_id() + "': must be a case id";
    }
    if (!std::isfinite(l.time_limit_s()) || l.time_limit_s() <= 0 || l.time_limit_s() > 3600) {
      return at + ".time_limit_s = " + std::to_string(l.time_limit_s()) + ": must be in (0, 3600]";
    }
    if (l.required_passes() > 100) {
      return at + ".required_passes = " + std::to_string(l.required_passes()) +
             ": must be <= 100";
    }
    for (const std::string& p : l.prerequisites()) {
      if (!earlier.count(p)) {
        return at + ".prerequisites: '" + p + "' is not an earlier lesson of this curriculum";
      }
    }
    std::string bad = CheckThresholds(l.pass(), at);
    if (!bad.empty()) return bad;
    earlier.insert(l.lesson_id());
  }
  return {};
}

Progress CalcProgress(const std::vector<ves::v1::Curriculum>& assigned,
                      const std::vector<patient_db::LessonVerdictRow>& verdicts) {
  std::map<std::string, std::vector<const patient_db::LessonVerdictRow*>> by_lesson;
  for (const auto& v : verdicts) by_lesson[v.lesson_id].push_back(&v);
  Progress out;
  std::set<std::string> seen_curricula;
  for (const ves::v1::Curriculum& c : assigned) {
    if (!seen_curricula.insert(c.curriculum_id()).second) continue;
    std::set<std::string> completed;
    for (int i = 0; i < c.lessons_size(); ++i) {
      const ves::v1::Lesson& l = c.lessons(i);
      ves::v1::LessonProgress p;
      p.set_curriculum_id(c.curriculum_id());
      p.set_lesson_id(l.lesson_id());
      p.set_title(l.title());
      const uint32_t required = l.required_passes() == 0 ? 1 : l.required_passes();
      p.set_required_passes(required);
      // Verdicts in session order, so the completing pass is the required-th one.
      std::vector<const patient_db::LessonVerdictRow*> mine = by_lesson[l.lesson_id()];
      std::stable_sort(mine.begin(), mine.end(), [](const auto* a, const auto* b) {
        return a->session_start_unix_ms < b->session_start_unix_ms;
      });
      for (const auto* v : mine) {
        if (v->curriculum_id != c.curriculum_id()) continue;
        p.set_attempts(p.attempts() + 1);
        if (p.attempts() == 1 || v->score > p.best_score()) p.set_best_score(v->score);
        p.set_last_attempt_unix_ms(std::max(p.last_attempt_unix_ms(), v->session_start_unix_ms));
        if (v->passed) {
          p.set_passes(p.passes() + 1);
          if (p.passes() == required) p.set_completed_unix_ms(v->session_start_unix_ms);
        }
      }
      p.set_completed(p.passes() >= required);
      if (p.completed()) completed.insert(l.lesson_id());
      bool unlocked = true;
      for (const std::string& pre : l.prerequisites()) unlocked = unlocked && completed.count(pre);
      if (!out.has_next && !p.completed() && unlocked) {
        out.has_next = true;
        out.next = l;
        out.next_curriculum_id = c.curriculum_id();
        out.next_curriculum_title = c.title();
        out.next_number = static_cast<uint32_t>(i + 1);
        out.next_count = static_cast<uint32_t>(c.lessons_size());
        out.next_passes = p.passes();
      }
      out.lessons.push_back(std::move(p));
    }
  }
  return out;
}

}  // namespace ves::server
