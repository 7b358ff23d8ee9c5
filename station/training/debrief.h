#pragma once

#include <functional>
#include <string>
#include <vector>

#include "station/training/metrics.h"
#include "station/training/score.h"
#include "ves/v1/case.pb.h"

namespace ves::training {

// One weighed part of a session's score (docs/scoring.md, "Debrief").
struct DebriefPart {
  std::string name;        // "cecum", "time", "pain", "loops", "force", "x-ray", "red-out", "damage"
  double points{0.0};      // what it gave (damage: minus what it took)
  double max_points{0.0};  // what it could have given (damage: 0)
  std::string measure;     // the metric behind it, e.g. "pain 12.3 s"
  // Where and when it cost points: "at 41.2 s for 3.1 s in the sigmoid",
  // the first kMaxPlaces episodes, then "and N more".
  std::vector<std::string> places;

  bool operator==(const DebriefPart&) const = default;
};

// The score split into its weighed parts: the parts' points sum to the
// score before it is bounded to [0, 100]; `score` is CalcScore's.
struct Debrief {
  // One line above the parts where they need a reason to read them; empty
  // when the cecum was reached. Not reached: how far the tip got, where,
  // and that every part is scaled by that share of the way, e.g.
  // "Cecum not reached: the tip got 0.92 m of the 1.53 m, as far as the
  //  transverse; every part below is scaled by that 60 % of the way".
  std::string headline;
  std::vector<DebriefPart> parts;
  double score{0.0};

  bool operator==(const Debrief&) const = default;
};

inline constexpr std::size_t kMaxPlaces = 4;

// Splits CalcScore(metrics, difficulty, cecum_arc_m, params) into its parts,
// with the session's events (MetricsAccumulator::Events) as the places;
// `region_at` names the colon region at an arc length (e.g. RegionNameAt).
Debrief CalcDebrief(const Metrics& metrics, const std::vector<Event>& events,
                    v1::Difficulty difficulty, double cecum_arc_m, const ScoreParams& params,
                    const std::function<std::string(double arc_m)>& region_at);

// The headline (when there is one), then one line per part for the
// terminal, e.g.
//   "    pain 14.2 of 20.0 (pain 4.1 s): at 41.2 s for 3.1 s in the sigmoid"
std::string DebriefText(const Debrief& debrief, const std::string& indent);

}  // namespace ves::training
