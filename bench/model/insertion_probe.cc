// insertion_probe: drives the model on a case and prints where the tip is,
// once per simulated second, so a model or operator change can be judged by
// what it does to an insertion (docs/model-shortening-notes.md, "To measure").
//   insertion_probe CASE_FILE [speed_mm_per_s=20] [seconds=120] [segments=150] [--flag ...]
// Without --operator it inserts by position at the given speed with the
// simple steering rule (knobs turned toward the lumen 4 cm ahead), which is
// the "a loop forms" driver of the model tests. Flags (--key=value; --key
// alone is --key=1; '-' and '_' alike in a key):
//   --operator=novice|expert   a scripted operator drives instead
//   --advance, --withdraw, --push, --pull, --loop-limit,
//   --roll-rate, --settle      the expert's settings (ExpertOperator::Settings)
//   --withdraw-at=M            position rule: at M metres inserted, withdraw
//   --withdraw-m=W             ... by W metres (default 0.25)
//   --roll=R                   ... turning the roll at R rad/s (+: clockwise)
//   --roll-max=A               ... up to A rad at most (default: no limit)
//   --pin-tip                  ... with the tip held where the withdrawal began
//                                  (a perfect hook; also for --reduce)
//   --reinsert                 ... then insert again; --withdraw-every=E
//                                  repeats the withdrawal every E metres
//   --<key>=V                  a model setting, key one of the keys of
//                                  bench/model/model_overrides.h
//                                  (--mu=0.5 halves friction, --soft-k,
//                                  --ei, --meso-k, --pleat, --links ...)
//   --dump-every=S             draw both shapes to /tmp/probe_T.png every S s
//   --wall=F                   print when and where the wall force rises over F N
//   --forces=S                 every S s: what holds the scope along its axis
//                                  (friction, wall normals, rings; the largest)
//   --joints                   at the end: the inserted links' lengths and bends
//   --tip-resist=F             an axial F newtons on the tip against its advance
//   --slack                    at the end: the extremes of the inserted length
//                                  less the colon's path behind the tip
//   --pleat-profile=M          each second: the pleat ratio in 2 cm bins of the
//                                  first M metres of colon
//   --tip-aim                  each second: the tip's place and axis, and its
//                                  angle off the lumen ahead
//   --region-move=R            each second: how far region R's points (a Region
//                                  number, 2 = sigmoid) have moved from rest
//   --regions=S                every S s: each region's path, chord and pleats
//   --phases                   a scripted operator's hand reversing (push / pull)
//   --input                    ... with its push and roll
//   --push-force=F             a constant push of F newtons, knobs neutral (Fig. 10)
//   --stiff-colon              the case as --stiff-colon loads it
//   --knob-max=A               position rule: the knobs turned at most A rad in all
//   --reduce                   position rule: reduce by the loop index, over
//                                  --fixed-limit (0.06 m) with the tip in fixed
//                                  colon or --mobile-limit (0.25 m) in mobile
//                                  colon, until the tip comes back 1.5 cm; with
//                                  --reduce-again-m, --stall-s, --hold-s,
//                                  --unhook, --stiffen=X (the insertion tube
//                                  X times stiffer after the first reduction),
//                                  --hook=A (the tip bent at least A rad while
//                                  withdrawing)
//   --spike-detail, --lost, --side, --track,
//   --track-detail             more detail on force spikes, lost tracking, the
//                                  mesentery's side and the tracked arcs
// Each flag is read once, before the run; one that nothing reads (misspelt,
// or an expert setting without --operator) stops the probe (exit 2).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bench/model/model_overrides.h"
#include "patient_db/case_format.h"
#include "station/model/model.h"
#include "station/training/case_model.h"
#include "station/training/metrics.h"
#include "station/training/observer.h"
#include "station/training/scripted_operator.h"
#include "station/training/session_runner.h"

namespace {

// How far the tip has gone into the fixed (retroperitoneal) colon it is in,
// 0 in colon that hangs on a mesentery: the probe's reduction rule reads the
// case's regions (the scripted expert does not).
double TipIntoFixedColon(const ves::model::ModelParams& params, double tip_arc_m) {
  const auto& pts = params.colon.points;
  auto at = std::upper_bound(
      pts.begin(), pts.end(), tip_arc_m,
      [](double arc_m, const ves::model::ColonPoint& point) { return arc_m < point.arc_m; });
  if (at != pts.begin()) --at;  // the last point at or before the tip
  if (at->tissue.mobile) return 0.0;
  auto start = at;
  while (start != pts.begin() && !(start - 1)->tissue.mobile) --start;
  return tip_arc_m - start->arc_m;
}

using ves::model::StepInput;

// The colon's current path length from the anus to the tip's place in its
// material (pleats count their zigzag, a stretched wall its stretch).
double ColonPathBehindTheTip(const ves::model::ModelParams& params,
                             const ves::model::ModelState& state) {
  const auto& pts = params.colon.points;
  double path_m = 0.0;
  size_t i = 0;
  for (; i + 1 < pts.size() && pts[i + 1].arc_m <= state.tip_arc_m; ++i) {
    path_m += (state.p_WColon[i + 1] - state.p_WColon[i]).norm();
  }
  if (i + 1 < pts.size()) {
    const double t = (state.tip_arc_m - pts[i].arc_m) / (pts[i + 1].arc_m - pts[i].arc_m);
    path_m += t * (state.p_WColon[i + 1] - state.p_WColon[i]).norm();
  }
  return path_m;
}

// AP (x, z) and lateral (y, z) projections: rest centerline grey, deformed
// colon blue (darker where pleated), scope red.
void DumpShape(const ves::model::ModelParams& params, const ves::model::ModelState& state,
               const ves::model::StepOutput& out, const std::string& path) {
  const double px_per_m = 1200.0;
  cv::Mat image(900, 1100, CV_8UC3, cv::Scalar(255, 255, 255));
  auto to_px = [&](double h, double v, int panel) {
    return cv::Point(static_cast<int>(panel * 550 + 275 + h * px_per_m),
                     static_cast<int>(850 - v * px_per_m));
  };
  for (int panel = 0; panel < 2; ++panel) {
    auto project = [&](const Eigen::Vector3d& p) {
      return panel == 0 ? to_px(-p.x(), p.z(), 0) : to_px(p.y(), p.z(), 1);
    };
    const auto& pts = params.colon.points;
    for (size_t i = 1; i < pts.size(); ++i) {
      cv::line(image, project(pts[i - 1].rest_position_m), project(pts[i].rest_position_m),
               cv::Scalar(210, 210, 210), 1);
      const double pleat = std::clamp(out.pleat_ratio[i], 0.0, 1.0);
      cv::line(image, project(state.p_WColon[i - 1]), project(state.p_WColon[i]),
               cv::Scalar(255, 200 * pleat, 200 * pleat), 2);
    }
    for (size_t k = 1; k < state.p_WSample.size(); ++k) {
      if (!state.contact[k].inside) continue;
      cv::line(image, project(state.p_WSample[k - 1]), project(state.p_WSample[k]),
               cv::Scalar(0, 0, 255), 2);
    }
    cv::circle(image, project(state.X_WTip.translation()), 5, cv::Scalar(0, 0, 0), 2);
  }
  cv::putText(image,
              "t " + std::to_string(state.time_s).substr(0, 6) + " s  inserted " +
                  std::to_string(state.inserted_m).substr(0, 5) + " m  tip arc " +
                  std::to_string(state.tip_arc_m).substr(0, 5) + " m",
              cv::Point(20, 30), cv::FONT_HERSHEY_SIMPLEX, 0.7, cv::Scalar(0, 0, 0), 1);
  cv::imwrite(path, image);
}

}  // namespace

int main(int argc, char** argv) {
  constexpr char kUsage[] =
      "usage: insertion_probe CASE_FILE [speed_mm_s] [seconds] [segments] [--key=value ...]\n";
  std::optional<ves::bench::ProbeFlags> parsed;
  try {
    parsed.emplace(argc, argv);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "insertion_probe: %s\n%s", error.what(), kUsage);
    return 2;
  }
  const ves::bench::ProbeFlags& flags = *parsed;
  const std::vector<std::string>& args = flags.positional();
  if (args.empty() || args.size() > 4) {
    std::fprintf(stderr, "%s", kUsage);
    return 2;
  }
  const double speed_m_per_s = (args.size() > 1 ? std::atof(args[1].c_str()) : 20.0) / 1000.0;
  const double seconds = args.size() > 2 ? std::atof(args[2].c_str()) : 120.0;
  ves::training::CaseModelOptions options;
  if (args.size() > 3) options.segments = std::atoi(args[3].c_str());
  const auto colon_case = ves::patient_db::LoadCaseFile(args[0]);
  options.stiff_colon = flags.Has("stiff_colon");
  auto params = ves::training::MakeModelParams(colon_case, ves::training::DefaultEndoscopeSpec(),
                                               options);
  ves::bench::ApplyModelOverrides(flags.Getter(), &params);
  auto state = ves::model::MakeInitialState(params);
  auto scratch =
      ves::model::MakeScratch(params, ves::bench::ExperimentsWithOverrides(flags.Getter()));
  auto out = ves::model::MakeStepOutput(params);

  std::unique_ptr<ves::training::ScriptedOperator> scripted;
  if (const char* kind = flags.Text("operator")) {
    scripted = ves::training::MakeScriptedOperator(
        kind, params.dt_s, ves::bench::ExpertSettingsWithOverrides(flags.Getter()));
  }
  const double withdraw_at_m = flags.Get("withdraw_at", 1e9);
  const double withdraw_m = flags.Get("withdraw_m", 0.25);
  const double roll_rate = flags.Get("roll", 0.0);
  const double roll_max_rad = flags.Get("roll_max", 0.0);
  const double dump_every_s = flags.Get("dump_every", 0.0);
  double next_dump_s = 0.0, next_forces_s = 0.0;
  StepInput in;
  in.thrust_mode = ves::model::ThrustMode::kPosition;
  const double gain_per_s = ves::training::ExpertOperator::kSteerGain_per_s;  // the simple rule
  // --knob-max: the hand turns the knobs at most this far (no windup).
  const double knob_max = flags.Get("knob_max", 10.0);
  const double tip_resist_N = flags.Get("tip_resist", 0.0);
  double command_m = 0.0;
  int phase = 0;  // position rule: 0 inserting, 1 withdrawing, 2 holding
  // --reinsert: after the withdrawal, insert again (reductions repeat
  // every --withdraw-every metres of insertion when that is set).
  const bool reinsert = flags.Has("reinsert");
  double withdraw_at_m_next = withdraw_at_m;
  double withdraw_at_reached_m = 0.0;
  const double withdraw_every_m = flags.Get("withdraw_every", 0.0);
  // --reduce: reduce by the loop index (limits --fixed-limit and
  // --mobile-limit, m) until the tip comes back 1.5 cm.
  const bool reduce_rule = flags.Has("reduce");
  const double fixed_limit_m = flags.Get("fixed_limit", 0.06);
  const double mobile_limit_m = flags.Get("mobile_limit", 0.25);
  ves::training::LoopIndex loop_index;
  double reduce_tip_max_m = 0.0;
  Eigen::Vector3d pinned_tip_W = Eigen::Vector3d::Zero();
  const bool pin_tip = flags.Has("pin_tip");
  constexpr double kPinStiffness_N_per_m = 2000.0;
  bool stiffened = false;
  bool was_pulling = false;
  double last_reduce_tip_m = -1.0;
  double hold_until_s = 0.0;
  double stall_tip_m = 0.0, stall_since_s = 0.0;  // --hold-s: hold still this long after a reduction
  std::printf("t_s inserted_m tip_arc_m base_N roll_Nm stretch_m@arc wall_N fixed_mm "
              "min_pleat knob_up knob_right\n");
  double next_print_s = 0.0;
  double max_tip_arc_m = 0.0, max_stretch_m = 0.0, max_wall_N = 0.0, max_base_N = 0.0;
  double max_fixed_m = 0.0, max_roll_Nm = 0.0;
  double max_mobile_m = 0.0, max_mobile_arc_m = 0.0, max_beyond_meso_m = -1.0;
  long over_10N_steps = 0, steps = 0;
  double stretch_over_s[4] = {0, 0, 0, 0};  // time with the stretch over 1, 2, 3, 4 cm
  int spikes_printed = 0;
  const bool spike_detail = flags.Has("spike_detail");
  bool wall_was_over = false;
  double base_jump_sum_N = 0.0, last_base_N = 0.0;
  ves::bench::TenStepMean base_10ms_N;
  long over_10N_mean_steps = 0;
  ves::model::ModelState previous = state, before_previous = state;
  // --slack: the scope inside less the colon's current path behind the
  // tip (what the lumen holds beyond the colon's length), its extremes.
  const bool track_slack = flags.Has("slack");
  double slack_min_m = 1e9, slack_max_m = -1e9, slack_min_s = 0.0, slack_max_s = 0.0;
  // The rest of the flags, read once (header comment and
  // docs/model-shortening-notes.md, "How to reproduce").
  const char* const push_force = flags.Text("push_force");
  const bool print_phases = flags.Has("phases");
  const double reduce_again_m = flags.Get("reduce_again_m", 0.10);
  const double stall_s = flags.Get("stall_s", 1e9);
  const double hold_s = flags.Get("hold_s", 0.0);
  const bool unhook = flags.Has("unhook");
  const double stiffen = flags.Get("stiffen", 1.0);
  const double hook_rad = flags.Get("hook", 0.0);
  const double wall_over_N = flags.Get("wall", 0.0);
  const double forces_every_s = flags.Get("forces", 0.0);
  const bool print_lost = flags.Has("lost");
  const bool print_side = flags.Has("side");
  const bool print_regions = flags.Has("regions");
  const long regions_every_s = std::max(1L, static_cast<long>(flags.Get("regions", 10)));
  const double pleat_profile_m = flags.Get("pleat_profile", 0.0);
  const bool print_tip_aim = flags.Has("tip_aim");
  const char* const region_move = flags.Text("region_move");
  const bool print_track = flags.Has("track");
  const bool print_track_detail = flags.Has("track_detail");
  const bool print_input = flags.Has("input");
  const bool print_joints = flags.Has("joints");
  // Every flag is read by now: one nothing read is misspelt or has no
  // effect in this run (an expert setting without --operator).
  if (const std::vector<std::string> unread = flags.Unread(); !unread.empty()) {
    for (const std::string& key : unread) {
      std::fprintf(stderr, "insertion_probe: --%s is not a flag of this run\n", key.c_str());
    }
    return 2;
  }
  while (state.time_s < seconds) {
    const auto p = ves::training::Perceive(params, state, out);
    if (push_force != nullptr) {
      // Fig. 10: a constant push, knobs neutral.
      in = StepInput{};
      in.thrust_mode = ves::model::ThrustMode::kForce;
      in.push_force_N = std::atof(push_force);
    } else if (scripted) {
      const auto sample = scripted->Act(p);
      in = ves::training::ToStepInput(sample);
      // Phase changes of the scripted operator (its hand reverses).
      const bool pulling = sample.push_force_N < 0.0;
      if (pulling != was_pulling && print_phases) {
        std::printf("  %s at t=%.2f: tip %.3f m, inserted %.3f m\n", pulling ? "pull" : "push",
                    state.time_s, state.tip_arc_m, state.inserted_m);
      }
      was_pulling = pulling;
    } else {
      // --pin-tip: while withdrawing (either rule) the tip is held where
      // the withdrawal began, a perfect hook, to see how far a reduction goes.
      in.tip_force_W_N = pin_tip && phase == 1
                             ? Eigen::Vector3d(kPinStiffness_N_per_m *
                                               (pinned_tip_W - state.X_WTip.translation()))
                             : Eigen::Vector3d::Zero();
      if (phase == 0) {  // steer; withdrawing, the knobs hold the tip hooked
        ves::training::SteerTowardTheLumen(p, gain_per_s, params.dt_s, &in.knob_up_rad,
                                           &in.knob_right_rad);
        ves::training::LimitKnobBend(knob_max, &in.knob_up_rad, &in.knob_right_rad);
      }
      if (reduce_rule) {
        // Loop reduction by the loop index (as the expert does it, by position).
        const double loop_m = loop_index.Update(state.inserted_m, state.tip_arc_m);
        const double limit_m = TipIntoFixedColon(params, state.tip_arc_m) >= 0.08 ? fixed_limit_m : mobile_limit_m;
        // After a reduction, the next one waits until the tip has gone
        // --reduce-again-m (default 0.10 m) deeper: a loop re-formed by
        // pushing on is taut before the tip moves.
        const bool deeper = state.tip_arc_m > last_reduce_tip_m + reduce_again_m;
        const bool full = state.inserted_m > params.scope.working_length_m - 0.08;
        // A stall with the scope all in: the tip has not advanced for a while.
        if (state.tip_arc_m > stall_tip_m + 0.005) {
          stall_tip_m = state.tip_arc_m;
          stall_since_s = state.time_s;
        }
        const bool stalled = state.time_s - stall_since_s > stall_s;
        if (phase == 0 && ((loop_m > limit_m && deeper) || (full && (deeper || stalled)))) {
          stall_since_s = state.time_s;
          last_reduce_tip_m = state.tip_arc_m;
          pinned_tip_W = state.X_WTip.translation();
          std::printf("  reduce at t=%.2f: loop %.3f m, tip %.3f m (%s), inserted %.3f m\n",
                      state.time_s, loop_m, state.tip_arc_m,
                      TipIntoFixedColon(params, state.tip_arc_m) >= 0.08 ? "hooked" : "not hooked", state.inserted_m);
          phase = 1;
          reduce_tip_max_m = state.tip_arc_m;
          withdraw_at_reached_m = command_m;
        }
        if (phase == 1) {
          reduce_tip_max_m = std::max(reduce_tip_max_m, state.tip_arc_m);
          if (state.tip_arc_m < reduce_tip_max_m - 0.015 ||
              withdraw_at_reached_m - command_m > 0.3) {
            std::printf("  advance at t=%.2f: tip %.3f m, inserted %.3f m\n", state.time_s,
                        state.tip_arc_m, state.inserted_m);
            phase = 0;
            hold_until_s = state.time_s + hold_s;
            if (unhook) in.knob_up_rad = in.knob_right_rad = 0.0;
            // Experiment: --stiffen=R stiffens the insertion tube R times
            // after the first reduction (a variable-stiffness colonoscope).
            if (!stiffened && stiffen != 1.0) {
              stiffened = true;
              for (int k = 1; k < state.first_bending_link; ++k) {
                if (params.scope.flexural_rigidity_N_m2 / state.joint_stiffness_N_m_per_rad[k] > 0.0 &&
                    std::abs(state.joint_stiffness_N_m_per_rad[k] * 0.5 *
                                 (state.link_length_m[k - 1] + state.link_length_m[k]) -
                             params.scope.flexural_rigidity_N_m2) < 1e-9) {
                  state.joint_stiffness_N_m_per_rad[k] *= stiffen;
                }
              }
              std::printf("  stiffened the insertion tube\n");
            }
          }
        }
      } else if (phase == 0 && command_m >= withdraw_at_m_next) {
        phase = 1;
        withdraw_at_reached_m = command_m;
        pinned_tip_W = state.X_WTip.translation();
      }
      if (!reduce_rule && phase == 1 && command_m <= withdraw_at_reached_m - withdraw_m) {
        phase = reinsert ? 0 : 2;
        withdraw_at_m_next =
            withdraw_every_m > 0.0 ? withdraw_at_reached_m + withdraw_every_m : 1e9;
      }
      if (phase == 0 && state.time_s >= hold_until_s) command_m += speed_m_per_s * params.dt_s;
      if (phase == 1) {
        command_m -= speed_m_per_s * params.dt_s;
        in.roll_rad += roll_rate * params.dt_s;
        if (roll_max_rad > 0.0) in.roll_rad = std::clamp(in.roll_rad, -roll_max_rad, roll_max_rad);
        // --hook=A: while withdrawing, angulate the tip to at least A rad
        // in the direction it is bent (hook the flexure).
        const double bend = std::hypot(in.knob_up_rad, in.knob_right_rad);
        if (hook_rad > 0.0 && bend > 1e-3 && bend < hook_rad) {
          const double grow = std::min(hook_rad / bend, 1.0 + 2.0 * params.dt_s);
          in.knob_up_rad *= grow;
          in.knob_right_rad *= grow;
        }
      }
      command_m = std::clamp(command_m, 0.0, params.scope.working_length_m - 0.05);
      in.insertion_m = command_m;
    }
    if (spike_detail) before_previous = previous, previous = state;
    if (tip_resist_N > 0.0) {
      // An axial force on the tip against its advance (StepInput::tip_force_W_N;
      // the colon does not feel it), full once it moves in at 5 mm/s.
      const Eigen::Vector3d axis = state.X_WTip.linear().col(2);
      const double share = std::clamp(state.insertion_rate_m_per_s / 0.005, -1.0, 1.0);
      in.tip_force_W_N = -(tip_resist_N * share) * axis;
    }
    ves::model::Step(params, in, &state, &scratch, &out);
    if (track_slack && state.inserted_m > 0.05) {
      const double slack_m = state.inserted_m - ColonPathBehindTheTip(params, state);
      if (slack_m < slack_min_m) slack_min_m = slack_m, slack_min_s = state.time_s;
      if (slack_m > slack_max_m) slack_max_m = slack_m, slack_max_s = state.time_s;
    }
    if (!out.finite) {
      std::printf("diverged at t=%.3f\n", state.time_s);
      return 1;
    }
    max_tip_arc_m = std::max(max_tip_arc_m, state.tip_arc_m);
    max_stretch_m = std::max(max_stretch_m, out.peak_stretch_m);
    max_wall_N = std::max(max_wall_N, out.peak_wall_force_N);
    // --wall=F: where and when the wall force first rises over F N.
    if (wall_over_N > 0.0) {
      const bool over = out.peak_wall_force_N > wall_over_N;
      if (over && !wall_was_over) {
        const int at = ves::bench::LargestWallForcePoint(out);
        std::printf("  wall t=%.3f %.1f N at arc %.3f (region %d), tip %.3f, inserted %.3f, "
                    "base %.1f N, push in %.1f N, knobs %.2f/%.2f\n",
                    state.time_s, out.peak_wall_force_N, params.colon.points[at].arc_m,
                    static_cast<int>(params.colon.points[at].region), state.tip_arc_m,
                    state.inserted_m, out.base_force_N, in.push_force_N, in.knob_up_rad,
                    in.knob_right_rad);
      }
      wall_was_over = over;
    }
    max_base_N = std::max(max_base_N, std::abs(out.base_force_N));
    max_roll_Nm = std::max(max_roll_Nm, std::abs(out.roll_torque_Nm));
    max_fixed_m = std::max(max_fixed_m, out.peak_fixed_displacement_m);
    // How far the mobile colon was carried from its rest place, and how far
    // beyond its mesocolon height (a loop's size as the abdomen feels it).
    for (size_t i = 0; i < params.colon.points.size(); ++i) {
      const ves::model::ColonPoint& point = params.colon.points[i];
      if (!point.tissue.mobile) continue;
      const double moved_m = state.colon_displacement_m[i].norm();
      if (moved_m > max_mobile_m) {
        max_mobile_m = moved_m;
        max_mobile_arc_m = point.arc_m;
      }
      max_beyond_meso_m = std::max(max_beyond_meso_m, moved_m - point.tissue.mesentery_length_m);
    }
    if (std::abs(out.base_force_N) > 10.0) ++over_10N_steps;
    // Chatter of the base force: step-to-step change, and the 10 ms mean.
    base_jump_sum_N += std::abs(out.base_force_N - last_base_N);
    last_base_N = out.base_force_N;
    if (std::abs(base_10ms_N.Add(out.base_force_N)) > 10.0) ++over_10N_mean_steps;
    for (int t = 0; t < 4; ++t) {
      if (out.peak_stretch_m > 0.01 * (t + 1)) stretch_over_s[t] += params.dt_s;
    }
    ++steps;
    if ((std::abs(out.base_force_N) > 30.0 || std::abs(out.roll_torque_Nm) > 1.0) &&
        spikes_printed < 5) {
      ++spikes_printed;
      std::printf("  spike t=%.3f base %.1f N roll %.2f N m push %.2f roll_in %.3f\n",
                  state.time_s, out.base_force_N, out.roll_torque_Nm, in.push_force_N,
                  in.roll_rad);
      if (spike_detail) {
        // What moved in the step before: the largest sample and colon point moves.
        double sample_move = 0.0, colon_move = 0.0, turn = 0.0;
        int sample_at = 0, colon_at = 0, turn_at = 0;
        for (size_t k = 0; k < previous.p_WSample.size(); ++k) {
          const double d = (previous.p_WSample[k] - before_previous.p_WSample[k]).norm();
          if (d > sample_move) sample_move = d, sample_at = static_cast<int>(k);
        }
        for (size_t i = 0; i < previous.p_WColon.size(); ++i) {
          const double d = (previous.p_WColon[i] - before_previous.p_WColon[i]).norm();
          if (d > colon_move) colon_move = d, colon_at = static_cast<int>(i);
        }
        for (size_t k = 0; k < previous.bend_rad.size(); ++k) {
          const double d = (previous.bend_rad[k] - before_previous.bend_rad[k]).norm();
          if (d > turn) turn = d, turn_at = static_cast<int>(k);
        }
        std::printf("    step before: sample %d moved %.5f m, colon point %d moved %.5f m, joint %d "
                    "turned %.4f rad, roll %.4f -> %.4f, inserted %.5f -> %.5f\n",
                    sample_at, sample_move, colon_at, colon_move, turn_at, turn,
                    before_previous.roll_rad, previous.roll_rad, before_previous.inserted_m,
                    previous.inserted_m);
        const Eigen::Vector3d e = params.colon.points.front().rest_tangent;
        for (int j = 0; j < out.contact_count; ++j) {
          const auto& c = out.contacts[j];
          const double moment = e.dot(c.p_W.cross(c.force_on_scope_W_N));
          if (c.force_on_scope_W_N.norm() < 3.0 && std::abs(moment) < 0.5) continue;
          std::printf("    moment %.2f ", moment);
          std::printf("    sample %d from_tip %.3f arc %.3f N %.1f pen %.4f |F| %.1f alpha %.2f\n",
                      c.sample, c.scope_arc_from_tip_m, c.colon_arc_m, c.normal_force_N,
                      c.penetration_m, c.force_on_scope_W_N.norm(), c.alpha);
          // The lumen geometry it was measured in: the bracketing planes.
          const int k = c.segment;
          const Eigen::Vector3d pa = state.p_WSample[c.sample] - state.p_WColon[k];
          const Eigen::Vector3d pb = state.p_WSample[c.sample] - state.p_WColon[k + 1];
          const Eigen::Vector3d& ta = state.colon_tangent[k];
          const Eigen::Vector3d& tb = state.colon_tangent[k + 1];
          const int last_s = static_cast<int>(state.p_WSample.size()) - 1;
          const Eigen::Vector3d scope_t = (state.p_WSample[std::min(c.sample + 1, last_s)] -
                                           state.p_WSample[std::max(c.sample - 1, 0)]).normalized();
          std::printf("      seg %d da %.4f db %.4f |wa| %.4f |wb| %.4f ta.tb %.2f ta.scope %.2f "
                      "seg len %.4f (rest %.4f)\n",
                      k, pa.dot(ta), pb.dot(tb), (pa - pa.dot(ta) * ta).norm(),
                      (pb - pb.dot(tb) * tb).norm(), ta.dot(tb), ta.dot(scope_t),
                      (state.p_WColon[k + 1] - state.p_WColon[k]).norm(),
                      params.colon.points[k + 1].arc_m - params.colon.points[k].arc_m);
        }
      }
    }
    // --forces=S: every S s, what holds the scope along its own axis:
    // friction and the axial part of the wall normals, and the largest ones.
    if (forces_every_s > 0.0 && state.time_s + 1e-9 >= next_forces_s) {
      next_forces_s += forces_every_s;
      double friction_N = 0.0, wedge_N = 0.0, normal_sum_N = 0.0;
      struct Part { double along_N; double arc_m; int region; double f_n; };
      std::vector<Part> parts;
      const int last = static_cast<int>(state.p_WSample.size()) - 1;
      for (int c = 0; c < out.contact_count; ++c) {
        const auto& k = out.contacts[c];
        const int i = k.sample;
        const Eigen::Vector3d t =
            (state.p_WSample[std::min(i + 1, last)] - state.p_WSample[std::max(i - 1, 0)])
                .normalized();  // toward the tip
        const Eigen::Vector3d normal_part = k.force_on_scope_W_N.dot(k.normal_W) * k.normal_W;
        const double fr = (k.force_on_scope_W_N - normal_part).dot(t);
        const double we = normal_part.dot(t);
        friction_N += fr;
        wedge_N += we;
        normal_sum_N += k.normal_force_N;
        parts.push_back({fr + we, k.colon_arc_m,
                         static_cast<int>(params.colon.points[k.segment].region), k.normal_force_N});
      }
      double ring_N = 0.0;
      for (int j = 0; j < scratch.ring_contact_count; ++j) {
        const auto& rc = scratch.ring_contacts[j];
        const double along = ves::bench::RingPushAlongScope_N(state, scratch, j);
        ring_N += along;
        parts.push_back({along, params.colon.points[rc.point].arc_m,
                         100 + static_cast<int>(params.colon.points[rc.point].region), rc.force_N});
      }
      std::printf("  rings %d along %.2f N;", scratch.ring_contact_count, ring_N);
      {  // the same forces along the entry direction (what the base holds)
        const int f0 = std::min(state.first_inside_sample, last - 1);
        const Eigen::Vector3d e = (state.p_WSample[f0 + 1] - state.p_WSample[f0]).normalized();
        double contacts_e = 0.0, rings_e = 0.0, gravity_e = 0.0;
        std::vector<std::pair<double, int>> by_sample;
        for (int c = 0; c < out.contact_count; ++c) {
          contacts_e += out.contacts[c].force_on_scope_W_N.dot(e);
          by_sample.push_back({out.contacts[c].force_on_scope_W_N.dot(e), out.contacts[c].sample});
        }
        for (int j = 0; j < scratch.ring_contact_count; ++j) {
          rings_e += (-scratch.ring_contacts[j].force_N * scratch.ring_contacts[j].normal_W).dot(e);
        }
        for (int i = state.first_inside_sample; i <= last; ++i) {
          gravity_e += state.samples[i].mass_kg * params.gravity_W_m_per_s2.dot(e);
        }
        std::sort(by_sample.begin(), by_sample.end(),
                  [](const auto& a, const auto& b) { return std::abs(a.first) > std::abs(b.first); });
        std::printf(" entry: contacts %.2f rings %.2f gravity %.2f (last sample %d; top", contacts_e,
                    rings_e, gravity_e, last);
        for (size_t j = 0; j < std::min<size_t>(4, by_sample.size()); ++j) {
          std::printf(" s%d %.2f", by_sample[j].second, by_sample[j].first);
        }
        std::printf(");");
      }
      std::sort(parts.begin(), parts.end(),
                [](const Part& a, const Part& b) { return std::abs(a.along_N) > std::abs(b.along_N); });
      std::printf("  forces t=%.1f hand %.1f base %.1f: %d contacts, sum f_n %.1f N, along the "
                  "scope (+ toward tip): friction %.2f N, wall normals %.2f N; largest:",
                  state.time_s, in.push_force_N, out.base_force_N, out.contact_count, normal_sum_N,
                  friction_N, wedge_N);
      for (size_t j = 0; j < std::min<size_t>(5, parts.size()); ++j) {
        std::printf(" [%.2f N at %.3f r%d f_n %.1f]", parts[j].along_N, parts[j].arc_m,
                    parts[j].region, parts[j].f_n);
      }
      std::printf("\n");
    }
    if (dump_every_s > 0.0 && state.time_s >= next_dump_s) {
      DumpShape(params, state, out,
                "/tmp/probe_" + std::to_string(static_cast<int>(std::lround(next_dump_s))) + ".png");
      next_dump_s += dump_every_s;
    }
    if (state.time_s >= next_print_s) {
      next_print_s += 1.0;
      const double min_pleat = *std::min_element(out.pleat_ratio.begin(), out.pleat_ratio.end());
      // Samples farther from their tracked segment than its lumen allows (lost).
      int lost = 0;
      for (size_t k = 0; k < state.contact.size(); ++k) {
        const auto& c = state.contact[k];
        if (!c.inside || c.penetration_m < 0.02) continue;
        ++lost;
        if (print_lost && lost <= 3) {
          std::printf("    lost sample %zu seg %d pen %.3f\n", k, c.segment, c.penetration_m);
        }
      }
      if (lost > 0) std::printf("    %d samples beyond 2 cm of their lumen\n", lost);
      if (print_side) {  // the mobile point farthest through its root
        double worst = 1e9;
        int at = -1;
        for (size_t i = 0; i < params.colon.points.size(); ++i) {
          const auto& pt = params.colon.points[i];
          if (pt.tether_side.squaredNorm() < 0.5) continue;
          const double h = (state.p_WColon[i] - pt.tether_anchor_m).dot(pt.tether_side);
          if (h < worst) worst = h, at = static_cast<int>(i);
        }
        if (at >= 0) {
          const auto& pt = params.colon.points[at];
          const Eigen::Vector3d& x = state.p_WColon[at];
          std::printf("    side: point %d arc %.3f h %.3f at (%.3f %.3f %.3f) anchor (%.3f %.3f %.3f)\n", at,
                      pt.arc_m, worst, x.x(), x.y(), x.z(), pt.tether_anchor_m.x(),
                      pt.tether_anchor_m.y(), pt.tether_anchor_m.z());
        }
      }
      if (print_regions && static_cast<long>(state.time_s) % regions_every_s == 0) {
        // Where the scope lies: per region, the scope length tracked to it,
        // the colon's current path length, its rest length and its chord.
        double scope_m[9] = {0}, path_m[9] = {0}, rest_m[9] = {0};
        int first[9], last[9];
        std::fill(first, first + 9, -1);
        std::fill(last, last + 9, -1);
        const auto& pts = params.colon.points;
        for (size_t i = 1; i < pts.size(); ++i) {
          const int r = static_cast<int>(pts[i].region);
          path_m[r] += (state.p_WColon[i] - state.p_WColon[i - 1]).norm();
          rest_m[r] += (pts[i].rest_position_m - pts[i - 1].rest_position_m).norm();
          if (first[r] < 0) first[r] = static_cast<int>(i);
          last[r] = static_cast<int>(i);
        }
        for (int k = state.first_inside_sample + 1; k < static_cast<int>(state.contact.size()); ++k) {
          if (!state.contact[k].inside) continue;
          const int r = static_cast<int>(pts[state.contact[k].segment].region);
          scope_m[r] += (state.p_WSample[k] - state.p_WSample[k - 1]).norm();
        }
        std::printf("    regions (scope/path/rest/chord m):");
        const char* names[9] = {"?", "rect", "sig", "desc", "splen", "trans", "hep", "asc", "cec"};
        for (int r = 1; r < 9; ++r) {
          if (first[r] < 0) continue;
          std::printf(" %s %.2f/%.2f/%.2f/%.2f", names[r], scope_m[r], path_m[r], rest_m[r],
                      (state.p_WColon[last[r]] - state.p_WColon[first[r] - 1]).norm());
        }
        std::printf("\n");
      }
      if (pleat_profile_m > 0.0) {
        // Where the colon gathers: the mean pleat ratio of each 2 cm of rest
        // arc over the first pleat_profile_m (1 = natural length, < 1 pleated).
        constexpr double kBin_m = 0.02;
        std::printf("    pleat per %.0f cm:", kBin_m * 100.0);
        const auto& pts = params.colon.points;
        double sum = 0.0, bin_end_m = kBin_m;
        int count = 0;
        for (size_t i = 0; i < pts.size() && pts[i].arc_m < pleat_profile_m; ++i) {
          if (pts[i].arc_m > bin_end_m && count > 0) {
            std::printf(" %.2f", sum / count);
            sum = 0.0;
            count = 0;
            bin_end_m += kBin_m;
          }
          sum += out.pleat_ratio[i];
          ++count;
        }
        if (count > 0) std::printf(" %.2f", sum / count);
        std::printf("\n");
      }
      if (print_tip_aim) {
        // Whether the tip moves in space and where it points: its position and
        // axis, how far it is from its tracked colon point, and the angle
        // between its axis and the lumen 4 cm ahead (what the steering sees).
        const Eigen::Vector3d tip = state.X_WTip.translation();
        const Eigen::Vector3d axis = state.X_WTip.rotation().col(2);
        const Eigen::Vector3d tracked =
            ves::training::ColonPointAhead(params, state, state.tip_arc_m, 0.0);
        const Eigen::Vector3d ahead = ves::training::ColonPointAhead(
            params, state, state.tip_arc_m, ves::training::kLumenLookahead_m);
        const double aim_deg =
            std::acos(std::clamp(axis.dot((ahead - tip).normalized()), -1.0, 1.0)) * 180.0 /
            ves::model::kPi;
        std::printf("    tip at (%.3f %.3f %.3f) axis (%.2f %.2f %.2f), %.3f m from its tracked "
                    "point, %.0f deg off the lumen ahead\n",
                    tip.x(), tip.y(), tip.z(), axis.x(), axis.y(), axis.z(), (tip - tracked).norm(),
                    aim_deg);
      }
      if (region_move != nullptr) {
        // How far one region's points (a Region number: 2 sigmoid) have moved
        // from rest, per axis of W (+x right, +y anterior, +z cranial).
        const int region = std::atoi(region_move);
        Eigen::Vector3d low = Eigen::Vector3d::Constant(1e9), high = -low;
        for (size_t i = 0; i < params.colon.points.size(); ++i) {
          if (static_cast<int>(params.colon.points[i].region) != region) continue;
          const Eigen::Vector3d d = state.p_WColon[i] - params.colon.points[i].rest_position_m;
          low = low.cwiseMin(d);
          high = high.cwiseMax(d);
        }
        std::printf("    region %d moved: x %.3f..%.3f y %.3f..%.3f z %.3f..%.3f m\n", region,
                    low.x(), high.x(), low.y(), high.y(), low.z(), high.z());
      }
      if (print_track) {  // tracked colon arc of the inside samples
        std::printf("    track");
        for (int k = state.first_inside_sample; k < static_cast<int>(state.contact.size()); k += 3) {
          const auto& c = state.contact[k];
          std::printf(" %.3f", params.colon.points[c.segment].arc_m);
        }
        std::printf("\n");
        if (print_track_detail) {
          for (int k = state.first_inside_sample; k < static_cast<int>(state.contact.size()); ++k) {
            const auto& c = state.contact[k];
            const Eigen::Vector3d& q = state.p_WSample[k];
            int nearest = 0;
            for (size_t m = 0; m < state.p_WColon.size(); ++m) {
              if ((state.p_WColon[m] - q).norm() < (state.p_WColon[nearest] - q).norm()) {
                nearest = static_cast<int>(m);
              }
            }
            std::printf("      sample %d tracked %.3f (%.3f m away, pen %.4f) nearest %.3f (%.3f m)\n",
                        k, params.colon.points[c.segment].arc_m,
                        (state.p_WColon[c.segment] - q).norm(), c.penetration_m,
                        params.colon.points[nearest].arc_m, (state.p_WColon[nearest] - q).norm());
          }
        }
      }
      std::printf("%5.1f %.3f %.3f %6.2f %5.2f %.3f@%.2f %5.2f %4.1f %.2f %5.2f %5.2f\n",
                  state.time_s, state.inserted_m, state.tip_arc_m, out.base_force_N,
                  out.roll_torque_Nm, out.peak_stretch_m, out.peak_stretch_arc_m,
                  out.peak_wall_force_N, 1e3 * out.peak_fixed_displacement_m, min_pleat,
                  in.knob_up_rad, in.knob_right_rad);
      if (print_input) {
        std::printf("    push %.2f roll %.2f\n", in.push_force_N, in.roll_rad);
      }
    }
  }
  if (print_joints) {  // the inserted joints: length, bend, stiffness, sample
    const int root = state.first_inside_link > 0 ? state.first_inside_link - 1 : 0;
    for (int k = root; k < std::min<int>(root + 40, state.link_length_m.size()); ++k) {
      int first_sample = -1;
      for (size_t i = 0; i < state.samples.size(); ++i) {
        if (state.samples[i].link == k) { first_sample = static_cast<int>(i); break; }
      }
      std::printf("  link %d len %.4f bend %.3f rad K %.4f first sample %d\n", k,
                  state.link_length_m[k], state.bend_rad[k].norm(),
                  state.joint_stiffness_N_m_per_rad[k], first_sample);
    }
  }
  if (track_slack) {
    std::printf("slack (inserted less the colon path behind the tip): min %.3f m at %.2f s, "
                "max %.3f m at %.2f s\n", slack_min_m, slack_min_s, slack_max_m, slack_max_s);
  }
  std::printf("summary: max tip arc %.3f m, inserted %.3f m, stretch peak %.3f m, wall peak %.1f "
              "N, base peak %.1f N (over 10 N %.1f %% of steps), roll peak %.2f N m, fixed moved "
              "%.1f mm\n",
              max_tip_arc_m, state.inserted_m, max_stretch_m, max_wall_N, max_base_N,
              100.0 * over_10N_steps / std::max(1L, steps), max_roll_Nm, 1e3 * max_fixed_m);
  std::printf("base force: mean step-to-step change %.2f N, 10 ms mean over 10 N %.1f %% of steps\n",
              base_jump_sum_N / std::max(1L, steps), 100.0 * over_10N_mean_steps / std::max(1L, steps));
  std::printf("mobile colon moved: peak %.1f cm at arc %.3f m, %.1f cm beyond its mesocolon height\n",
              1e2 * max_mobile_m, max_mobile_arc_m, 1e2 * max_beyond_meso_m);
  std::printf("stretch over 1/2/3/4 cm: %.1f / %.1f / %.1f / %.1f s\n", stretch_over_s[0],
              stretch_over_s[1], stretch_over_s[2], stretch_over_s[3]);
  return 0;
}
