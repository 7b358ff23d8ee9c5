#include "station/training/score.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace ves::training {
namespace {

// 1 at zero, 1/2 at `half`, tending to 0: never saturates, so any difference
// in the metric still separates two runs.
double Decay(double value, double half) { return 1.0 / (1.0 + std::max(0.0, value) / half); }

}  // namespace

const ScoreWeights& ScoreParams::WeightsFor(v1::Difficulty difficulty) const {
  switch (difficulty) {
    case v1::DIFFICULTY_EASY:
      return easy;
    case v1::DIFFICULTY_HARD:
      return hard;
    default:
      return medium;
  }
}

ScoreComponents CalcScoreComponents(const Metrics& m, double cecum_arc_m,
                                    const ScoreParams& params) {
  if (!(cecum_arc_m > 0.0)) {
    throw std::invalid_argument("score: cecum_arc_m must be > 0, got " +
                                std::to_string(cecum_arc_m));
  }
  ScoreComponents c;
  const double t_half_s = cecum_arc_m / params.half_score_speed_m_per_s;
  c.time = m.completed ? Decay(m.time_to_cecum_s, t_half_s) : 0.0;
  c.pain = Decay(m.pain_s, params.pain_half_s);
  c.loop = Decay(m.loop_s, params.loop_half_s);
  c.force = Decay(m.excessive_force_s, params.excessive_force_half_s);
  const auto share_without = [&](double seconds) {
    return m.duration_s > 0.0 ? std::clamp(1.0 - seconds / m.duration_s, 0.0, 1.0) : 1.0;
  };
  c.xray = share_without(m.xray_s);
  c.redout = share_without(m.redout_s);
  c.progress = std::clamp(m.max_tip_arc_m / cecum_arc_m, 0.0, 1.0);
  if (m.completed) c.progress = 1.0;
  return c;
}

double CalcScore(const Metrics& m, v1::Difficulty difficulty, double cecum_arc_m,
                 const ScoreParams& params) {
  const ScoreComponents c = CalcScoreComponents(m, cecum_arc_m, params);
  const ScoreWeights& w = params.WeightsFor(difficulty);
  const double others = w.pain * c.pain + w.loop * c.loop + w.force * c.force +
                        w.xray * c.xray + w.redout * c.redout;
  const double other_weight = w.pain + w.loop + w.force + w.xray + w.redout;
  double score = 0.0;
  if (m.completed) {
    score = 50.0 + 50.0 * (w.time * c.time + others);
  } else {
    const double quality = other_weight > 0.0 ? others / other_weight : 1.0;
    score = 50.0 * c.progress * quality;
  }
  score -= params.damage_penalty_points * m.damage_events;
  return std::clamp(score, 0.0, 100.0);
}

}  // namespace ves::training
