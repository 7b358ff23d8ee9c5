// expert_sweep: runs the scripted expert (or novice) on a case with model and
// operator settings overridden from the command line, and prints one line of
// results, for parameter sweeps (docs/model-shortening-notes.md).
//   expert_sweep CASE_FILE OPERATOR SECONDS [key=value ...]
//   expert_sweep --expert-defaults   (the expert's main settings, key=value)
// Keys: the model's (bench/model/model_overrides.h: mu, soft_k, meso_k,
// links, ...); the expert's advance, withdraw, push, pull, loop_limit,
// roll_rate, settle; the assistant's press_sig, press_desc, press_trans,
// press_past, press_gate, press_on_stretch, press_release (pressing a
// region while the patient complains of it); show_damage=1 prints each
// damage episode, show_over10=1 the base force over 10 N, show_roll=1 each
// step with the roll torque over 1 N·m, trace_from=T 12 steps from T
// (samples near the largest wall force, ring contacts).
// The line gives the roll torque's peak, its 10 ms mean's peak (the force
// metric's resolution) and roll_over1, the share of steps over 1 N·m;
// damage counts episodes of the largest wall force's 10 ms mean over the
// damage level (as the session's metrics do), damage_1ms those of single
// steps (show_damage=1 prints these). ring_hold is the peak 10 ms mean of
// the ring contacts' push along the shaft toward the anus (N), ring_hold_s
// the time they hold more than half of a push of 4 N or more.
// show_every=S prints the operator's state every S seconds.
// show_reduce=1 prints each turn of the hand between pushing and pulling;
// op_press_from/op_press_s/op_turns/op_turn_from give when and how long the
// operator had the assistant press and how often it turned the patient.
// state_hash=1 also prints a hash of the final model state (every colon and
// scope array, bit for bit): a speed change that must not change one result
// gives the same hash before and after it.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

#include "bench/model/model_overrides.h"
#include "patient_db/case_format.h"
#include "station/model/model.h"
#include "station/training/case_model.h"
#include "station/training/metric_thresholds.h"
#include "station/training/scripted_operator.h"
#include "station/training/session_runner.h"

namespace {

// One step of trace_from=T: the largest wall force and where, every sample
// tracked within 4 segments of it (a sample changing segment from step to
// step shows up here), and every ring contact with its load.
// FNV-1a over the bytes of the state's arrays (they hold doubles only).
std::uint64_t HashModelState(const ves::model::ModelState& state) {
  std::uint64_t hash = 14695981039346656037ull;
  auto add = [&](const void* data, std::size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) hash = (hash ^ p[i]) * 1099511628211ull;
  };
  auto add_vector = [&](const auto& v) { add(v.data(), v.size() * sizeof(v[0])); };
  add(&state.time_s, sizeof state.time_s);
  add(&state.inserted_m, sizeof state.inserted_m);
  add(&state.roll_rad, sizeof state.roll_rad);
  add(&state.tip_arc_m, sizeof state.tip_arc_m);
  add_vector(state.bend_rad);
  add_vector(state.bend_rate_rad_per_s);
  add_vector(state.p_WSample);
  add_vector(state.colon_displacement_m);
  add_vector(state.colon_reference_m);
  add_vector(state.colon_pair_rest_gap_m);
  add_vector(state.colon_velocity_m_per_s);
  add_vector(state.p_WColon);
  add_vector(state.colon_tangent);
  add_vector(state.colon_gap_m);
  add_vector(state.colon_tether_distance_m);
  add_vector(state.colon_lumen_radius_m);
  add_vector(state.wall_deformation_m);
  add_vector(state.ring_onset);
  return hash;
}

void PrintStepTrace(const ves::model::ModelParams& params, const ves::model::ModelState& state,
                    const ves::model::StepOutput& out, const ves::model::Scratch& scratch,
                    double hand_N) {
  const int at = ves::bench::LargestWallForcePoint(out);
  std::printf("  trace t=%.3f base %.2f N hand %.2f N thrust %+.1f um; wall %.2f N at point %d (arc %.3f)\n",
              state.time_s, out.base_force_N, hand_N, 1e6 * state.insertion_rate_m_per_s * params.dt_s,
              out.peak_wall_force_N, at, params.colon.points[at].arc_m);
  std::printf("     point: angle between its tangent and the next one's, now/at rest (deg), moved (mm):");
  for (int m = std::max(at - 3, 0); m <= std::min<int>(at + 2, state.colon_tangent.size() - 2); ++m) {
    const auto& pts = params.colon.points;
    const double now = std::acos(std::clamp(state.colon_tangent[m].dot(state.colon_tangent[m + 1]), -1.0, 1.0));
    const double rest = std::acos(std::clamp(pts[m].rest_tangent.dot(pts[m + 1].rest_tangent), -1.0, 1.0));
    std::printf(" %d:%.0f/%.0f,%.1f", m, now * 57.2958, rest * 57.2958,
                1e3 * (state.p_WColon[m] - pts[m].rest_position_m).norm());
  }
  std::printf("\n");
  std::printf("     sample:segment(t, touching)");
  for (int i = state.first_inside_sample; i < static_cast<int>(state.contact.size()); ++i) {
    const auto& c = state.contact[i];
    if (std::abs(c.segment - at) <= 4) {
      std::printf(" %d:%d(%.2f,%s)", i, c.segment, c.segment_t, c.touching ? "T" : "-");
    }
  }
  std::printf("\n");
  for (int j = 0; j < scratch.ring_contact_count; ++j) {
    const auto& rc = scratch.ring_contacts[j];
    std::printf("     ring: point %d on the piece after sample %d (t %.2f), %.1f mm in, %.2f N "
                "(onset %.2f)\n",
                rc.point, rc.sample, rc.piece_t, 1e3 * rc.penetration_m, rc.force_N, rc.onset);
  }
}

}  // namespace

int main(int argc, char** argv) {
  // The expert's main settings as they are compiled in, for the ±20 % sweep
  // (bench/model/expert_robustness.sh), so it keeps no copy of them.
  if (argc == 2 && std::string(argv[1]) == "--expert-defaults") {
    const ves::training::ExpertOperator::Settings d;
    std::printf("advance=%g withdraw=%g push=%g pull=%g loop_limit=%g roll_rate=%g\n",
                d.advance_speed_m_per_s, d.withdraw_speed_m_per_s, d.push_limit_N,
                d.pull_limit_N, d.loop_limit_m, d.roll_rate_rad_per_s);
    return 0;
  }
  if (argc < 4) {
    std::fprintf(stderr, "usage: expert_sweep CASE_FILE novice|expert SECONDS [key=value ...]\n");
    return 2;
  }
  const ves::bench::CommandLineOverrides overrides = ves::bench::ParseOverrides(argc, argv, 4);
  const std::string& tag = overrides.tag;
  auto get = [&](const char* k, double fallback) { return overrides.Get(k, fallback); };
  const auto params = ves::bench::LoadParamsWithOverrides(argv[1], get);
  auto op = ves::training::MakeScriptedOperator(argv[2], params.dt_s,
                                                ves::bench::ExpertSettingsWithOverrides(get));
  const double seconds = std::atof(argv[3]);
  // The cecum starts where the case's cecum region starts (else the end).
  double cecum_m = params.colon.points.back().arc_m;
  for (const auto& point : params.colon.points) {
    if (point.region == ves::model::Region::kCecum) {
      cecum_m = point.arc_m;
      break;
    }
  }
  // The assistant presses over a mobile region once the tip is
  // press_past m beyond its end (keys press_sig, press_trans: the pressure).
  double region_end_m[9] = {0};
  for (const auto& point : params.colon.points) {
    region_end_m[static_cast<int>(point.region)] = point.arc_m;
  }
  const double press_past_m = get("press_past", 0.10);
  const double press[9] = {0, 0, get("press_sig", 0.0), get("press_desc", 0.0), 0,
                           get("press_trans", 0.0), 0, 0, 0};
  auto state = ves::model::MakeInitialState(params);
  auto scratch =
      ves::model::MakeScratch(params, ves::bench::ExperimentsWithOverrides(get));
  auto out = ves::model::MakeStepOutput(params);
  const double pain_m = ves::training::MetricThresholds{}.pain_stretch_m;
  double t_cecum = -1.0, inserted_at_cecum = -1.0, max_tip = 0.0, peak_force = 0.0;
  double peak_roll = 0.0, peak_fixed = 0.0, pain15_s = 0.0, pain20_s = 0.0, pain_s = 0.0;
  long over10 = 0, steps = 0;
  // Damage episodes of single steps: wall force over the threshold,
  // episodes closer than the merge gap counted once.
  const ves::training::MetricThresholds thresholds;
  int damage_events = 0;
  double peak_wall_N = 0.0, last_damage_s = -1e9;
  // The same of the largest wall force's 10 ms mean, as the session's
  // metrics count them: a contact spike of a few steps is counted above only.
  ves::bench::TenStepMean wall_10ms;
  int damage10_events = 0;
  double last_damage10_s = -1e9;
  ves::bench::TenStepMean force_10ms;  // of |force|
  // The roll torque likewise: its peak, its 10 ms mean's peak, steps over 1 N·m.
  ves::bench::TenStepMean roll_10ms;
  double peak_roll_10ms = 0.0;
  // Ring contacts holding the shaft along its length, toward the anus (a
  // ring beyond its piece's end acts as a barb: docs/model-shortening-notes.md,
  // "Rings that hold the scope along its length"): the 10 ms mean's peak, and
  // the time they hold more than half of a push of 4 N or more.
  ves::bench::TenStepMean ring_hold_10ms;
  double peak_ring_hold_N = 0.0, ring_hold_s = 0.0;
  long roll_over1 = 0;
  double pull_s = 0.0, reduced_to_m = 0.0;
  // press_gate > 0: the assistant presses a region (from then on) once its
  // path is within press_gate times its chord (it has been straightened).
  const double press_gate = get("press_gate", 0.0);
  const double press_on_stretch_m = get("press_on_stretch", 0.0);
  const double press_release_m = get("press_release", 0.0);
  int region_first[9], region_last[9];
  for (int r = 0; r < 9; ++r) region_first[r] = region_last[r] = -1;
  for (int i = 0; i < static_cast<int>(params.colon.points.size()); ++i) {
    const int r = static_cast<int>(params.colon.points[i].region);
    if (region_first[r] < 0) region_first[r] = i;
    region_last[r] = i;
  }
  // trace_from=T: 12 steps from T, each with the point of the largest wall
  // force and the samples tracked near it; show_over10=1: a line every 0.5 s
  // while the base force is over 10 N.
  const double trace_from_s = get("trace_from", 1e9);
  const bool show_over10 = get("show_over10", 0.0) != 0.0;
  const bool show_roll = get("show_roll", 0.0) != 0.0;
  double last_over10_shown_s = -1.0;
  bool pressing[9] = {false};
  double press_from_s[9] = {-1, -1, -1, -1, -1, -1, -1, -1, -1};
  double help_press_from_s = -1.0, help_press_s = 0.0, first_turn_s = -1.0;
  int position_changes = 0;
  const bool show_reduce = get("show_reduce", 0.0) != 0.0;
  const double show_every_s = get("show_every", 0.0);
  double last_shown_s = -1e9;
  double last_hand_N = 0.0;
  ves::training::LoopIndex loop_watch;
  auto last_position = ves::training::PatientPosition::kSupine;
  while (state.time_s < seconds) {
    const auto p = ves::training::Perceive(params, state, out);
    const auto sample = op->Act(p);
    auto input = ves::training::ToStepInput(sample);
    if (show_reduce && (sample.push_force_N < 0.0) != (last_hand_N < 0.0)) {
      std::printf("  hand %s t=%.1f inserted %.3f tip %.3f loop %.3f stretch %.3f press %d pos %d\n",
                  sample.push_force_N < 0.0 ? "pulls" : "pushes", state.time_s, state.inserted_m,
                  state.tip_arc_m, loop_watch.Update(state.inserted_m, state.tip_arc_m),
                  out.peak_stretch_m, static_cast<int>(sample.abdominal_press),
                  static_cast<int>(sample.patient_position));
    }
    last_hand_N = sample.push_force_N;
    if (show_every_s > 0.0 && state.time_s - last_shown_s >= show_every_s) {
      last_shown_s = state.time_s;
      std::printf("  t=%.1f inserted %.3f tip %.3f loop %.3f stretch %.3f at %.3f hand %.1f base %.1f "
                  "wall %.1f press %d pos %d\n",
                  state.time_s, state.inserted_m, state.tip_arc_m,
                  loop_watch.Update(state.inserted_m, state.tip_arc_m), out.peak_stretch_m,
                  out.peak_stretch_arc_m, sample.push_force_N, out.base_force_N,
                  out.peak_wall_force_N, static_cast<int>(sample.abdominal_press),
                  static_cast<int>(sample.patient_position));
    }
    // The operator's own calls for help: the assistant's hand and the patient's position.
    if (sample.abdominal_press != ves::training::AbdominalPress::kNone) {
      if (help_press_from_s < 0.0) help_press_from_s = state.time_s;
      help_press_s += params.dt_s;
    }
    if (sample.patient_position != last_position) {
      ++position_changes;
      if (first_turn_s < 0.0) first_turn_s = state.time_s;
      last_position = sample.patient_position;
    }
    // A reduction (the hand pulling for a while) straightens what the tip
    // has passed; from then on the assistant holds it.
    pull_s = sample.push_force_N < -1.0 ? pull_s + params.dt_s : 0.0;
    if (pull_s > 2.0) reduced_to_m = std::max(reduced_to_m, state.tip_arc_m);
    for (int r = 0; r < 9; ++r) {
      if (press_gate > 0.0 && press[r] > 0.0 && !pressing[r] && region_first[r] >= 0 &&
          state.tip_arc_m > region_end_m[r] + press_past_m) {
        double path = 0.0;
        for (int i = region_first[r]; i < region_last[r]; ++i) {
          path += (state.p_WColon[i + 1] - state.p_WColon[i]).norm();
        }
        const double chord = (state.p_WColon[region_last[r]] - state.p_WColon[region_first[r]]).norm();
        if (path <= press_gate * chord) {
          pressing[r] = true;
          press_from_s[r] = state.time_s;
        }
      }
      // The patient complains of the region (its mesentery stretched over
      // press_on_stretch m): the assistant presses it, until the stretch
      // falls under press_release m (if given).
      const double arc_m = out.peak_stretch_arc_m;
      if (press_on_stretch_m > 0.0 && press[r] > 0.0 && !pressing[r] && region_first[r] >= 0 &&
          out.peak_stretch_m > press_on_stretch_m &&
          arc_m >= params.colon.points[region_first[r]].arc_m && arc_m <= region_end_m[r]) {
        pressing[r] = true;
        if (press_from_s[r] < 0.0) press_from_s[r] = state.time_s;
      }
      if (press_release_m > 0.0 && pressing[r] && out.peak_stretch_m < press_release_m) {
        pressing[r] = false;
      }
      if (pressing[r]) input.abdominal_pressure[r] = press[r];
      if (press_gate == 0.0 && press[r] > 0.0 && reduced_to_m > region_end_m[r] + press_past_m) {
        input.abdominal_pressure[r] = press[r];
      }
    }
    ves::model::Step(params, input, &state, &scratch, &out);
    if (!out.finite) {
      std::printf("%s %s %s diverged at %.3f\n", argv[1], argv[2], tag.c_str(), state.time_s);
      return 1;
    }
    if (state.time_s >= trace_from_s && state.time_s < trace_from_s + 0.012) {
      PrintStepTrace(params, state, out, scratch, sample.push_force_N);
    }
    const double f = std::abs(out.base_force_N);
    peak_force = std::max(peak_force, force_10ms.Add(f));
    if (f > 10.0) {
      ++over10;
      if (show_over10 && state.time_s - last_over10_shown_s > 0.5) {
        last_over10_shown_s = state.time_s;
        std::printf("  over10 t=%.3f base %.1f N hand %.1f N rate %.3f m/s inserted %.3f tip %.3f wall %.1f\n",
                    state.time_s, out.base_force_N, sample.push_force_N, state.insertion_rate_m_per_s,
                    state.inserted_m, state.tip_arc_m, out.peak_wall_force_N);
      }
    }
    ++steps;
    peak_roll = std::max(peak_roll, std::abs(out.roll_torque_Nm));
    if (std::abs(out.roll_torque_Nm) > 1.0) {
      ++roll_over1;
      if (show_roll) {
        std::printf("  roll t=%.3f %.2f N m base %.1f N wall %.1f N inserted %.3f tip %.3f roll_in %.3f\n",
                    state.time_s, out.roll_torque_Nm, out.base_force_N, out.peak_wall_force_N,
                    state.inserted_m, state.tip_arc_m, sample.roll_rad);
      }
    }
    peak_roll_10ms = std::max(peak_roll_10ms, roll_10ms.Add(std::abs(out.roll_torque_Nm)));
    double ring_hold_N = 0.0;  // toward the anus
    for (int j = 0; j < scratch.ring_contact_count; ++j) {
      ring_hold_N -= ves::bench::RingPushAlongScope_N(state, scratch, j);
    }
    peak_ring_hold_N = std::max(peak_ring_hold_N, ring_hold_10ms.Add(ring_hold_N));
    if (sample.push_force_N >= 4.0 && ring_hold_N > 0.5 * sample.push_force_N) {
      ring_hold_s += params.dt_s;
    }
    peak_wall_N = std::max(peak_wall_N, out.peak_wall_force_N);
    if (out.peak_wall_force_N > thresholds.damage_wall_force_N) {
      if (state.time_s - last_damage_s > thresholds.episode_merge_gap_s) {
        ++damage_events;
        if (get("show_damage", 0.0) != 0.0) {
          const int at = ves::bench::LargestWallForcePoint(out);
          std::printf("  damage t=%.2f %.1f N at arc %.3f region %d; tip %.3f inserted %.3f "
                      "hand %.1f N base %.1f N\n",
                      state.time_s, out.peak_wall_force_N, params.colon.points[at].arc_m,
                      static_cast<int>(params.colon.points[at].region), state.tip_arc_m,
                      state.inserted_m, sample.push_force_N, out.base_force_N);
        }
      }
      last_damage_s = state.time_s;
    }
    if (wall_10ms.Add(out.peak_wall_force_N) > thresholds.damage_wall_force_N) {
      if (state.time_s - last_damage10_s > thresholds.episode_merge_gap_s) ++damage10_events;
      last_damage10_s = state.time_s;
    }
    peak_fixed = std::max(peak_fixed, out.peak_fixed_displacement_m);
    max_tip = std::max(max_tip, state.tip_arc_m);
    if (out.peak_stretch_m > 0.015) pain15_s += params.dt_s;
    if (out.peak_stretch_m > 0.02) pain20_s += params.dt_s;
    if (out.peak_stretch_m > pain_m) pain_s += params.dt_s;
    if (t_cecum < 0.0 && state.tip_arc_m >= cecum_m) {
      t_cecum = state.time_s;
      inserted_at_cecum = state.inserted_m;
      break;
    }
  }
  const std::string name = std::string(argv[1]).substr(std::string(argv[1]).rfind('/') + 1);
  std::printf("RESULT case=%s op=%s cecum_s=%.1f inserted_at_cecum=%.3f max_tip=%.3f cecum_at=%.3f "
              "over10=%.2f%% peak_force=%.1f peak_roll=%.2f peak_roll_10ms=%.2f roll_over1=%.2f%% peak_wall=%.1f damage=%d damage_1ms=%d fixed_mm=%.1f pain15=%.0f pain20=%.0f "
              "pain=%.0f press_sig_from=%.0f press_trans_from=%.0f ring_hold=%.1f ring_hold_s=%.0f "
              "op_press_from=%.0f op_press_s=%.0f op_turns=%d op_turn_from=%.0f %s\n",
              name.c_str(), argv[2], t_cecum, inserted_at_cecum, max_tip, cecum_m,
              100.0 * over10 / std::max(1L, steps), peak_force, peak_roll, peak_roll_10ms,
              100.0 * roll_over1 / std::max(1L, steps), peak_wall_N, damage10_events, damage_events,
              1e3 * peak_fixed,
              pain15_s, pain20_s, pain_s, press_from_s[2], press_from_s[5], peak_ring_hold_N,
              ring_hold_s, help_press_from_s, help_press_s, position_changes, first_turn_s,
              tag.c_str());
  if (get("state_hash", 0.0) != 0.0) {
    std::printf("STATE_HASH %016llx\n", static_cast<unsigned long long>(HashModelState(state)));
  }
  return 0;
}
