#include "station/ui/score_panel.h"

#include <algorithm>
#include <cstdio>

#include "station/ui/training_screen.h"

namespace ves::ui {
namespace {

const cv::Scalar kText(235, 235, 235);
const cv::Scalar kDim(170, 170, 170);
const cv::Scalar kAmber(40, 170, 230);
const cv::Scalar kRed(60, 60, 235);

std::string Points(const char* format, double a, double b = 0.0) {
  char text[64];
  std::snprintf(text, sizeof text, format, a, b);
  return text;
}

}  // namespace

void TrackScoreFigures(const training::Metrics& metrics, double wall_force_N,
                       ScoreFigures* figures) {
  if (metrics.damage_events == 0) {
    figures->last_damage_s = -1.0;
  } else if (metrics.damage_events > figures->damage_events) {
    figures->last_damage_s = metrics.duration_s;
  }
  figures->damage_events = metrics.damage_events;
  figures->pain_s = metrics.pain_s;
  figures->loop_s = metrics.loop_s;
  figures->xray_s = metrics.xray_s;
  figures->redout_s = metrics.redout_s;
  figures->wall_force_N = wall_force_N;
}

bool DamageWarningOn(const ScoreFigures& figures, double elapsed_s) {
  return figures.last_damage_s >= 0.0 && elapsed_s - figures.last_damage_s < kDamageWarningHold_s;
}

std::string SittingLine(const training::Sitting& sitting) {
  const auto& sessions = sitting.sessions();
  if (sessions.empty()) return "";
  const auto number_and_score = [&](std::size_t i) {
    return Points("%.0f (%.1f/100)", static_cast<double>(i + 1), sessions[i].score);
  };
  return "session " + std::to_string(sessions.size()) + " of this sitting     best: " +
         number_and_score(*sitting.best()) + "     last: " + number_and_score(sessions.size() - 1);
}

void DrawDebrief(cv::Mat& canvas, const cv::Rect& box, const training::Debrief& debrief,
                 const std::string& sitting_line, double scale) {
  // The headline (a cecum not reached), the parts, the total, the sitting:
  // equal lines filling the box.
  const int headline = debrief.headline.empty() ? 0 : 1;
  const int lines = headline + static_cast<int>(debrief.parts.size()) + 2;
  const int line = box.height / std::max(lines, 1);
  const int name_width = box.width * 30 / 100;
  int y = box.y;
  if (headline) {
    // Thin strokes: the line is long and drawn small; bold blurs it.
    DrawTextFitted(canvas, debrief.headline, {box.x, y, box.width, line}, 0.7 * scale, kAmber);
    y += line;
  }
  for (const training::DebriefPart& part : debrief.parts) {
    const bool damage = part.name == "damage";
    const bool cost = damage ? part.points < 0.0 : part.points < part.max_points - 0.05;
    const cv::Scalar color = damage && cost ? kRed : cost ? kAmber : kText;
    const std::string head =
        damage ? part.name + Points("  %+.1f", part.points)
               : part.name + Points("  %.1f of %.1f", part.points, part.max_points);
    std::string detail = "(" + part.measure + ")";
    for (std::size_t i = 0; i < part.places.size(); ++i) {
      detail += (i == 0 ? "  " : "; ") + part.places[i];
    }
    DrawTextFitted(canvas, head, {box.x, y, name_width, line}, 0.7 * scale, color);
    DrawTextFitted(canvas, detail, {box.x + name_width, y, box.width - name_width, line},
                   0.6 * scale, color);
    y += line;
  }
  DrawTextFitted(canvas, Points("score  %.1f of 100", debrief.score), {box.x, y, box.width, line},
                 0.75 * scale, kAmber, false, 2);
  y += line;
  DrawTextFitted(canvas, sitting_line, {box.x, y, box.width, line}, 0.65 * scale, kDim);
}

}  // namespace ves::ui
