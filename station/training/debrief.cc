#include "station/training/debrief.h"

#include <cstdio>

namespace ves::training {
namespace {

std::string Format(const char* format, double a, double b = 0.0, double c = 0.0) {
  char text[160];
  std::snprintf(text, sizeof(text), format, a, b, c);
  return text;
}

// The places of the events of `kind`: when, for how long, where.
std::vector<std::string> PlacesOf(const std::vector<Event>& events, EventKind kind,
                                  const std::function<std::string(double)>& region_at) {
  std::vector<std::string> places;
  std::size_t count = 0;
  for (const Event& e : events) {
    if (e.kind != kind) continue;
    if (++count > kMaxPlaces) continue;
    std::string place = Format("at %.1f s", e.t_s);
    if (kind == EventKind::kFluoroscopy) {
      place = "on " + place;
    } else {
      place += Format(" for %.1f s", e.duration_s);
      if (region_at) place += " in the " + region_at(e.arc_m);
    }
    places.push_back(place);
  }
  if (count > kMaxPlaces) places.push_back("and " + std::to_string(count - kMaxPlaces) + " more");
  return places;
}

}  // namespace

Debrief CalcDebrief(const Metrics& m, const std::vector<Event>& events, v1::Difficulty difficulty,
                    double cecum_arc_m, const ScoreParams& params,
                    const std::function<std::string(double arc_m)>& region_at) {
  const ScoreComponents c = CalcScoreComponents(m, cecum_arc_m, params);
  const ScoreWeights& w = params.WeightsFor(difficulty);
  const double other_weight = w.pain + w.loop + w.force + w.xray + w.redout;
  Debrief d;
  // Completed: 50 for the cecum, 50 × weight × component per part. Not
  // completed: 50 × progress × (weight / other weights) × component per
  // part other than time (CalcScore's renormalisation), the cecum nothing.
  double per_weight = 50.0;
  if (!m.completed) {
    // Said first: a trainee reading only amber parts would not know why.
    d.headline = Format("Cecum not reached: the tip got %.2f m of the %.2f m", m.max_tip_arc_m,
                        cecum_arc_m);
    if (region_at) d.headline += ", as far as the " + region_at(m.max_tip_arc_m);
    d.headline += other_weight > 0.0
                      ? Format("; every part below is scaled by that %.0f %% of the way",
                               100.0 * c.progress)
                      : Format("; the cecum part gives %.0f %% of its points, the way made",
                               100.0 * c.progress);
  }
  if (m.completed) {
    d.parts.push_back({"cecum", 50.0, 50.0, Format("reached in %.1f s", m.time_to_cecum_s), {}});
    d.parts.push_back({"time", 50.0 * w.time * c.time, 50.0 * w.time,
                       Format("%.1f s to the cecum", m.time_to_cecum_s), {}});
  } else if (other_weight > 0.0) {
    // The time part is out of play; the others share the 50 points.
    per_weight = 50.0 * c.progress / other_weight;
    d.parts.push_back({"cecum", 0.0, 50.0,
                       Format("not reached: %.0f %% of the way", 100.0 * c.progress),
                       {}});
  } else {  // only time counts (easy) and it was not reached: the way made
    d.parts.push_back({"cecum", 50.0 * c.progress, 50.0,
                       Format("not reached: %.0f %% of the way", 100.0 * c.progress), {}});
    d.parts.push_back({"time", 0.0, 50.0, "the cecum not reached", {}});
    per_weight = 0.0;
  }
  const auto part = [&](const char* name, double weight, double component, std::string measure,
                        EventKind kind) {
    if (weight <= 0.0) return;
    d.parts.push_back({name, per_weight * weight * component,
                       (m.completed ? 50.0 : 50.0 / other_weight) * weight, std::move(measure),
                       PlacesOf(events, kind, region_at)});
  };
  part("pain", w.pain, c.pain, Format("pain %.1f s", m.pain_s), EventKind::kPain);
  part("loops", w.loop, c.loop, Format("loop %.1f s", m.loop_s), EventKind::kLoop);
  part("force", w.force, c.force, Format("excessive force %.1f s", m.excessive_force_s),
       EventKind::kExcessiveForce);
  part("x-ray", w.xray, c.xray, Format("X-ray %.1f s of %.1f s", m.xray_s, m.duration_s),
       EventKind::kFluoroscopy);
  part("red-out", w.redout, c.redout, Format("red-out %.1f s of %.1f s", m.redout_s, m.duration_s),
       EventKind::kRedout);
  if (m.damage_events > 0) {
    d.parts.push_back({"damage", -params.damage_penalty_points * m.damage_events, 0.0,
                       std::to_string(m.damage_events) + " damage episode" +
                           (m.damage_events == 1 ? "" : "s") +
                           Format(", %.0f points each", params.damage_penalty_points),
                       PlacesOf(events, EventKind::kDamage, region_at)});
  }
  d.score = CalcScore(m, difficulty, cecum_arc_m, params);
  return d;
}

std::string DebriefText(const Debrief& debrief, const std::string& indent) {
  std::string text;
  if (!debrief.headline.empty()) text += indent + debrief.headline + "\n";
  double sum = 0.0;
  for (const DebriefPart& p : debrief.parts) {
    sum += p.points;
    text += indent + p.name + " " +
            (p.name == "damage" ? Format("%.1f", p.points)
                                : Format("%.1f of %.1f", p.points, p.max_points)) +
            " (" + p.measure + ")";
    for (std::size_t i = 0; i < p.places.size(); ++i) {
      text += (i == 0 ? ": " : "; ") + p.places[i];
    }
    text += "\n";
  }
  if (sum < 0.0 || sum > 100.0) {
    text += indent + Format("(the parts sum to %.1f; the score is bounded to %.1f)", sum,
                            debrief.score) + "\n";
  }
  return text;
}

}  // namespace ves::training
