#include "patient_db/case_generator.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "patient_db/case_geometry.h"
#include "patient_db/case_problem.h"
#include "patient_db/case_regions.h"
#include "patient_db/case_validate.h"

namespace ves::patient_db {
namespace {

using ves::v1::Region;
using Vec = std::array<double, 3>;

constexpr int kRegionCount = 8;
constexpr std::array<Region, kRegionCount> kRegionOrder = {
    ves::v1::REGION_RECTUM,          ves::v1::REGION_SIGMOID,    ves::v1::REGION_DESCENDING,
    ves::v1::REGION_SPLENIC_FLEXURE, ves::v1::REGION_TRANSVERSE, ves::v1::REGION_HEPATIC_FLEXURE,
    ves::v1::REGION_ASCENDING,       ves::v1::REGION_CECUM};
enum RegionIndex {
  kRectum,
  kSigmoid,
  kDescending,
  kSplenic,
  kTransverse,
  kHepatic,
  kAscending,
  kCecum
};

// Draw ranges (docs/case-generator.md has each one's source).
constexpr std::array<GeneratedLengthRange, kRegionCount> kLengthRanges = {{
    {ves::v1::REGION_RECTUM, 0.12, 0.15},
    {ves::v1::REGION_SIGMOID, 0.15, 0.70},
    {ves::v1::REGION_DESCENDING, 0.20, 0.28},
    {ves::v1::REGION_SPLENIC_FLEXURE, 0.06, 0.10},
    {ves::v1::REGION_TRANSVERSE, 0.30, 0.65},
    {ves::v1::REGION_HEPATIC_FLEXURE, 0.05, 0.08},
    {ves::v1::REGION_ASCENDING, 0.15, 0.20},
    {ves::v1::REGION_CECUM, 0.05, 0.08},
}};
constexpr double kRedundantSigmoidProbability = 0.25;
constexpr double kRedundantSigmoidMin_m = 0.50;
constexpr double kSigmoidMean_m = 0.38;
constexpr double kSigmoidSd_m = 0.07;
constexpr double kTransverseMean_m = 0.45;
constexpr double kTransverseSd_m = 0.08;
constexpr double kMobileDescendingProbability = 0.25;
// Mesocolon heights (Phillips et al., Ann R Coll Surg Engl 2015).
constexpr double kSigmoidMesocolonMean_m = 0.063;
constexpr double kSigmoidMesocolonSd_m = 0.026;
constexpr double kTransverseMesocolonMean_m = 0.074;
constexpr double kTransverseMesocolonSd_m = 0.036;
constexpr double kMinMesocolon_m = 0.02;
constexpr double kMaxMesocolon_m = 0.18;

// Lumen radius per region, as the shipped cases (docs/case-format.md), all
// scaled by one drawn factor (distension); the anal canal stays 13 mm.
constexpr std::array<double, kRegionCount> kRadius_m = {0.022, 0.016, 0.018, 0.020,
                                                        0.024, 0.025, 0.027, 0.032};
constexpr double kAnalCanalRadius_m = 0.013;
constexpr double kAnalCanalLength_m = 0.04;
constexpr double kMinRadiusScale = 0.85;
constexpr double kMaxRadiusScale = 1.15;

constexpr double kControlPointStep_m = 0.025;  // as the shipped cases
constexpr int kSamplesPerSpan = 20;            // of the smooth curve between waypoints
constexpr double kLengthTolerance_m = 0.005;   // fitted region length against its draw
constexpr int kMaxAttempts = 200;

// The shipped cases' anatomy in W (patient_db/cases/generate_cases.py, x
// toward the patient's right): each region's template is stretched to its
// drawn length.
const std::vector<Vec> kRectumShape = {{0.0, 0.0, 0.0},         {0.0, -0.012, 0.028},
                                       {0.0, -0.028, 0.055},    {-0.001, -0.040, 0.080},
                                       {-0.003, -0.044, 0.103}, {-0.005, -0.040, 0.125}};
// The common sigmoid: forward and to the right out of the pelvis, back to the
// left iliac fossa.
const std::vector<Vec> kSigmoidShape = {
    {-0.005, -0.040, 0.125}, {0.008, -0.022, 0.145}, {0.027, -0.001, 0.160}, {0.042, 0.024, 0.172},
    {0.047, 0.052, 0.188},   {0.040, 0.076, 0.208},  {0.018, 0.088, 0.225},  {-0.010, 0.089, 0.233},
    {-0.040, 0.080, 0.233},  {-0.066, 0.060, 0.226}, {-0.086, 0.034, 0.217}, {-0.098, 0.008, 0.210},
    {-0.106, -0.018, 0.212}, {-0.112, -0.035, 0.225}};
// A redundant sigmoid: rises out of the pelvis, comes back down and swings
// across in front of its own start (where an alpha loop forms).
const std::vector<Vec> kRedundantSigmoidShape = {
    {-0.005, -0.040, 0.125}, {0.010, -0.026, 0.158}, {0.032, -0.010, 0.180}, {0.052, 0.015, 0.198},
    {0.060, 0.045, 0.215},   {0.052, 0.072, 0.235},  {0.030, 0.088, 0.250},  {0.000, 0.095, 0.256},
    {-0.030, 0.092, 0.250},  {-0.052, 0.082, 0.235}, {-0.056, 0.070, 0.212}, {-0.040, 0.062, 0.192},
    {-0.015, 0.062, 0.174},  {0.005, 0.075, 0.155},  {0.000, 0.095, 0.135},  {-0.030, 0.105, 0.125},
    {-0.062, 0.095, 0.135},  {-0.088, 0.072, 0.155}, {-0.104, 0.042, 0.175}, {-0.112, 0.010, 0.195},
    {-0.114, -0.018, 0.208}, {-0.112, -0.035, 0.225}};
const std::vector<Vec> kDescendingShape = {{-0.112, -0.035, 0.225},
                                           {-0.118, -0.042, 0.280},
                                           {-0.124, -0.045, 0.340},
                                           {-0.128, -0.043, 0.400},
                                           {-0.128, -0.038, 0.455}};
const std::vector<Vec> kSplenicShape = {{-0.128, -0.038, 0.455},
                                        {-0.124, -0.024, 0.485},
                                        {-0.110, -0.004, 0.497},
                                        {-0.097, 0.016, 0.488}};
const std::vector<Vec> kTransverseShape = {
    {-0.097, 0.016, 0.488}, {-0.090, 0.040, 0.462}, {-0.080, 0.062, 0.428}, {-0.066, 0.082, 0.392},
    {-0.048, 0.097, 0.356}, {-0.026, 0.106, 0.325}, {0.000, 0.110, 0.308},  {0.026, 0.108, 0.306},
    {0.052, 0.102, 0.318},  {0.074, 0.092, 0.340},  {0.092, 0.078, 0.366},  {0.106, 0.060, 0.392},
    {0.114, 0.040, 0.414},  {0.118, 0.020, 0.428}};
const std::vector<Vec> kHepaticShape = {
    {0.118, 0.020, 0.428}, {0.124, 0.000, 0.434}, {0.128, -0.018, 0.425}, {0.128, -0.026, 0.405}};
const std::vector<Vec> kAscendingShape = {{0.128, -0.026, 0.405},
                                          {0.126, -0.028, 0.365},
                                          {0.122, -0.026, 0.320},
                                          {0.118, -0.022, 0.278},
                                          {0.114, -0.016, 0.238}};
const std::vector<Vec> kCecumShape = {
    {0.114, -0.016, 0.238}, {0.112, -0.008, 0.210}, {0.110, 0.004, 0.185}};
// Where the sigmoid meets the descending colon (left iliac fossa).
constexpr Vec kSigmoidDescendingJunction = {-0.112, -0.035, 0.225};
constexpr double kHepaticFlexureX_m = 0.118;
constexpr double kHepaticFlexureY_m = 0.020;

Vec Add(const Vec& a, const Vec& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec Sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec Scale(const Vec& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
Vec Lerp(const Vec& a, const Vec& b, double w) { return Add(a, Scale(Sub(b, a), w)); }
double Norm(const Vec& a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }
double Distance(const Vec& a, const Vec& b) { return Norm(Sub(a, b)); }

double PolylineLength(const std::vector<Vec>& points) {
  double length = 0.0;
  for (size_t i = 1; i < points.size(); ++i) length += Distance(points[i - 1], points[i]);
  return length;
}

// Deterministic on every platform (std:: distributions are not): SplitMix64.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t Next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double Uniform01() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform01(); }
  bool Chance(double p) { return Uniform01() < p; }
  // Normal(mean, sd) by Box-Muller, drawn again until within [lo, hi].
  double TruncatedNormal(double mean, double sd, double lo, double hi) {
    for (int i = 0; i < 100; ++i) {
      const double u1 = 1.0 - Uniform01();  // (0, 1]
      const double u2 = Uniform01();
      const double z = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
      const double value = mean + sd * z;
      if (value >= lo && value <= hi) return value;
    }
    return std::clamp(mean, lo, hi);
  }

 private:
  std::uint64_t state_;
};

// One colon's draws.
struct Draw {
  std::array<double, kRegionCount> length_m{};
  bool redundant_sigmoid = false;
  bool mobile_descending = false;
  double radius_scale = 1.0;
  double sigmoid_mesocolon_m = 0.0;
  double transverse_mesocolon_m = 0.0;
  double descending_mesocolon_m = 0.0;
  Vec sigmoid_shape{1.0, 1.0, 1.0};     // scale of the loop's excursion per axis
  Vec transverse_shape{1.0, 1.0, 1.0};  // forward and downward sag
  Vec junction_shift{0.0, 0.0, 0.0};    // of the sigmoid-descending junction
  double descending_medial_m = 0.0;     // bow toward the midline of a mobile descending colon
  double hepatic_drop_m = 0.0;          // hepatic flexure below the splenic
};

Draw DrawColon(Rng& rng, const ColonGeneratorOptions& options) {
  Draw d;
  d.redundant_sigmoid =
      options.redundant_sigmoid.value_or(rng.Chance(kRedundantSigmoidProbability));
  d.mobile_descending =
      options.mobile_descending.value_or(rng.Chance(kMobileDescendingProbability));
  const auto uniform = [&](int r) {
    return rng.Uniform(kLengthRanges[r].min_m, kLengthRanges[r].max_m);
  };
  d.length_m[kRectum] = uniform(kRectum);
  d.length_m[kSigmoid] =
      d.redundant_sigmoid
          ? rng.Uniform(kRedundantSigmoidMin_m, kLengthRanges[kSigmoid].max_m)
          : rng.TruncatedNormal(kSigmoidMean_m, kSigmoidSd_m, kLengthRanges[kSigmoid].min_m,
                                kRedundantSigmoidMin_m);
  d.length_m[kDescending] = uniform(kDescending);
  d.length_m[kSplenic] = uniform(kSplenic);
  d.length_m[kTransverse] =
      rng.TruncatedNormal(kTransverseMean_m, kTransverseSd_m, kLengthRanges[kTransverse].min_m,
                          kLengthRanges[kTransverse].max_m);
  d.length_m[kHepatic] = uniform(kHepatic);
  d.length_m[kAscending] = uniform(kAscending);
  d.length_m[kCecum] = uniform(kCecum);
  d.radius_scale = rng.Uniform(kMinRadiusScale, kMaxRadiusScale);
  d.sigmoid_mesocolon_m = rng.TruncatedNormal(kSigmoidMesocolonMean_m, kSigmoidMesocolonSd_m,
                                              kMinMesocolon_m, kMaxMesocolon_m);
  d.transverse_mesocolon_m = rng.TruncatedNormal(
      kTransverseMesocolonMean_m, kTransverseMesocolonSd_m, kMinMesocolon_m, kMaxMesocolon_m);
  d.descending_mesocolon_m = rng.TruncatedNormal(kSigmoidMesocolonMean_m, kSigmoidMesocolonSd_m,
                                                 kMinMesocolon_m, kMaxMesocolon_m);
  d.sigmoid_shape = d.redundant_sigmoid
                        ? Vec{rng.Uniform(0.8, 1.1), rng.Uniform(0.9, 1.2), rng.Uniform(0.8, 1.3)}
                        : Vec{rng.Uniform(0.6, 1.2), rng.Uniform(0.8, 1.2), rng.Uniform(0.6, 1.6)};
  d.transverse_shape = {1.0, rng.Uniform(0.8, 1.2), rng.Uniform(0.7, 1.3)};
  d.junction_shift = {rng.Uniform(-0.01, 0.01), 0.0, rng.Uniform(-0.02, 0.02)};
  d.descending_medial_m = d.mobile_descending ? rng.Uniform(0.02, 0.05) : 0.0;
  d.hepatic_drop_m = rng.Uniform(0.03, 0.09);
  return d;
}

// Arc fraction of each point along a polyline.
std::vector<double> ArcFractions(const std::vector<Vec>& points) {
  std::vector<double> u(points.size(), 0.0);
  for (size_t i = 1; i < points.size(); ++i) u[i] = u[i - 1] + Distance(points[i - 1], points[i]);
  for (auto& value : u) value /= u.back();
  return u;
}

// `shape` from `to`, its excursion from its own chord scaled per axis by
// `excursion`: a loop drawn larger or smaller between new ends.
std::vector<Vec> LoopBetween(const std::vector<Vec>& shape, const Vec& from, const Vec& to,
                             const Vec& excursion) {
  const auto u = ArcFractions(shape);
  std::vector<Vec> out;
  for (size_t i = 0; i < shape.size(); ++i) {
    const Vec offset = Sub(shape[i], Lerp(shape.front(), shape.back(), u[i]));
    const Vec base = Lerp(from, to, u[i]);
    out.push_back({base[0] + offset[0] * excursion[0], base[1] + offset[1] * excursion[1],
                   base[2] + offset[2] * excursion[2]});
  }
  return out;
}

// `shape` moved to start at `from`, scaled by `scale`.
std::vector<Vec> ScaledFrom(const std::vector<Vec>& shape, const Vec& from, double scale) {
  std::vector<Vec> out;
  for (const auto& p : shape) out.push_back(Add(from, Scale(Sub(p, shape.front()), scale)));
  return out;
}

// `shape` moved to start at `from`, its height (z extent) made `height_m`.
std::vector<Vec> StretchedFrom(const std::vector<Vec>& shape, const Vec& from, double height_m) {
  const double z_extent = std::abs(shape.back()[2] - shape.front()[2]);
  std::vector<Vec> out;
  for (const auto& p : shape) {
    const Vec d = Sub(p, shape.front());
    out.push_back(Add(from, {d[0], d[1], d[2] * height_m / z_extent}));
  }
  return out;
}

// Waypoints of every region (each starting where the previous ends) for the
// fitted size parameters `size` (one per region, each monotone in its length).
std::vector<std::vector<Vec>> Waypoints(const Draw& d,
                                        const std::array<double, kRegionCount>& size) {
  std::vector<std::vector<Vec>> regions(kRegionCount);
  regions[kRectum] = ScaledFrom(kRectumShape, {0.0, 0.0, 0.0}, size[kRectum]);
  const Vec rectosigmoid = regions[kRectum].back();
  // A short sigmoid brings the descending colon's start down toward the
  // rectum: its chord at most 3/4 of its length.
  Vec junction = Add(kSigmoidDescendingJunction, d.junction_shift);
  const double chord_m = Distance(rectosigmoid, junction);
  const double max_chord_m = 0.75 * d.length_m[kSigmoid];
  if (chord_m > max_chord_m) junction = Lerp(rectosigmoid, junction, max_chord_m / chord_m);
  regions[kSigmoid] = LoopBetween(d.redundant_sigmoid ? kRedundantSigmoidShape : kSigmoidShape,
                                  rectosigmoid, junction, Scale(d.sigmoid_shape, size[kSigmoid]));
  regions[kDescending] = StretchedFrom(kDescendingShape, junction, size[kDescending]);
  if (d.descending_medial_m > 0.0) {
    // A persistent descending mesocolon lets the colon lie toward the midline (+x).
    const auto u = ArcFractions(regions[kDescending]);
    for (size_t i = 0; i < u.size(); ++i) {
      regions[kDescending][i][0] += d.descending_medial_m * std::sin(std::numbers::pi * u[i]);
    }
  }
  regions[kSplenic] = ScaledFrom(kSplenicShape, regions[kDescending].back(), size[kSplenic]);
  const Vec splenic_end = regions[kSplenic].back();
  // The hepatic flexure below the splenic, high enough that the ascending
  // colon and cecum stay out of the pelvis.
  const double hepatic_z_m = std::max(splenic_end[2] - d.hepatic_drop_m,
                                      0.20 + d.length_m[kAscending] + d.length_m[kCecum]);
  const Vec hepatic_start = {kHepaticFlexureX_m, kHepaticFlexureY_m, hepatic_z_m};
  // The sag deepens with the size; it comes forward less.
  const double k = size[kTransverse];
  regions[kTransverse] = LoopBetween(
      kTransverseShape, splenic_end, hepatic_start,
      {d.transverse_shape[0], d.transverse_shape[1] * (0.7 + 0.3 * k), d.transverse_shape[2] * k});
  regions[kHepatic] = ScaledFrom(kHepaticShape, hepatic_start, size[kHepatic]);
  regions[kAscending] = StretchedFrom(kAscendingShape, regions[kHepatic].back(), size[kAscending]);
  regions[kCecum] = ScaledFrom(kCecumShape, regions[kAscending].back(), size[kCecum]);
  return regions;
}

// Centripetal Catmull-Rom through `points` (ends extended linearly),
// `kSamplesPerSpan` samples per span; sample i * kSamplesPerSpan is point i.
std::vector<Vec> SmoothCurve(const std::vector<Vec>& points) {
  std::vector<Vec> pts;
  pts.push_back(Sub(Scale(points[0], 2.0), points[1]));
  pts.insert(pts.end(), points.begin(), points.end());
  pts.push_back(Sub(Scale(points.back(), 2.0), points[points.size() - 2]));
  std::vector<Vec> out = {points[0]};
  for (size_t i = 1; i + 2 < pts.size(); ++i) {
    const Vec& p0 = pts[i - 1];
    const Vec& p1 = pts[i];
    const Vec& p2 = pts[i + 1];
    const Vec& p3 = pts[i + 2];
    const double t0 = 0.0;
    const double t1 = t0 + std::sqrt(Distance(p0, p1));
    const double t2 = t1 + std::sqrt(Distance(p1, p2));
    const double t3 = t2 + std::sqrt(Distance(p2, p3));
    const auto lerp = [](const Vec& a, const Vec& b, double ta, double tb, double t) {
      return Lerp(a, b, (t - ta) / (tb - ta));
    };
    for (int k = 1; k <= kSamplesPerSpan; ++k) {
      const double t = t1 + (t2 - t1) * k / kSamplesPerSpan;
      const Vec a1 = lerp(p0, p1, t0, t1, t);
      const Vec a2 = lerp(p1, p2, t1, t2, t);
      const Vec a3 = lerp(p2, p3, t2, t3, t);
      const Vec b1 = lerp(a1, a2, t0, t2, t);
      const Vec b2 = lerp(a2, a3, t1, t3, t);
      out.push_back(k == kSamplesPerSpan ? p2 : lerp(b1, b2, t1, t2, t));
    }
  }
  return out;
}

// `curve` resampled at equal arc steps of about kControlPointStep_m, ends kept.
std::vector<Vec> Resample(const std::vector<Vec>& curve) {
  std::vector<double> arcs = {0.0};
  for (size_t i = 1; i < curve.size(); ++i)
    arcs.push_back(arcs.back() + Distance(curve[i - 1], curve[i]));
  const int n = std::max(2, static_cast<int>(std::lround(arcs.back() / kControlPointStep_m)));
  std::vector<Vec> out;
  size_t j = 0;
  for (int k = 0; k <= n; ++k) {
    const double s = arcs.back() * k / n;
    while (j + 2 < arcs.size() && arcs[j + 1] < s) ++j;
    const double span = arcs[j + 1] - arcs[j];
    const double w = span > 0.0 ? std::clamp((s - arcs[j]) / span, 0.0, 1.0) : 0.0;
    out.push_back(k == n ? curve.back() : Lerp(curve[j], curve[j + 1], w));
  }
  return out;
}

double RoundTo(double value, double step) { return std::round(value / step) * step; }

// The control points of each region (the first of each the last of the one
// before), rounded to 0.1 mm, from one smooth curve through all waypoints.
std::vector<std::vector<Vec>> ControlPoints(const Draw& d,
                                            const std::array<double, kRegionCount>& size) {
  const auto waypoints = Waypoints(d, size);
  std::vector<Vec> all;
  std::vector<size_t> first_waypoint;
  for (const auto& region : waypoints) {
    first_waypoint.push_back(all.empty() ? 0 : all.size() - 1);
    all.insert(all.end(), all.empty() ? region.begin() : region.begin() + 1, region.end());
  }
  first_waypoint.push_back(all.size() - 1);
  const auto curve = SmoothCurve(all);
  std::vector<std::vector<Vec>> regions;
  for (int r = 0; r < kRegionCount; ++r) {
    const std::vector<Vec> piece(curve.begin() + first_waypoint[r] * kSamplesPerSpan,
                                 curve.begin() + first_waypoint[r + 1] * kSamplesPerSpan + 1);
    auto points = Resample(piece);
    for (auto& p : points) {
      for (auto& c : p) c = RoundTo(c, 1e-4) + 0.0;  // + 0.0: no "-0" in the file
    }
    regions.push_back(std::move(points));
  }
  return regions;
}

// Size parameters fitted region by region (bisection; each region's length
// also depends a little on its neighbours' waypoints, hence the passes).
std::array<double, kRegionCount> FitSizes(const Draw& d) {
  std::array<double, kRegionCount> size = {1.0, 1.0, 0.23, 1.0, 1.0, 1.0, 0.167, 1.0};
  constexpr std::array<double, kRegionCount> kLo = {0.5, 0.0, 0.05, 0.3, 0.0, 0.3, 0.05, 0.3};
  constexpr std::array<double, kRegionCount> kHi = {2.0, 6.0, 0.5, 3.0, 6.0, 3.0, 0.4, 3.0};
  for (int pass = 0; pass < 3; ++pass) {
    for (int r = 0; r < kRegionCount; ++r) {
      double lo = kLo[r];
      double hi = kHi[r];
      for (int i = 0; i < 40; ++i) {
        size[r] = 0.5 * (lo + hi);
        const double length_m = PolylineLength(ControlPoints(d, size)[r]);
        (length_m < d.length_m[r] ? lo : hi) = size[r];
      }
      size[r] = 0.5 * (lo + hi);
    }
  }
  return size;
}

std::string Format(const char* format, double value) {
  char text[64];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

// The case for fitted control points; nullopt when a region missed its drawn
// length.
std::optional<ves::v1::ColonCase> BuildCase(const Draw& d,
                                            const std::vector<std::vector<Vec>>& regions,
                                            std::uint64_t seed,
                                            const ColonGeneratorOptions& options) {
  ves::v1::ColonCase c;
  c.set_id(options.id.empty() ? "generated-" + std::to_string(seed) : options.id);
  c.set_title("Generated colon, seed " + std::to_string(seed));
  c.set_version(1);
  std::vector<double> start_m = {0.0};
  for (int r = 0; r < kRegionCount; ++r) {
    for (size_t i = r == 0 ? 0 : 1; i < regions[r].size(); ++i) {
      auto* point = c.add_centerline();
      point->set_x_m(regions[r][i][0]);
      point->set_y_m(regions[r][i][1]);
      point->set_z_m(regions[r][i][2]);
    }
    start_m.push_back(CalcCenterlineLength_m(c));
  }
  for (int r = 0; r < kRegionCount; ++r) {
    const double length_m = start_m[r + 1] - start_m[r];
    if (std::abs(length_m - d.length_m[r]) > kLengthTolerance_m ||
        length_m < kLengthRanges[r].min_m || length_m > kLengthRanges[r].max_m) {
      return std::nullopt;
    }
  }
  const double total_m = start_m.back();
  // Radius: the anal canal widening into the rectum, then each region's
  // radius over its middle half, linear between.
  auto add_radius = [&c](double arc_m, double radius_m) {
    auto* sample = c.add_radius_profile();
    sample->set_arc_m(RoundTo(arc_m, 1e-6));
    sample->set_radius_m(RoundTo(radius_m, 1e-4));
  };
  add_radius(0.0, kAnalCanalRadius_m);
  for (int r = 0; r < kRegionCount; ++r) {
    const double quarter_m = 0.25 * (start_m[r + 1] - start_m[r]);
    const double radius_m = kRadius_m[r] * d.radius_scale;
    add_radius(r == kRectum ? std::max(quarter_m, kAnalCanalLength_m) : start_m[r] + quarter_m,
               radius_m);
    add_radius(start_m[r + 1] - quarter_m, radius_m);
  }
  add_radius(total_m, kRadius_m[kCecum] * d.radius_scale);
  for (int r = 0; r < kRegionCount; ++r) {
    auto* span = c.add_regions();
    span->set_region(kRegionOrder[r]);
    span->set_start_arc_m(RoundTo(start_m[r], 1e-6));
    span->set_end_arc_m(r + 1 == kRegionCount ? total_m : RoundTo(start_m[r + 1], 1e-6));
    auto* tissue = span->mutable_tissue();
    *tissue = DefaultTissue(kRegionOrder[r]);
    if (r == kSigmoid) tissue->set_mesentery_length_m(RoundTo(d.sigmoid_mesocolon_m, 1e-3));
    if (r == kTransverse) tissue->set_mesentery_length_m(RoundTo(d.transverse_mesocolon_m, 1e-3));
    if (r == kDescending && d.mobile_descending) {
      // A persistent descending mesocolon: hung like the sigmoid.
      const auto mobile = DefaultTissue(ves::v1::REGION_SIGMOID);
      tissue->set_suspension_stiffness_n_per_m2(mobile.suspension_stiffness_n_per_m2());
      tissue->set_suspension_damping_n_s_per_m2(mobile.suspension_damping_n_s_per_m2());
      tissue->set_mobility(ves::v1::MOBILITY_MOBILE);
      tissue->set_mesentery_length_m(RoundTo(d.descending_mesocolon_m, 1e-3));
    }
  }
  const bool hard = d.redundant_sigmoid || d.mobile_descending || total_m >= 1.75;
  c.set_difficulty(hard ? ves::v1::DIFFICULTY_HARD : ves::v1::DIFFICULTY_MEDIUM);
  std::string description = "Generated colon, " + Format("%.3f m", total_m) + ": sigmoid " +
                            Format("%.3f m", d.length_m[kSigmoid]) +
                            (d.redundant_sigmoid ? " (redundant)" : "") + ", transverse " +
                            Format("%.3f m", d.length_m[kTransverse]) + ", descending colon " +
                            (d.mobile_descending ? "mobile (persistent mesocolon)" : "fixed") + ".";
  c.set_description(description);
  auto* provenance = c.mutable_provenance();
  provenance->set_source("synthetic (ves case generator)");
  provenance->set_institution("VES project");
  provenance->set_notes("GenerateColonCase seed " + std::to_string(seed) +
                        "; distributions and sources in docs/case-generator.md.");
  return c;
}

}  // namespace

const std::array<GeneratedLengthRange, 8>& GeneratedLengthRanges() { return kLengthRanges; }

ves::v1::ColonCase GenerateColonCase(std::uint64_t seed, const ColonGeneratorOptions& options) {
  if (!options.id.empty()) {
    // A bad id would fail every draw's validation: said once, here.
    ves::v1::ColonCase named;
    named.set_id(options.id);
    for (const auto& problem : ValidateCase(named, "generated")) {
      if (problem.field == "id") throw CaseError({problem});
    }
  }
  Rng rng(seed);
  for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
    const Draw d = DrawColon(rng, options);
    double total_m = 0.0;
    for (double length_m : d.length_m) total_m += length_m;
    if (total_m < kGeneratedMinLength_m || total_m > kGeneratedMaxLength_m) continue;
    const auto size = FitSizes(d);
    auto c = BuildCase(d, ControlPoints(d, size), seed, options);
    // A draw whose tube touches itself (or misses a length) is drawn again.
    if (c && ValidateCase(*c, "generated").empty()) return *std::move(c);
  }
  throw CaseError("generated", "seed", -1, std::to_string(seed),
                  "no valid colon in " + std::to_string(kMaxAttempts) + " draws");
}

}  // namespace ves::patient_db
