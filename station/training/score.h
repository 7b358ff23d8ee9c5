#pragma once

#include "station/training/metrics.h"
#include "ves/v1/case.pb.h"

namespace ves::training {

// Weights of the score's components for one difficulty; they sum to 1.
struct ScoreWeights {
  double time{1.0};
  double pain{0.0};
  double loop{0.0};
  double force{0.0};
  double xray{0.0};
  double redout{0.0};

  bool operator==(const ScoreWeights&) const = default;
};

// The score's parameters (docs/scoring.md). Each component is a number in
// [0, 1]; the defaults are the documented values.
struct ScoreParams {
  // Time to the cecum at which the time component is 1/2, per metre of colon:
  // t_half = cecum_arc_m / half_score_speed_m_per_s.
  double half_score_speed_m_per_s{0.01};
  double pain_half_s{10.0};            // pain time at which the pain component is 1/2
  double loop_half_s{20.0};            // loop time at which the loop component is 1/2
  double excessive_force_half_s{5.0};  // excessive-force time at which that component is 1/2
  double damage_penalty_points{10.0};  // subtracted per damage event, on every difficulty
  ScoreWeights easy{.time = 1.0};
  ScoreWeights medium{
      .time = 0.30, .pain = 0.20, .loop = 0.10, .force = 0.10, .xray = 0.10, .redout = 0.20};
  ScoreWeights hard{
      .time = 0.20, .pain = 0.25, .loop = 0.15, .force = 0.10, .xray = 0.15, .redout = 0.15};

  // Medium's weights for DIFFICULTY_UNSPECIFIED.
  const ScoreWeights& WeightsFor(v1::Difficulty difficulty) const;
};

// The components, each in [0, 1] (1 is best), before weighting.
struct ScoreComponents {
  double time{0.0};
  double pain{0.0};
  double loop{0.0};
  double force{0.0};
  double xray{0.0};
  double redout{0.0};    // 1 - redout_s / duration_s: the lumen kept in view
  double progress{0.0};  // max tip arc / cecum arc, capped at 1
};

ScoreComponents CalcScoreComponents(const Metrics& metrics, double cecum_arc_m,
                                    const ScoreParams& params = {});

// 0..100. Completed: 50 + 50 * (weighted components). Not completed:
// 50 * progress * (weighted components other than time, renormalised; 1 on
// easy cases). Then minus damage_penalty_points per damage event, floored at 0.
double CalcScore(const Metrics& metrics, v1::Difficulty difficulty, double cecum_arc_m,
                 const ScoreParams& params = {});

}  // namespace ves::training
