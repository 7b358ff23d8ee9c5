// insertion_probe: a position-driven insertion on a case with the knobs
// steered toward the lumen (the simple rule of issue #3), printed once per
// simulated second, so a model change can be judged by where the tip stalls.
//   insertion_probe CASE_FILE [speed_mm_per_s=20] [seconds=120] [segments=150]
// PROBE_* environment variables add loop reduction, parameter scaling, a
// scripted operator, shape drawings and contact dumps (docs/model.md).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "patient_db/case_format.h"
#include "station/model/internal.h"
#include "station/model/model.h"
#include "station/training/case_model.h"
#include "station/training/observer.h"
#include "station/training/scripted_operator.h"
#include "station/training/session_runner.h"

namespace {

using ves::model::StepInput;

// AP (x right = patient's left, z up) and lateral (y, z) projections: rest
// centerline grey, deformed colon blue, scope red.
void DumpShape(const ves::model::ModelParams& params, const ves::model::ModelState& state,
               const std::string& path) {
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
               cv::Scalar(200, 200, 200), 1);
      cv::line(image, project(state.p_WColon[i - 1]), project(state.p_WColon[i]),
               cv::Scalar(255, 0, 0), 1);
    }
    for (size_t k = 1; k < state.p_WSample.size(); ++k) {
      if (!state.contact[k].inside) continue;
      cv::line(image, project(state.p_WSample[k - 1]), project(state.p_WSample[k]),
               cv::Scalar(0, 0, 255), 2);
    }
    cv::circle(image, project(state.X_WTip.translation()), 5, cv::Scalar(0, 0, 0), 2);
  }
  cv::imwrite(path, image);
}

// One step whose base reaction passed 20 N: the contacts that make it up.
void PrintSpike(const ves::model::ModelState& state, const StepInput& in,
                const ves::model::StepOutput& out) {
  std::printf("spike t=%.3f base %.1f N, knobs %.2f %.2f, push %.2f N\n", state.time_s,
              out.base_force_N, in.knob_up_rad, in.knob_right_rad, in.push_force_N);
  const Eigen::Vector3d e = state.X_WLink[0].linear().col(2);
  double normal_sum_N = 0.0;
  double friction_sum_N = 0.0;
  for (int j = 0; j < out.contact_count; ++j) {
    const auto& c = out.contacts[j];
    const double along_N = -c.force_on_scope_W_N.dot(e);
    const double normal_along_N = c.normal_force_N * c.normal_W.dot(e);
    normal_sum_N += normal_along_N;
    friction_sum_N += along_N - normal_along_N;
    if (std::abs(along_N) <= 5.0) continue;
    std::printf("   from_tip %.3f arc %.3f N %.1f pen %.4f along_e %.1f (normal %.1f) alpha %.2f\n",
                c.scope_arc_from_tip_m, c.colon_arc_m, c.normal_force_N, c.penetration_m, along_N,
                normal_along_N, c.alpha);
  }
  std::printf("   along e: normal %.1f N, friction %.1f N, %d contacts\n", normal_sum_N,
              friction_sum_N, out.contact_count);
}

// What moved in the step before a spike: the largest sample and colon point
// displacements, and where they were.
void PrintMotion(const ves::model::ModelParams& params, const ves::model::ModelState& before,
                 const ves::model::ModelState& after, double previous_base_N) {
  double sample_move_m = 0.0, colon_move_m = 0.0;
  size_t sample_at = 0, colon_at = 0;
  for (size_t k = 0; k < after.p_WSample.size(); ++k) {
    const double d = (after.p_WSample[k] - before.p_WSample[k]).norm();
    if (d > sample_move_m) sample_move_m = d, sample_at = k;
  }
  for (size_t i = 0; i < after.p_WColon.size(); ++i) {
    const double d = (after.p_WColon[i] - before.p_WColon[i]).norm();
    if (d > colon_move_m) colon_move_m = d, colon_at = i;
  }
  double turn_rad = 0.0;
  size_t turn_at = 0;
  int clamped = 0;
  for (size_t k = 0; k < after.bend_rad.size(); ++k) {
    const double d = (after.bend_rad[k] - before.bend_rad[k]).norm();
    if (d > 0.0199) ++clamped;
    if (d > turn_rad) turn_rad = d, turn_at = k;
  }
  std::printf("   largest joint turn %.4f rad at link %zu, %d joints at the per-step limit\n",
              turn_rad, turn_at, clamped);
  if (std::getenv("PROBE_SPIKE_DETAIL")) {
    const Eigen::Vector3d dc = after.p_WColon[colon_at] - before.p_WColon[colon_at];
    std::printf("   colon point %zu moved (%.4f %.4f %.4f)\n", colon_at, dc.x(), dc.y(), dc.z());
    const int last_point = static_cast<int>(after.p_WColon.size()) - 1;
    for (int i = std::max(0, static_cast<int>(colon_at) - 2);
         i <= std::min(last_point, static_cast<int>(colon_at) + 2); ++i) {
      const auto& pt = params.colon.points[i];
      const Eigen::Vector3d& c = before.p_WColon[i];
      std::printf("    point %d at (%.4f %.4f %.4f) offset %.4f rest tangent (%.2f %.2f %.2f) "
                  "radius %.4f\n", i, c.x(), c.y(), c.z(), before.colon_offset_m[i].norm(),
                  pt.rest_tangent.x(), pt.rest_tangent.y(), pt.rest_tangent.z(), pt.radius_m);
    }
    for (size_t k = 0; k < after.p_WSample.size(); ++k) {
      const auto& cb = before.contact[k];
      const auto& ca = after.contact[k];
      if (std::abs(ca.segment - static_cast<int>(colon_at)) > 1 &&
          std::abs(cb.segment - static_cast<int>(colon_at)) > 1) continue;
      const Eigen::Vector3d ds = after.p_WSample[k] - before.p_WSample[k];
      const Eigen::Vector3d& q = before.p_WSample[k];
      std::printf("    sample %zu was at (%.4f %.4f %.4f) t %.2f\n", k, q.x(), q.y(), q.z(),
                  cb.segment_t);
      const auto mid = ves::model::internal::CalcSegmentHit(params, before, cb.segment,
                                                           after.p_WSample[k]);
      std::printf("    sample %zu seg %d->%d touching %d->%d pen %.4f->(new scope, old colon "
                  "%.4f n %.2f %.2f %.2f)->%.4f sliding %d moved (%.4f %.4f %.4f)\n", k,
                  cb.segment, ca.segment, cb.touching, ca.touching, cb.penetration_m,
                  mid.penetration_m, mid.normal.x(), mid.normal.y(), mid.normal.z(),
                  ca.penetration_m, ca.sliding, ds.x(), ds.y(), ds.z());
    }
  }
  std::printf("   previous base %.1f N; step moved sample %zu by %.4f m, colon point %zu "
              "(arc %.3f) by %.4f m; inserted %.4f -> %.4f\n",
              previous_base_N, sample_at, sample_move_m, colon_at,
              params.colon.points[colon_at].arc_m, colon_move_m, before.inserted_m,
              after.inserted_m);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: insertion_probe CASE_FILE [speed_mm_s] [seconds] [segments]\n");
    return 2;
  }
  const double speed_m_per_s = (argc > 2 ? std::atof(argv[2]) : 20.0) / 1000.0;
  const double seconds = argc > 3 ? std::atof(argv[3]) : 120.0;
  ves::training::CaseModelOptions options;
  if (argc > 4) options.segments = std::atoi(argv[4]);
  const auto colon_case = ves::patient_db::LoadCaseFile(argv[1]);
  auto params = ves::training::MakeModelParams(colon_case, ves::training::DefaultEndoscopeSpec(),
                                               options);
  // Experiments: PROBE_MU scales friction, PROBE_SOFT_K sets the suspension of
  // the mobile (soft) points, PROBE_EI scales the tube rigidity.
  for (auto& point : params.colon.points) {
    if (const char* mu = std::getenv("PROBE_MU")) {
      point.tissue.static_friction *= std::atof(mu);
      point.tissue.dynamic_friction *= std::atof(mu);
    }
    if (const char* k = std::getenv("PROBE_SOFT_K");
        k && point.tissue.suspension_stiffness_N_per_m2 < 1000.0) {
      point.tissue.suspension_stiffness_N_per_m2 = std::atof(k);
    }
  }
  if (const char* ei = std::getenv("PROBE_EI")) {
    params.scope.flexural_rigidity_N_m2 *= std::atof(ei);
  }
  // PROBE_DT_MS: another step (the rule and the operators keep their rates).
  if (const char* dt = std::getenv("PROBE_DT_MS")) params.dt_s = std::atof(dt) / 1000.0;
  // PROBE_EA (0 turns the axial give off), PROBE_PLEAT, PROBE_PLEAT_LIMIT: the
  // colon's axial give (docs/model.md).
  if (const char* ea = std::getenv("PROBE_EA")) params.colon_longitudinal_stiffness_N = std::atof(ea);
  if (const char* r = std::getenv("PROBE_PLEAT")) params.colon_pleat_stiffness_ratio = std::atof(r);
  if (const char* l = std::getenv("PROBE_PLEAT_LIMIT")) params.colon_pleat_limit = std::atof(l);
  // A colon pleated by f packs 1/(1 - f) of its arc on a unit of scope: with
  // the give on, the tracking continuity limit must allow that much
  // (docs/model.md); PROBE_TRACKING sets the ratio itself.
  if (params.colon_longitudinal_stiffness_N > 0.0) {
    params.tracking_arc_ratio =
        std::max(params.tracking_arc_ratio, 1.0 / (1.0 - params.colon_pleat_limit));
  }
  if (const char* r = std::getenv("PROBE_TRACKING")) params.tracking_arc_ratio = std::atof(r);
  auto state = ves::model::MakeInitialState(params);
  auto scratch = ves::model::MakeScratch(params);
  auto out = ves::model::MakeStepOutput(params);

  const double reduce_from_m =
      std::getenv("PROBE_REDUCE_FROM") ? std::atof(std::getenv("PROBE_REDUCE_FROM")) : 1e9;
  const double slack_start_m =
      std::getenv("PROBE_SLACK") ? std::atof(std::getenv("PROBE_SLACK")) : 0.10;
  // PROBE_SLACK_END: the slack at which a reduction stops (default 0.03 m;
  // below 0 the scope is withdrawn until it is shorter than the centerline).
  const double slack_end_m =
      std::getenv("PROBE_SLACK_END") ? std::atof(std::getenv("PROBE_SLACK_END")) : 0.03;
  // PROBE_PUSH_LIMIT: base reaction (N) above which a reduction starts (default 8).
  const double push_limit_N =
      std::getenv("PROBE_PUSH_LIMIT") ? std::atof(std::getenv("PROBE_PUSH_LIMIT")) : 8.0;
  bool withdrawing = false;
  double command_m = 0.0;
  // PROBE_OPERATOR=novice|expert: the scripted operator drives instead of the rule.
  std::unique_ptr<ves::training::ScriptedOperator> scripted;
  if (const char* kind = std::getenv("PROBE_OPERATOR")) {
    scripted = ves::training::MakeScriptedOperator(kind, params.dt_s);
  }
  StepInput in;
  in.thrust_mode = ves::model::ThrustMode::kPosition;
  const double gain_per_s = 8.0;
  std::printf("t_s inserted_m tip_arc_m base_N stretch_m@arc wall_N@arc knob_up knob_right "
              "lumen_off_deg contacts\n");
  int next_print = 0;
  ves::model::ModelState previous = state;
  ves::model::ModelState earlier = state;
  // Read once: the switches below are consulted every step.
  const char* relax = std::getenv("PROBE_RELAX");
  // PROBE_LOOKAHEAD: how far ahead of the tip (m) the rule aims.
  const double lookahead_m = std::getenv("PROBE_LOOKAHEAD")
                                 ? std::atof(std::getenv("PROBE_LOOKAHEAD"))
                                 : ves::training::kLumenLookahead_m;
  const bool spikes = std::getenv("PROBE_SPIKES") != nullptr;
  const char* dump = std::getenv("PROBE_DUMP_AT");
  const double wall_over_N =
      std::getenv("PROBE_WALL_OVER") ? std::atof(std::getenv("PROBE_WALL_OVER")) : 0.0;
  double last_wall_print_s = -1.0;
  // Summary at the end: the deepest tip, the stretch and wall force peaks,
  // the seconds of stretch over 3 cm (the pain level), steps over 20 N.
  double max_tip_arc_m = 0.0, max_stretch_m = 0.0, max_wall_N = 0.0, max_base_N = 0.0;
  int stretched_s = 0, printed_s = 0, spike_steps = 0;
  while (state.time_s < seconds) {
    const auto p = ves::training::Perceive(params, state, out, lookahead_m);
    const double up_err = std::atan2(p.lumen_Tip.y(), p.lumen_Tip.z());
    const double right_err = std::atan2(p.lumen_Tip.x(), p.lumen_Tip.z());
    in.knob_up_rad = std::clamp(in.knob_up_rad + gain_per_s * up_err * params.dt_s,
                                -p.angulation_up_rad, p.angulation_up_rad);
    in.knob_right_rad = std::clamp(in.knob_right_rad + gain_per_s * right_err * params.dt_s,
                                   -p.angulation_right_rad, p.angulation_right_rad);
    // PROBE_RELAX=RATE: with the lumen ahead (within 30 degrees), the knobs
    // ease toward neutral at RATE per second (the tip straightened).
    if (relax && std::acos(std::clamp(p.lumen_Tip.z(), -1.0, 1.0)) < 0.52) {
      const double keep = std::max(0.0, 1.0 - std::atof(relax) * params.dt_s);
      in.knob_up_rad *= keep;
      in.knob_right_rad *= keep;
    }
    // Loop reduction: when the scope goes in but the tip does not follow,
    // withdraw (knobs held, tip hooked) until the slack is gone.
    const double slack_m = state.inserted_m - state.tip_arc_m;
    if (!withdrawing && state.tip_arc_m > reduce_from_m &&
        (slack_m > slack_start_m || out.base_force_N > push_limit_N)) withdrawing = true;
    if (withdrawing && slack_m < slack_end_m) withdrawing = false;
    command_m += (withdrawing ? -1.0 : 1.0) * speed_m_per_s * params.dt_s;
    command_m = std::clamp(command_m, 0.0, params.scope.working_length_m - 0.05);
    in.insertion_m = command_m;
    if (scripted) in = ves::training::ToStepInput(scripted->Act(p));
    // A spike's contacts are those at the start of its step: what made them
    // is the step before, from `earlier` to `previous`.
    if (spikes) earlier = previous, previous = state;
    const double previous_base_N = out.base_force_N;
    ves::model::Step(params, in, &state, &scratch, &out);
    max_tip_arc_m = std::max(max_tip_arc_m, state.tip_arc_m);
    max_stretch_m = std::max(max_stretch_m, out.peak_stretch_m);
    max_wall_N = std::max(max_wall_N, out.peak_wall_force_N);
    max_base_N = std::max(max_base_N, std::abs(out.base_force_N));
    if (std::abs(out.base_force_N) > 20.0) ++spike_steps;
    if (spikes && std::abs(out.base_force_N) > 20.0) {
      PrintSpike(state, in, out);
      PrintMotion(params, earlier, previous, previous_base_N);
    }
    // PROBE_WALL_OVER=N: the contacts of a step whose largest wall force passes N (once per 0.2 s).
    if (wall_over_N > 0.0 && out.peak_wall_force_N > wall_over_N &&
        state.time_s - last_wall_print_s > 0.2) {
      last_wall_print_s = state.time_s;
      std::printf(
          "wall t=%.3f peak %.1f N, base %.2f N, push %.2f N, knobs %.2f %.2f, inserted %.3f "
          "tip %.3f\n",
          state.time_s, out.peak_wall_force_N, out.base_force_N, in.push_force_N, in.knob_up_rad,
          in.knob_right_rad, state.inserted_m, state.tip_arc_m);
      for (int j = 0; j < out.contact_count; ++j) {
        const auto& c = out.contacts[j];
        if (c.normal_force_N < 1.0) continue;
        std::printf("   from_tip %.3f colon_arc %.3f N %.2f pen %.4f alpha %.2f\n",
                    c.scope_arc_from_tip_m, c.colon_arc_m, c.normal_force_N, c.penetration_m,
                    c.alpha);
      }
    }
    if (!out.finite) {
      std::printf("diverged at t=%.3f\n", state.time_s);
      return 1;
    }
    if (dump && next_print == std::atoi(dump) && state.time_s >= next_print) {
      DumpShape(params, state, "/tmp/probe_" + std::to_string(next_print) + ".png");
    }
    if (state.time_s >= next_print) {
      ++next_print;
      ++printed_s;
      if (out.peak_stretch_m > 0.03) ++stretched_s;
      int wall_i = 0;
      for (size_t i = 0; i < out.wall_force_N.size(); ++i)
        if (out.wall_force_N[i] > out.wall_force_N[wall_i]) wall_i = static_cast<int>(i);
      std::printf("%5.1f %.3f %.3f %6.2f %.3f@%.2f %5.2f@%.2f %5.2f %5.2f %5.1f %d\n", state.time_s,
                  state.inserted_m, state.tip_arc_m, out.base_force_N, out.peak_stretch_m,
                  out.peak_stretch_arc_m, out.peak_wall_force_N,
                  params.colon.points[wall_i].arc_m, in.knob_up_rad, in.knob_right_rad,
                  std::acos(std::clamp(p.lumen_Tip.z(), -1.0, 1.0)) * 180 / M_PI,
                  out.contact_count);
      if (std::getenv("PROBE_TIP")) {
        const auto& c = state.contact.back();
        const Eigen::Vector3d tip = state.X_WTip.translation();
        std::printf("    tip (%.3f %.3f %.3f) seg %d t %.2f pen %.4f offset %.4f\n", tip.x(),
                    tip.y(), tip.z(), c.segment, c.segment_t, c.penetration_m,
                    state.colon_offset_m[c.segment].norm());
      }
      if (std::getenv("PROBE_AXIAL")) {
        // Axial give every 0.1 m of colon (mm, + toward the cecum).
        std::printf("    axial_mm");
        const auto& pts = params.colon.points;
        double next_arc_m = 0.1;
        for (size_t i = 0; i < pts.size(); ++i) {
          if (pts[i].arc_m < next_arc_m) continue;
          std::printf(" %.0f", 1e3 * state.colon_axial_m[i]);
          next_arc_m += 0.1;
        }
        std::printf("\n");
      }
      if (std::getenv("PROBE_CONTACTS")) {
        for (int j = 0; j < out.contact_count; ++j) {
          const auto& c = out.contacts[j];
          if (c.normal_force_N < 0.2) continue;
          const Eigen::Vector3d axis = state.X_WLink[state.samples[c.sample].link].linear().col(2);
          std::printf("    from_tip %.3f colon_arc %.3f N %.2f alpha %.2f axial_on_scope %.2f\n",
                      c.scope_arc_from_tip_m, c.colon_arc_m, c.normal_force_N, c.alpha,
                      c.force_on_scope_W_N.dot(axis));
        }
      }
    }
  }
  std::printf("summary: max tip arc %.3f m, stretch peak %.3f m, over 3 cm %d of %d s, "
              "wall peak %.1f N, %d steps over 20 N (largest %.1f N)\n",
              max_tip_arc_m, max_stretch_m, stretched_s, printed_s, max_wall_N, spike_steps,
              max_base_N);
  return 0;
}
