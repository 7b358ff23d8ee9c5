#pragma once

namespace ves::training {

// Thresholds that turn raw step observations into metrics. Defaults are the
// values documented in docs/scoring.md; change both together.
struct MetricThresholds {
  // The cecum is reached when the tip's arc position gets this far along the colon.
  double cecum_arc_m{1.0};
  // Wall force above which a contact counts as excessive (an episode).
  double excessive_wall_force_N{4.0};
  // Mesentery stretch beyond its slack above which the patient feels pain
  // (the paper: overextending the colon that is not fixed hurts; 2 cm separates the
  // scripted operators on the shortening colon, docs/scoring.md).
  double pain_stretch_m{0.02};
  // Wall force above which the wall is damaged; damage is the impulse above
  // it. The lowest perforation load of porcine colon under a colonoscope
  // head, 14.1 N (straight tip, angled loading; Johnson et al., J Mech Behav
  // Biomed Mater 2019).
  double damage_wall_force_N{14.0};
  // Loop index (slack, m) that starts a loop, and the lower value that ends it.
  double loop_enter_m{0.06};
  double loop_exit_m{0.03};
  // Red-out: the image counts as red-out when at least this fraction is red.
  double redout_fraction{0.5};
  // Episodes of the same kind closer than this are merged into one.
  double episode_merge_gap_s{0.2};

  bool operator==(const MetricThresholds&) const = default;
};

}  // namespace ves::training
