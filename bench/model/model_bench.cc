// Cost of one model Step (docs/model.md): the paper's size, the 64-link x
// 1000-segment target, and the scaling in the number of colon segments; and
// the colon's block elimination alone, the floor of any step that solves the
// 3-D colon directly (docs/model.md, "Speed").
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "station/model/internal.h"
#include "station/model/model.h"

namespace {

using namespace ves::model;

// A 1.2 m colon that winds like a sigmoid (two loops), mobile in the middle.
ModelParams MakeParams(int links, int segments) {
  ColonCurve curve;
  for (int i = 0; i <= 40; ++i) {
    const double s = i / 40.0;
    curve.control_points_m.emplace_back(0.06 * std::sin(2.0 * kPi * s),
                                        0.08 * std::sin(kPi * s) * std::sin(3.0 * kPi * s),
                                        0.5 * s);
  }
  curve.radius_profile = {{0.0, 0.015}, {0.1, 0.02}};
  TissueParams fixed;
  fixed.suspension_stiffness_N_per_m2 = 2e4;
  TissueParams mobile;
  mobile.suspension_stiffness_N_per_m2 = 300;
  curve.regions = {{Region::kRectum, 0.0, 0.15, fixed},
                   {Region::kSigmoid, 0.15, 0.6, mobile},
                   {Region::kDescending, 0.6, 10.0, fixed}};
  ModelParams params;
  params.colon = ResampleColon(curve, segments);
  params.scope.link_count = links;
  return params;
}

void BM_Step(benchmark::State& bench, int links, int segments) {
  ModelParams params = MakeParams(links, segments);
  ModelState state = MakeInitialState(params);
  Scratch scratch = MakeScratch(params);
  StepOutput out = MakeStepOutput(params);
  StepInput in;
  // Insert 0.5 m first so the scope lies in the colon with many contacts.
  while (state.time_s < 5.0) {
    in.insertion_m = 0.1 * state.time_s;
    Step(params, in, &state, &scratch, &out);
  }
  // Then a hand's small back-and-forth (+-5 mm at 1 Hz, up to ~30 mm/s), so
  // the state and the cost do not drift with the number of iterations.
  const double center_m = in.insertion_m;
  for (auto _ : bench) {
    in.insertion_m = center_m + 0.005 * std::sin(2.0 * kPi * state.time_s);
    Step(params, in, &state, &scratch, &out);
    benchmark::DoNotOptimize(out.base_force_N);
  }
  bench.counters["contacts"] = out.contact_count;
  bench.counters["samples"] = static_cast<double>(state.samples.size());
  // Colon points away from rest (the solver skips the rest of them).
  int displaced = 0;
  for (const auto& d : state.colon_displacement_m) displaced += d.cwiseAbs().maxCoeff() > 1e-7;
  bench.counters["displaced"] = displaced;
  bench.counters["points"] = static_cast<double>(params.colon.points.size());
}

// Paper §3.6: 5 movable joints (4 bending + the base) and 150 segments.
BENCHMARK_CAPTURE(BM_Step, paper_5joints_150seg, 5, 150)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Step, default_48links_150seg, 48, 150)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Step, target_64links_1000seg, 64, 1000)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Step, scaling_64links_250seg, 64, 250)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Step, scaling_64links_4000seg, 64, 4000)->Unit(benchmark::kMicrosecond);

// The block Thomas elimination of SolveColon over `points` points, on a
// random symmetric positive definite system (its cost does not depend on the
// values).
void BM_ColonElimination(benchmark::State& bench, int points) {
  std::mt19937 random(1);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  ColonSystem system;
  system.Resize(points);
  for (int i = 0; i < points; ++i) {
    Eigen::Matrix3d a;
    for (int k = 0; k < 9; ++k) a.data()[k] = unit(random);
    const Eigen::Matrix3d upper = 0.3 * (a + a.transpose());
    const Eigen::Matrix3d diag = 5.0 * Eigen::Matrix3d::Identity() + 0.1 * a * a.transpose();
    const int entry[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
    for (int e = 0; e < 6; ++e) system.diag[e][i] = diag(entry[e][0], entry[e][1]);
    for (int e = 0; e < 9; ++e) system.upper[e][i] = upper(e / 3, e % 3);
    for (int c = 0; c < 3; ++c) system.rhs[c][i] = unit(random);
  }
  for (auto _ : bench) {
    internal::SolveBlockTridiagonal(points - 1, &system);
    benchmark::DoNotOptimize(system.solution.data());
  }
}

BENCHMARK_CAPTURE(BM_ColonElimination, paper_150seg, 150)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_ColonElimination, target_1000seg, 1000)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
