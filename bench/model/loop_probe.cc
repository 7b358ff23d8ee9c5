// loop_probe: does a loop form? Runs a push-only hand (a steady push of F
// newtons, knobs neutral: the scripted novice) or the scripted expert on a
// case and prints issue #47's loop figures in one RESULT line:
//   loop_probe CASE_FILE novice:F|expert SECONDS [key=value ...]
// (keys: bench/model/model_overrides.h and the expert's). Figures:
//   tip_at_060   the tip's place along the colon when 0.60 m is in, and
//                sd_junction, where the descending colon starts
//   min_ratio    the least tip advance over insertion in any 10 cm window of
//                insertion with the tip in the sigmoid
//   apex_rise    the most the sigmoid's highest (most cranial, +z) point
//                rose above its rest height
//   wall_strain  the largest strain of the wall itself, beyond the gathered
//                reserve (a gap's length over its material length, less 1)
//   pain_s, damage, cecum_s, inserted_at_cecum: as the session metrics
//                count them (training::MetricThresholds)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench/model/model_overrides.h"
#include "patient_db/case_format.h"
#include "station/model/model.h"
#include "station/training/case_model.h"
#include "station/training/metric_thresholds.h"
#include "station/training/scripted_operator.h"
#include "station/training/session_runner.h"

namespace {

using ves::model::Region;

struct Track {
  double inserted_m;
  double tip_arc_m;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: loop_probe CASE_FILE novice:F|expert SECONDS [key=value ...]\n");
    return 2;
  }
  const ves::bench::CommandLineOverrides overrides = ves::bench::ParseOverrides(argc, argv, 4);
  const std::string& tag = overrides.tag;
  auto get = [&](const char* k, double fallback) { return overrides.Get(k, fallback); };
  const auto params = ves::bench::LoadParamsWithOverrides(argv[1], get);
  const std::string op_name = argv[2];
  std::unique_ptr<ves::training::ScriptedOperator> op;
  if (op_name.rfind("novice:", 0) == 0) {
    op = std::make_unique<ves::training::NoviceOperator>(std::atof(op_name.c_str() + 7));
  } else {
    op = ves::training::MakeScriptedOperator(op_name, params.dt_s,
                                             ves::bench::ExpertSettingsWithOverrides(get));
  }
  const double seconds = std::atof(argv[3]);
  const auto& pts = params.colon.points;
  const int n = static_cast<int>(pts.size());
  double sigmoid_from_m = -1.0, sigmoid_to_m = -1.0, descending_m = -1.0, cecum_m = pts.back().arc_m;
  double rest_apex_m = -1e9;
  for (const auto& p : pts) {
    if (p.region == Region::kSigmoid) {
      if (sigmoid_from_m < 0.0) sigmoid_from_m = p.arc_m;
      sigmoid_to_m = p.arc_m;
      rest_apex_m = std::max(rest_apex_m, p.rest_position_m.z());
    }
    if (p.region == Region::kDescending && descending_m < 0.0) descending_m = p.arc_m;
    if (p.region == Region::kCecum && cecum_m == pts.back().arc_m) cecum_m = p.arc_m;
  }
  auto state = ves::model::MakeInitialState(params);
  auto scratch =
      ves::model::MakeScratch(params, ves::bench::ExperimentsWithOverrides(get));
  auto out = ves::model::MakeStepOutput(params);
  const ves::training::MetricThresholds thresholds;
  std::vector<Track> track;
  // position=P (1 left lateral, 2 right lateral) from position_from=T s.
  const int position = static_cast<int>(get("position", 0.0));
  const double position_from_s = get("position_from", 0.0);
  // trace=S: a line every S x 10 ms.
  const long trace_every = static_cast<long>(get("trace", 0.0));
  double tip_at_060 = -1.0, apex_rise_m = 0.0, wall_strain = 0.0, pain_s = 0.0;
  double t_cecum = -1.0, inserted_at_cecum = -1.0, last_damage_s = -1e9, peak_hand = 0.0;
  double peak_wall = 0.0, max_inserted = 0.0;
  int damage = 0;
  long steps = 0;
  const int every = std::max(1, static_cast<int>(std::lround(0.01 / params.dt_s)));
  while (state.time_s < seconds) {
    const auto p = ves::training::Perceive(params, state, out);
    const auto sample = op->Act(p);
    auto input = ves::training::ToStepInput(sample);
    if (state.time_s >= position_from_s) {
      input.patient_position = static_cast<ves::model::PatientPosition>(position);
    }
    ves::model::Step(params, input, &state, &scratch, &out);
    if (!out.finite) {
      std::printf("%s %s %s diverged at %.3f\n", argv[1], argv[2], tag.c_str(), state.time_s);
      return 1;
    }
    peak_hand = std::max(peak_hand, std::abs(sample.push_force_N));
    max_inserted = std::max(max_inserted, state.inserted_m);
    peak_wall = std::max(peak_wall, out.peak_wall_force_N);
    if (out.peak_stretch_m > thresholds.pain_stretch_m) pain_s += params.dt_s;
    if (out.peak_wall_force_N > thresholds.damage_wall_force_N) {
      if (state.time_s - last_damage_s > thresholds.episode_merge_gap_s) ++damage;
      last_damage_s = state.time_s;
    }
    if (++steps % every != 0) continue;
    track.push_back({state.inserted_m, state.tip_arc_m});
    if (tip_at_060 < 0.0 && state.inserted_m >= 0.60) tip_at_060 = state.tip_arc_m;
    double apex = -1e9;
    for (int i = 0; i < n; ++i) {
      if (pts[i].region == Region::kSigmoid) apex = std::max(apex, state.p_WColon[i].z());
    }
    apex_rise_m = std::max(apex_rise_m, apex - rest_apex_m);
    if (trace_every > 0 && steps % (trace_every * every) == 0) {
      std::printf("  t=%.2f in=%.3f tip=%.3f apex=%+.3f stretch=%.3f at %.3f base=%.1f wall=%.1f strain=%.3f\n",
                  state.time_s, state.inserted_m, state.tip_arc_m, apex - rest_apex_m,
                  out.peak_stretch_m, out.peak_stretch_arc_m, out.base_force_N,
                  out.peak_wall_force_N, out.peak_wall_strain);
    }
    wall_strain = std::max(wall_strain, out.peak_wall_strain);
    if (state.tip_arc_m >= cecum_m) {
      t_cecum = state.time_s;
      inserted_at_cecum = state.inserted_m;
      break;
    }
  }
  // The least tip advance per insertion over 10 cm windows with the tip in the sigmoid.
  double min_ratio = 1e9, min_ratio_at = -1.0;
  for (std::size_t i = 0, j = 0; i < track.size(); ++i) {
    if (track[i].tip_arc_m < sigmoid_from_m) continue;
    j = std::max(j, i);
    while (j < track.size() && track[j].inserted_m - track[i].inserted_m < 0.10) ++j;
    if (j >= track.size()) break;
    if (track[j].tip_arc_m > sigmoid_to_m) continue;
    const double ratio = (track[j].tip_arc_m - track[i].tip_arc_m) /
                         (track[j].inserted_m - track[i].inserted_m);
    if (ratio < min_ratio) {
      min_ratio = ratio;
      min_ratio_at = track[i].inserted_m;
    }
  }
  const std::string file = argv[1];
  std::printf("RESULT case=%s op=%s tip_at_060=%.3f sd_junction=%.3f min_ratio=%.2f at=%.2f "
              "apex_rise=%.3f wall_strain=%.3f pain_s=%.0f damage=%d peak_wall=%.1f peak_hand=%.1f "
              "cecum_s=%.1f inserted_at_cecum=%.3f max_inserted=%.3f tip=%.3f %s\n",
              file.substr(file.rfind('/') + 1).c_str(), argv[2], tip_at_060, descending_m,
              min_ratio, min_ratio_at, apex_rise_m, wall_strain, pain_s, damage, peak_wall,
              peak_hand, t_cecum, inserted_at_cecum, max_inserted,
              state.tip_arc_m, tag.c_str());
  return 0;
}
