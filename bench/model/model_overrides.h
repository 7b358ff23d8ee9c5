#pragma once

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <functional>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "patient_db/case_format.h"
#include "station/training/case_model.h"
#include "ves/v1/case.pb.h"
#include "station/model/model.h"
#include "station/training/scripted_operator.h"

// The model (and scripted expert) settings the probing tools override, by key, in one place so
// that expert_sweep (key=value arguments) and insertion_probe (--key=value
// flags) cannot drift apart (docs/model-shortening-notes.md).
// `get(key, fallback)` returns the override or the fallback.
//   every point: mu (friction x)
//   mobile points: soft_k (suspension, N/m^2), mobile_kc_scale (suspension x),
//     relax_s, meso_k, meso_m, pleat (limit), tension
//   colon: shear, anchor_arc (0/1), abdomen (m),
//     across (0/1), ring_onset_s, window (contact search, segments), arc_ratio
//   scope: ei (insertion tube EI x), bend_ei, links, growth, passive_m, passive_ei
//   step: dt_ms, pleat_k, toe_k, toe_strain, toe_regions (bit 1 << Region),
//     pleat_set_s, pleat_release_s, press_k, press_slack
//   experiments (model::ModelExperiments, ExperimentsWithOverrides): gather
//     (the set pleat ratio at which the lumen hugs the scope, 0 off),
//     gather_clear (m)
namespace ves::bench {

using OverrideGetter = std::function<double(const char* key, double fallback)>;

// The key=value arguments from argv[first] on (others are skipped), and
// their text joined for a result line's tag.
struct CommandLineOverrides {
  std::map<std::string, double> values;
  std::string tag;
  double Get(const char* key, double fallback) const {
    const auto it = values.find(key);
    return it != values.end() ? it->second : fallback;
  }
};

inline CommandLineOverrides ParseOverrides(int argc, char** argv, int first) {
  CommandLineOverrides o;
  for (int i = first; i < argc; ++i) {
    const std::string a = argv[i];
    const auto eq = a.find('=');
    if (eq == std::string::npos) continue;
    o.values[a.substr(0, eq)] = std::atof(a.substr(eq + 1).c_str());
    o.tag += a + " ";
  }
  return o;
}

// The settings that shape the colon at rest, set on the case before it is
// resampled: reserve_sig, reserve_trans (TissueParams::gathered_reserve of
// the sigmoid and transverse colon; a mobile descending colon takes the
// sigmoid's).
inline void ApplyCaseOverrides(const OverrideGetter& get, ves::v1::ColonCase* colon_case) {
  for (auto& span : *colon_case->mutable_regions()) {
    const bool transverse = span.region() == ves::v1::REGION_TRANSVERSE;
    const bool sigmoid_like =
        span.region() == ves::v1::REGION_SIGMOID || span.region() == ves::v1::REGION_DESCENDING;
    const double reserve = get(transverse ? "reserve_trans" : "reserve_sig", -1.0);
    if (reserve >= 0.0 && (transverse || sigmoid_like)) {
      span.mutable_tissue()->set_gathered_reserve(reserve);
    }
  }
}

inline void ApplyModelOverrides(const OverrideGetter& get, model::ModelParams* params) {
  for (auto& point : params->colon.points) {
    auto& t = point.tissue;
    t.static_friction *= get("mu", 1.0);
    t.dynamic_friction *= get("mu", 1.0);
    if (!t.mobile) continue;
    t.suspension_stiffness_N_per_m2 =
        get("soft_k", t.suspension_stiffness_N_per_m2) * get("mobile_kc_scale", 1.0);
    t.suspension_relaxation_s = get("relax_s", t.suspension_relaxation_s);
    t.mesentery_stiffness_N_per_m2 = get("meso_k", t.mesentery_stiffness_N_per_m2);
    t.mesentery_length_m = get("meso_m", t.mesentery_length_m);
    t.pleat_limit = get("pleat", t.pleat_limit);
    t.neighbor_tension_N = get("tension", t.neighbor_tension_N);
  }
  auto& colon = params->colon;
  colon.mesentery_shear_ratio = get("shear", colon.mesentery_shear_ratio);
  colon.mesentery_anchor_by_arc = get("anchor_arc", colon.mesentery_anchor_by_arc ? 1.0 : 0.0) != 0.0;
  colon.abdomen_margin_m = get("abdomen", colon.abdomen_margin_m);
  params->contacts_across_scope =
      get("across", params->contacts_across_scope ? 1.0 : 0.0) != 0.0;
  params->ring_onset_s = get("ring_onset_s", params->ring_onset_s);
  params->contact_search_window =
      static_cast<int>(get("window", params->contact_search_window));
  params->tracking_arc_ratio = get("arc_ratio", params->tracking_arc_ratio);
  model::CalcMesenteryAnchors(&colon);
  auto& scope = params->scope;
  scope.flexural_rigidity_N_m2 *= get("ei", 1.0);
  scope.bending_section_rigidity_N_m2 = get("bend_ei", scope.bending_section_rigidity_N_m2);
  scope.link_count = static_cast<int>(get("links", scope.link_count));
  scope.link_growth_ratio = get("growth", scope.link_growth_ratio);
  scope.passive_section_length_m = get("passive_m", scope.passive_section_length_m);
  scope.passive_section_rigidity_N_m2 = get("passive_ei", scope.passive_section_rigidity_N_m2);
  if (const double dt_ms = get("dt_ms", 0.0); dt_ms > 0.0) params->dt_s = dt_ms * 1e-3;
  params->colon_pleat_stiffness_N = get("pleat_k", params->colon_pleat_stiffness_N);
  params->colon_toe_stiffness_N = get("toe_k", params->colon_toe_stiffness_N);
  params->colon_straighten_stiffness_N = get("straighten_k", params->colon_straighten_stiffness_N);
  params->colon_toe_strain = get("toe_strain", params->colon_toe_strain);
  params->colon_toe_regions =
      static_cast<std::uint32_t>(get("toe_regions", params->colon_toe_regions));
  params->colon_pleat_set_s = get("pleat_set_s", params->colon_pleat_set_s);
  params->colon_pleat_release_s = get("pleat_release_s", params->colon_pleat_release_s);
  params->abdominal_pressure_stiffness_N_per_m2 =
      get("press_k", params->abdominal_pressure_stiffness_N_per_m2);
  params->abdominal_pressure_slack_m = get("press_slack", params->abdominal_pressure_slack_m);
  params->abdominal_pressure_ramp_s = get("press_ramp_s", params->abdominal_pressure_ramp_s);
}

// The model's experiments (MakeScratch) with the overrides applied.
inline model::ModelExperiments ExperimentsWithOverrides(const OverrideGetter& get) {
  model::ModelExperiments experiments;
  experiments.lumen_gather_pleat = get("gather", experiments.lumen_gather_pleat);
  experiments.lumen_gather_clearance_m = get("gather_clear", experiments.lumen_gather_clearance_m);
  return experiments;
}

// A case file as the model's parameters with every override applied: the
// case's (ApplyCaseOverrides) before it is resampled, the model's after.
inline model::ModelParams LoadParamsWithOverrides(const std::string& case_file,
                                                  const OverrideGetter& get) {
  auto colon_case = patient_db::LoadCaseFile(case_file);
  ApplyCaseOverrides(get, &colon_case);
  auto params = training::MakeModelParams(colon_case, training::DefaultEndoscopeSpec(),
                                          training::CaseModelOptions{});
  ApplyModelOverrides(get, &params);
  return params;
}

// The scripted expert's settings by key: advance, withdraw, push, pull,
// loop_limit, roll_rate, settle, max_withdraw, max_reduce_s
// (ExpertOperator::Settings).
inline training::ExpertOperator::Settings ExpertSettingsWithOverrides(const OverrideGetter& get) {
  training::ExpertOperator::Settings expert;
  expert.advance_speed_m_per_s = get("advance", expert.advance_speed_m_per_s);
  expert.withdraw_speed_m_per_s = get("withdraw", expert.withdraw_speed_m_per_s);
  expert.push_limit_N = get("push", expert.push_limit_N);
  expert.pull_limit_N = get("pull", expert.pull_limit_N);
  expert.loop_limit_m = get("loop_limit", expert.loop_limit_m);
  expert.roll_rate_rad_per_s = get("roll_rate", expert.roll_rate_rad_per_s);
  expert.settle_s = get("settle", expert.settle_s);
  expert.max_withdraw_m = get("max_withdraw", expert.max_withdraw_m);
  expert.max_reduce_s = get("max_reduce_s", expert.max_reduce_s);
  return expert;
}

// insertion_probe's command line: positional arguments, and flags
// --key=value or --key alone (the value 1); a key may be written with '-' or
// '_' (--meso-k=2 and --meso_k=2 are the key meso_k). Each flag is read by
// Has/Get/Text; Unread() names those nothing asked for (misspelt, or of no
// effect in this run).
class ProbeFlags {
 public:
  // Throws std::invalid_argument for a flag without a key ("--", "--=1").
  ProbeFlags(int argc, char** argv) {
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      if (arg.rfind("--", 0) != 0) {
        positional_.push_back(arg);
        continue;
      }
      const std::size_t eq = arg.find('=');
      std::string key = arg.substr(2, eq == std::string::npos ? std::string::npos : eq - 2);
      if (key.empty()) throw std::invalid_argument("flag '" + arg + "' has no name");
      std::replace(key.begin(), key.end(), '-', '_');
      values_[key] = eq == std::string::npos ? "1" : arg.substr(eq + 1);
    }
  }
  bool Has(const char* key) const {
    asked_.insert(key);
    return values_.count(key) > 0;
  }
  double Get(const char* key, double fallback) const {
    const char* value = Text(key);
    return value != nullptr ? std::atof(value) : fallback;
  }
  // The flag's text; nullptr when it was not given.
  const char* Text(const char* key) const {
    asked_.insert(key);
    const auto it = values_.find(key);
    return it != values_.end() ? it->second.c_str() : nullptr;
  }
  OverrideGetter Getter() const {
    return [this](const char* key, double fallback) { return Get(key, fallback); };
  }
  const std::vector<std::string>& positional() const { return positional_; }
  std::vector<std::string> Unread() const {
    std::vector<std::string> unread;
    for (const auto& [key, value] : values_) {
      if (asked_.count(key) == 0) unread.push_back(key);
    }
    return unread;
  }

 private:
  std::map<std::string, std::string> values_;
  mutable std::set<std::string> asked_;
  std::vector<std::string> positional_;
};

// The mean of the last 10 values added (zeros before that): a 10 ms mean at
// the 1 ms step, the resolution the session metrics give a hand's force.
class TenStepMean {
 public:
  double Add(double value) {
    sum_ += value - last_[next_];
    last_[next_] = value;
    next_ = (next_ + 1) % 10;
    return sum_ / 10.0;
  }

 private:
  double sum_{0.0};
  double last_[10]{};
  int next_{0};
};

// The push ring contact j (Scratch::ring_contacts) gives the scope along its
// axis at the ring's sample, the chord through the neighbouring samples;
// + toward the tip. A ring whose point lies past its piece's end pushes
// along the shaft like a barb (docs/model-shortening-notes.md, "Rings that
// hold the scope along its length").
inline double RingPushAlongScope_N(const model::ModelState& state, const model::Scratch& scratch,
                                   int j) {
  const auto& rc = scratch.ring_contacts[j];
  const int last = static_cast<int>(state.p_WSample.size()) - 1;
  const Eigen::Vector3d axis = (state.p_WSample[std::min(rc.sample + 1, last)] -
                                state.p_WSample[std::max(rc.sample - 1, 0)])
                                   .normalized();
  return (-rc.force_N * rc.normal_W).dot(axis);
}

// The colon point that carries the largest wall force this step.
inline int LargestWallForcePoint(const model::StepOutput& out) {
  const auto& wall = out.wall_force_N;
  return static_cast<int>(std::max_element(wall.begin(), wall.end()) - wall.begin());
}

}  // namespace ves::bench
