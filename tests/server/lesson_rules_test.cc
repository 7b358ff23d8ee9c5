// Curriculum rules without storage or network (server/lesson_rules.h).
#include "server/lesson_rules.h"

#include <cmath>

#include <gtest/gtest.h>

namespace ves::server {
namespace {

ves::v1::Lesson MakeLesson(const std::string& id, uint32_t passes,
                           std::vector<std::string> prerequisites = {}) {
  ves::v1::Lesson l;
  l.set_lesson_id(id);
  l.set_title("Title " + id);
  l.mutable_case_ref()->set_case_id("paper-sigmoid");
  l.set_time_limit_s(60);
  l.set_required_passes(passes);
  for (auto& p : prerequisites) l.add_prerequisites(p);
  return l;
}

ves::v1::Curriculum ThreeLessons() {
  ves::v1::Curriculum c;
  c.set_curriculum_id("cur");
  c.set_title("Cur");
  *c.add_lessons() = MakeLesson("a", 1);
  *c.add_lessons() = MakeLesson("b", 2, {"a"});
  *c.add_lessons() = MakeLesson("c", 1, {"b"});
  return c;
}

patient_db::LessonVerdictRow Verdict(const std::string& lesson, bool passed, double score,
                                     int64_t start) {
  return {"u" + std::to_string(start), "t1", "cur", lesson, passed, score, start, start + 1, ""};
}

TEST(CheckCurriculum, AcceptsAWellFormedCurriculum) {
  EXPECT_EQ(CheckCurriculum(ThreeLessons()), "");
}

TEST(CheckCurriculum, NamesTheFirstBadField) {
  auto c = ThreeLessons();
  c.mutable_lessons(1)->set_lesson_id("a");
  EXPECT_EQ(CheckCurriculum(c), "lessons[1].lesson_id = 'a': used twice");
  c = ThreeLessons();
  c.mutable_lessons(0)->add_prerequisites("c");  // a later lesson
  EXPECT_NE(CheckCurriculum(c).find("lessons[0].prerequisites: 'c'"), std::string::npos);
  c = ThreeLessons();
  c.mutable_lessons(2)->set_time_limit_s(0);
  EXPECT_NE(CheckCurriculum(c).find("lessons[2].time_limit_s"), std::string::npos);
  c = ThreeLessons();
  c.mutable_lessons(0)->mutable_pass()->set_max_pain_s(-1);
  EXPECT_NE(CheckCurriculum(c).find("lessons[0].pass.max_pain_s"), std::string::npos);
  c = ThreeLessons();
  c.mutable_lessons(0)->mutable_pass()->set_min_mucosa_seen_fraction(1.5);
  EXPECT_NE(CheckCurriculum(c).find("min_mucosa_seen_fraction"), std::string::npos);
  for (const double bad : {0.0, 5.5, std::nan("")}) {
    c = ThreeLessons();
    c.mutable_lessons(1)->mutable_pass()->set_max_inserted_at_cecum_m(bad);
    EXPECT_NE(CheckCurriculum(c).find("lessons[1].pass.max_inserted_at_cecum_m"), std::string::npos)
        << bad << ": " << CheckCurriculum(c);
  }
  c = ThreeLessons();
  c.mutable_lessons(1)->mutable_pass()->set_max_inserted_at_cecum_m(1.45);
  EXPECT_EQ(CheckCurriculum(c), "");
  c.clear_lessons();
  EXPECT_NE(CheckCurriculum(c).find("at least one lesson"), std::string::npos);
  c = ThreeLessons();
  c.set_curriculum_id("");
  EXPECT_NE(CheckCurriculum(c).find("curriculum_id"), std::string::npos);
}

TEST(CalcProgress, WithNoVerdictsTheFirstLessonIsNext) {
  const Progress p = CalcProgress({ThreeLessons()}, {});
  ASSERT_TRUE(p.has_next);
  EXPECT_EQ(p.next.lesson_id(), "a");
  EXPECT_EQ(p.next_number, 1u);
  EXPECT_EQ(p.next_count, 3u);
  ASSERT_EQ(p.lessons.size(), 3u);
  EXPECT_EQ(p.lessons[0].attempts(), 0u);
  EXPECT_FALSE(p.lessons[0].completed());
}

TEST(CalcProgress, AFailedAttemptDoesNotAdvance) {
  const Progress p = CalcProgress({ThreeLessons()}, {Verdict("a", false, 12, 100)});
  EXPECT_EQ(p.next.lesson_id(), "a");
  EXPECT_EQ(p.lessons[0].attempts(), 1u);
  EXPECT_EQ(p.lessons[0].passes(), 0u);
  EXPECT_DOUBLE_EQ(p.lessons[0].best_score(), 12);
  EXPECT_EQ(p.lessons[0].last_attempt_unix_ms(), 100);
  EXPECT_EQ(p.lessons[0].completed_unix_ms(), 0);
}

TEST(CalcProgress, ALessonNeedsItsRequiredPassesBeforeTheNextUnlocks) {
  // b needs 2 passes: after one, b is still next; after two, c is.
  std::vector<patient_db::LessonVerdictRow> v = {Verdict("a", true, 50, 100),
                                                 Verdict("b", true, 40, 200)};
  Progress p = CalcProgress({ThreeLessons()}, v);
  EXPECT_TRUE(p.lessons[0].completed());
  EXPECT_EQ(p.lessons[0].completed_unix_ms(), 100);
  EXPECT_EQ(p.next.lesson_id(), "b");
  EXPECT_EQ(p.next_passes, 1u);
  v.push_back(Verdict("b", false, 70, 300));
  v.push_back(Verdict("b", true, 60, 400));
  p = CalcProgress({ThreeLessons()}, v);
  EXPECT_TRUE(p.lessons[1].completed());
  EXPECT_EQ(p.lessons[1].attempts(), 3u);
  EXPECT_DOUBLE_EQ(p.lessons[1].best_score(), 70);  // best over every attempt, passed or not
  EXPECT_EQ(p.lessons[1].completed_unix_ms(), 400);  // the second pass
  EXPECT_EQ(p.next.lesson_id(), "c");
  v.push_back(Verdict("c", true, 80, 500));
  p = CalcProgress({ThreeLessons()}, v);
  EXPECT_FALSE(p.has_next);
}

TEST(CalcProgress, APrerequisiteNotCompletedHoldsALessonBack) {
  // Lesson c done out of order (a verdict exists) does not skip b.
  const Progress p =
      CalcProgress({ThreeLessons()}, {Verdict("a", true, 1, 1), Verdict("c", true, 1, 2)});
  EXPECT_EQ(p.next.lesson_id(), "b");
  EXPECT_TRUE(p.lessons[2].completed());
}

TEST(CalcProgress, CurriculaFollowTheirAssignmentOrderAndCountOnce) {
  ves::v1::Curriculum other;
  other.set_curriculum_id("other");
  *other.add_lessons() = MakeLesson("z", 1);
  Progress p = CalcProgress({other, ThreeLessons(), other}, {});
  EXPECT_EQ(p.lessons.size(), 4u);
  EXPECT_EQ(p.next.lesson_id(), "z");
  p = CalcProgress({other, ThreeLessons()}, {{"u", "t1", "other", "z", true, 9, 1, 2, ""}});
  EXPECT_EQ(p.next.lesson_id(), "a");
  EXPECT_EQ(p.next_curriculum_id, "cur");
}

}  // namespace
}  // namespace ves::server
