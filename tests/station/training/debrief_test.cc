// The debrief (station/training/debrief.h): the score split into its weighed
// parts, which sum to CalcScore's score, each with where and when it cost.
#include "station/training/debrief.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace ves::training {
namespace {

constexpr double kCecumArc_m = 1.5;

std::string Region(double arc_m) { return arc_m < 0.5 ? "sigmoid" : "transverse"; }

double Sum(const Debrief& debrief) {
  double sum = 0.0;
  for (const DebriefPart& p : debrief.parts) sum += p.points;
  return sum;
}

const DebriefPart* Part(const Debrief& debrief, const std::string& name) {
  for (const DebriefPart& p : debrief.parts) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

Metrics Completed() {
  Metrics m;
  m.completed = true;
  m.duration_s = 200.0;
  m.time_to_cecum_s = 200.0;
  m.pain_s = 12.0;
  m.loop_s = 30.0;
  m.excessive_force_s = 2.0;
  m.xray_s = 40.0;
  m.redout_s = 10.0;
  m.max_tip_arc_m = kCecumArc_m;
  return m;
}

std::vector<Event> Events() {
  const auto event = [](double t_s, EventKind kind, double duration_s, double arc_m) {
    Event e;
    e.t_s = t_s;
    e.kind = kind;
    e.duration_s = duration_s;
    e.arc_m = arc_m;
    return e;
  };
  return {event(20.0, EventKind::kPain, 5.0, 0.3), event(41.5, EventKind::kPain, 7.0, 0.9),
          event(60.0, EventKind::kFluoroscopy, 0.0, 0.0),
          event(70.0, EventKind::kDamage, 0.4, 0.35)};
}

TEST(Debrief, ThePartsOfACompletedSessionSumToItsScoreEachWithItsPlaces) {
  const ScoreParams params;
  for (const v1::Difficulty difficulty :
       {v1::DIFFICULTY_EASY, v1::DIFFICULTY_MEDIUM, v1::DIFFICULTY_HARD}) {
    Metrics m = Completed();
    m.damage_events = 1;
    const Debrief d = CalcDebrief(m, Events(), difficulty, kCecumArc_m, params, Region);
    const double score = CalcScore(m, difficulty, kCecumArc_m, params);
    EXPECT_DOUBLE_EQ(d.score, score);
    EXPECT_NEAR(Sum(d), score, 1e-9) << difficulty;
    double max_sum = 0.0;
    for (const DebriefPart& p : d.parts) max_sum += p.max_points;
    EXPECT_NEAR(max_sum, 100.0, 1e-9) << "the parts can give 100 together";
  }
  const Debrief medium =
      CalcDebrief(Completed(), Events(), v1::DIFFICULTY_MEDIUM, kCecumArc_m, params, Region);
  const DebriefPart* pain = Part(medium, "pain");
  ASSERT_NE(pain, nullptr);
  EXPECT_DOUBLE_EQ(pain->max_points, 50.0 * params.medium.pain);
  EXPECT_LT(pain->points, pain->max_points);
  EXPECT_EQ(pain->measure, "pain 12.0 s");
  EXPECT_EQ(pain->places,
            (std::vector<std::string>{"at 20.0 s for 5.0 s in the sigmoid",
                                      "at 41.5 s for 7.0 s in the transverse"}));
  EXPECT_EQ(Part(medium, "x-ray")->places, std::vector<std::string>{"on at 60.0 s"});
  EXPECT_EQ(Part(medium, "damage"), nullptr) << "no damage, no damage part";
}

TEST(Debrief, ThePartsOfASessionThatDidNotReachTheCecumSumToItsScore) {
  const ScoreParams params;
  for (const v1::Difficulty difficulty :
       {v1::DIFFICULTY_EASY, v1::DIFFICULTY_MEDIUM, v1::DIFFICULTY_HARD}) {
    Metrics m = Completed();
    m.completed = false;
    m.max_tip_arc_m = 0.6;
    const Debrief d = CalcDebrief(m, Events(), difficulty, kCecumArc_m, params, Region);
    EXPECT_NEAR(Sum(d), CalcScore(m, difficulty, kCecumArc_m, params), 1e-9) << difficulty;
    double max_sum = 0.0;
    for (const DebriefPart& p : d.parts) {
      max_sum += p.max_points;
      EXPECT_LE(p.points, p.max_points + 1e-9) << p.name;
    }
    EXPECT_NEAR(max_sum, 100.0, 1e-9) << difficulty;
    ASSERT_FALSE(d.parts.empty());
    EXPECT_EQ(d.parts.front().name, "cecum");
    EXPECT_NE(d.parts.front().measure.find("not reached: 40 % of the way"), std::string::npos)
        << d.parts.front().measure;
  }
}

// Every part of a session short of the cecum is scaled by the share of the
// way, so every one reads amber; the line above them says why, with how
// far the tip got and where (issue #48).
TEST(Debrief, ASessionShortOfTheCecumSaysSoAboveItsParts) {
  const ScoreParams params;
  Metrics m = Completed();
  m.completed = false;
  m.max_tip_arc_m = 0.6;
  const Debrief medium = CalcDebrief(m, Events(), v1::DIFFICULTY_MEDIUM, kCecumArc_m, params, Region);
  EXPECT_EQ(medium.headline,
            "Cecum not reached: the tip got 0.60 m of the 1.50 m, as far as the transverse; "
            "every part below is scaled by that 40 % of the way");
  const std::string text = DebriefText(medium, "  ");
  EXPECT_EQ(text.rfind("  " + medium.headline + "\n  cecum 0.0 of 50.0 ", 0), 0u)
      << "the headline first, then the parts:\n" << text;
  // Easy: only time counts, so only the cecum's part gives the way made.
  const Debrief easy = CalcDebrief(m, Events(), v1::DIFFICULTY_EASY, kCecumArc_m, params, Region);
  EXPECT_EQ(easy.headline,
            "Cecum not reached: the tip got 0.60 m of the 1.50 m, as far as the transverse; "
            "the cecum part gives 40 % of its points, the way made");
  // No region names (none given): the line still reads.
  const Debrief unnamed = CalcDebrief(m, Events(), v1::DIFFICULTY_HARD, kCecumArc_m, params, {});
  EXPECT_EQ(unnamed.headline.rfind("Cecum not reached: the tip got 0.60 m of the 1.50 m; ", 0),
            0u)
      << unnamed.headline;
  // Reached: no headline; the parts say it all.
  const Debrief reached =
      CalcDebrief(Completed(), Events(), v1::DIFFICULTY_MEDIUM, kCecumArc_m, params, Region);
  EXPECT_TRUE(reached.headline.empty()) << reached.headline;
  EXPECT_EQ(DebriefText(reached, "  ").rfind("  cecum 50.0 of 50.0 ", 0), 0u);
}

TEST(Debrief, DamageCostsItsPointsWithItsPlacesAndTheBoundIsSaid) {
  const ScoreParams params;
  Metrics m = Completed();
  m.completed = false;
  m.max_tip_arc_m = 0.3;
  m.damage_events = 6;
  std::vector<Event> events;
  for (int i = 0; i < 6; ++i) {
    Event damage;
    damage.t_s = 10.0 * i;
    damage.kind = EventKind::kDamage;
    damage.duration_s = 0.2;
    damage.arc_m = 0.1;
    events.push_back(damage);
  }
  const Debrief d = CalcDebrief(m, events, v1::DIFFICULTY_MEDIUM, kCecumArc_m, params, Region);
  const DebriefPart* damage = Part(d, "damage");
  ASSERT_NE(damage, nullptr);
  EXPECT_DOUBLE_EQ(damage->points, -60.0);
  ASSERT_EQ(damage->places.size(), kMaxPlaces + 1);
  EXPECT_EQ(damage->places.front(), "at 0.0 s for 0.2 s in the sigmoid");
  EXPECT_EQ(damage->places.back(), "and 2 more");
  EXPECT_LT(Sum(d), 0.0);
  EXPECT_EQ(d.score, 0.0);
  const std::string text = DebriefText(d, "  ");
  EXPECT_NE(text.find("  damage -60.0 (6 damage episodes, 10 points each): at 0.0 s"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("the score is bounded to 0.0"), std::string::npos) << text;
}

}  // namespace
}  // namespace ves::training
