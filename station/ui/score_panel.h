#pragma once

// What the score weighs, on the training screen (docs/station-ui.md, "What
// the score weighs"): live in the panel while a session runs (hand force
// against its labelled limit, the largest wall force, pain, loop, X-ray and
// red-out time, damage episodes, and a warning the moment one happens), and
// at the end of each session the debrief: the score split into its weighed
// parts with where and when each cost points, and the sitting's best and
// last.
#include <opencv2/core.hpp>

#include <chrono>
#include <cstdint>
#include <string>

#include "station/training/metrics.h"
#include "station/training/sitting.h"

namespace ves::ui {

// The 1 kHz loop publishes the model's state to the screen every this many
// steps (16 ms at 1 kHz), and a running session's screen is redrawn at a
// display's refresh rate: a figure the model reports is on the screen at
// most kPanelPublishSteps steps plus one frame later.
inline constexpr int kPanelPublishSteps = 16;
inline constexpr std::chrono::microseconds kRunningScreenPeriod{16'667};
// The damage warning stays up this long (session time) after an episode began.
inline constexpr double kDamageWarningHold_s = 3.0;

// The score's live figures as the loop publishes them (plain values: the
// 1 kHz thread copies them without allocating).
struct ScoreFigures {
  double pain_s{0.0};
  double loop_s{0.0};
  double xray_s{0.0};
  double redout_s{0.0};
  double wall_force_N{0.0};  // the largest wall force of the latest step
  std::uint32_t damage_events{0};
  double last_damage_s{-1.0};  // session time the latest damage episode was reported; < 0: none
  bool operator==(const ScoreFigures&) const = default;
};

// At a publication: the session's metrics so far and its latest step's
// largest wall force. A new damage episode (metrics.damage_events went up)
// is stamped with the session time it was reported at; a new session (no
// damage yet) clears the stamp.
void TrackScoreFigures(const training::Metrics& metrics, double wall_force_N,
                       ScoreFigures* figures);

// The warning is up: a damage episode was reported less than
// kDamageWarningHold_s before `elapsed_s`.
bool DamageWarningOn(const ScoreFigures& figures, double elapsed_s);

// The sitting's line under the debrief: "session 3 of this sitting   best: 2
// (45.0/100)   last: 3 (38.2/100)"; empty for an empty sitting.
std::string SittingLine(const training::Sitting& sitting);

// The debrief over `box`: one line per weighed part ("pain  9.1 of 10.0
// (pain 1.0 s)  at 41.2 s for 1.0 s in the sigmoid; ..."), a line "total"
// with the score, and `sitting_line`. Lines whose part cost points are
// amber, damage red. Text shrinks to fit, never cut.
void DrawDebrief(cv::Mat& canvas, const cv::Rect& box, const training::Debrief& debrief,
                 const std::string& sitting_line, double scale);

}  // namespace ves::ui
