#!/usr/bin/env python3
"""Authoring aid for the shipped synthetic colon cases (docs/case-format.md).

Draws each case's centerline as a centripetal Catmull-Rom curve through
hand-placed anatomical waypoints (drawn with +x toward the patient's left and
written out with x negated into the patient frame W: origin at the anus, +x the
patient's right (RAS), +y anterior, +z cranial; metres), resamples every region at
about 2.5 cm and writes the textproto. Tissue values are the defaults of
patient_db/case_regions.cc. Run once to create the files:

    python3 patient_db/cases/generate_cases.py --print-lengths       # inspect
    python3 patient_db/cases/generate_cases.py --write CASE...        # create

The shipped .textproto files are the truth afterwards (others tune them by
hand), so --write refuses to overwrite an existing file unless --force.
"""
import argparse
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
STEP_M = 0.025

# Lumen radius per region (m), from insufflated CT colonography diameters.
RADIUS_M = {
    "rectum": 0.022, "sigmoid": 0.016, "descending": 0.018, "splenic-flexure": 0.020,
    "transverse": 0.024, "hepatic-flexure": 0.025, "ascending": 0.027, "cecum": 0.032,
}
ANAL_CANAL_RADIUS_M = 0.013  # entry, widening into the rectal ampulla over ~4 cm
FIXED = dict(K_c=20000.0, D_c=200.0)
MOBILE = dict(K_c=300.0, D_c=10.0)
VERY_MOBILE = dict(K_c=150.0, D_c=6.0)
ENUM = {
    "rectum": "REGION_RECTUM", "sigmoid": "REGION_SIGMOID", "descending": "REGION_DESCENDING",
    "splenic-flexure": "REGION_SPLENIC_FLEXURE", "transverse": "REGION_TRANSVERSE",
    "hepatic-flexure": "REGION_HEPATIC_FLEXURE", "ascending": "REGION_ASCENDING",
    "cecum": "REGION_CECUM",
}

# Waypoints per region; each region starts where the previous one ends.
RECTUM = [(0.0, 0.0, 0.0), (0.0, -0.012, 0.028), (0.0, -0.028, 0.055), (0.001, -0.040, 0.080),
          (0.003, -0.044, 0.103), (0.005, -0.040, 0.125)]
SIGMOID = [(0.005, -0.040, 0.125), (-0.008, -0.022, 0.145), (-0.027, -0.001, 0.160),
           (-0.042, 0.024, 0.172), (-0.047, 0.052, 0.188), (-0.040, 0.076, 0.208),
           (-0.018, 0.088, 0.225), (0.010, 0.089, 0.233), (0.040, 0.080, 0.233),
           (0.066, 0.060, 0.226), (0.086, 0.034, 0.217), (0.098, 0.008, 0.210),
           (0.106, -0.018, 0.212), (0.112, -0.035, 0.225)]
DESCENDING = [(0.112, -0.035, 0.225), (0.118, -0.042, 0.280), (0.124, -0.045, 0.340),
              (0.128, -0.043, 0.400), (0.128, -0.038, 0.455)]
SPLENIC = [(0.128, -0.038, 0.455), (0.124, -0.024, 0.485), (0.110, -0.004, 0.497),
           (0.097, 0.016, 0.488)]
TRANSVERSE = [(0.097, 0.016, 0.488), (0.090, 0.040, 0.462), (0.080, 0.062, 0.428),
              (0.066, 0.082, 0.392), (0.048, 0.097, 0.356), (0.026, 0.106, 0.325),
              (0.000, 0.110, 0.308), (-0.026, 0.108, 0.306), (-0.052, 0.102, 0.318),
              (-0.074, 0.092, 0.340), (-0.092, 0.078, 0.366), (-0.106, 0.060, 0.392),
              (-0.114, 0.040, 0.414), (-0.118, 0.020, 0.428)]
HEPATIC = [(-0.118, 0.020, 0.428), (-0.124, 0.000, 0.434), (-0.128, -0.018, 0.425),
           (-0.128, -0.026, 0.405)]
ASCENDING = [(-0.128, -0.026, 0.405), (-0.126, -0.028, 0.365), (-0.122, -0.026, 0.320),
             (-0.118, -0.022, 0.278), (-0.114, -0.016, 0.238)]
CECUM = [(-0.114, -0.016, 0.238), (-0.112, -0.008, 0.210), (-0.110, 0.004, 0.185)]

# Redundant sigmoid: ~65 cm, rising out of the pelvis, coming back down and
# swinging across in front of its own start (the loop an alpha loop forms on).
REDUNDANT_SIGMOID = [(0.005, -0.040, 0.125), (-0.010, -0.026, 0.158), (-0.032, -0.010, 0.180),
                     (-0.052, 0.015, 0.198), (-0.060, 0.045, 0.215), (-0.052, 0.072, 0.235),
                     (-0.030, 0.088, 0.250), (0.000, 0.095, 0.256), (0.030, 0.092, 0.250),
                     (0.052, 0.082, 0.235), (0.056, 0.070, 0.212), (0.040, 0.062, 0.192),
                     (0.015, 0.062, 0.174), (-0.005, 0.075, 0.155), (0.000, 0.095, 0.135),
                     (0.030, 0.105, 0.125), (0.062, 0.095, 0.135), (0.088, 0.072, 0.155),
                     (0.104, 0.042, 0.175), (0.112, 0.010, 0.195), (0.114, -0.018, 0.208),
                     (0.112, -0.035, 0.225)]

# A long sigmoid (0.537 m against the standard 0.396 m; its loop drawn 1.2 times
# as far from its chord as in version 1, which had 0.462 m) and a longer, low
# transverse (0.465 m against 0.448 m; --print-lengths) for the case whose
# descending colon keeps a mesentery (a persistent descending mesocolon). With
# them the cecum lies 1.70 m along the colon, beyond the 1.68 m scope, so a push
# without reductions cannot reach it (docs/case-format.md).
LONG_SIGMOID = [(0.005, -0.040, 0.125), (-0.016, -0.016, 0.154), (-0.043, 0.010, 0.174),
                (-0.066, 0.044, 0.189), (-0.078, 0.082, 0.208), (-0.069, 0.116, 0.229),
                (-0.040, 0.135, 0.244), (-0.002, 0.139, 0.249), (0.038, 0.130, 0.243),
                (0.072, 0.106, 0.231), (0.095, 0.073, 0.218), (0.108, 0.037, 0.209),
                (0.112, 0.001, 0.206), (0.112, -0.035, 0.225)]
LONG_TRANSVERSE = [(0.097, 0.016, 0.488), (0.090, 0.042, 0.458), (0.079, 0.066, 0.420),
                   (0.064, 0.088, 0.380), (0.044, 0.105, 0.342), (0.020, 0.116, 0.312),
                   (-0.006, 0.120, 0.298), (-0.032, 0.116, 0.302), (-0.056, 0.107, 0.320),
                   (-0.077, 0.094, 0.346), (-0.095, 0.077, 0.372), (-0.108, 0.058, 0.396),
                   (-0.116, 0.038, 0.414), (-0.118, 0.020, 0.428)]

STANDARD = [("rectum", RECTUM), ("sigmoid", SIGMOID), ("descending", DESCENDING),
            ("splenic-flexure", SPLENIC), ("transverse", TRANSVERSE),
            ("hepatic-flexure", HEPATIC), ("ascending", ASCENDING), ("cecum", CECUM)]


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def dist(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


def catmull_rom(points, per_span=40):
    """Centripetal Catmull-Rom through all points (ends extended linearly)."""
    pts = [tuple(2 * a - b for a, b in zip(points[0], points[1]))] + list(points)
    pts.append(tuple(2 * a - b for a, b in zip(points[-1], points[-2])))
    out = [points[0]]
    for i in range(1, len(pts) - 2):
        p0, p1, p2, p3 = pts[i - 1], pts[i], pts[i + 1], pts[i + 2]
        t0 = 0.0
        t1 = t0 + dist(p0, p1) ** 0.5
        t2 = t1 + dist(p1, p2) ** 0.5
        t3 = t2 + dist(p2, p3) ** 0.5
        for k in range(1, per_span + 1):
            t = t1 + (t2 - t1) * k / per_span

            def lerp(pa, pb, ta, tb):
                w = (t - ta) / (tb - ta)
                return tuple((1 - w) * a + w * b for a, b in zip(pa, pb))
            a1, a2, a3 = lerp(p0, p1, t0, t1), lerp(p1, p2, t1, t2), lerp(p2, p3, t2, t3)
            b1, b2 = lerp(a1, a2, t0, t2), lerp(a2, a3, t1, t3)
            out.append(lerp(b1, b2, t1, t2))
    return out


def resample(curve, step):
    arcs = [0.0]
    for a, b in zip(curve, curve[1:]):
        arcs.append(arcs[-1] + dist(a, b))
    n = max(1, round(arcs[-1] / step))
    out, j = [], 0
    for k in range(n + 1):
        s = arcs[-1] * k / n
        while j + 1 < len(arcs) - 1 and arcs[j + 1] < s:
            j += 1
        w = 0.0 if arcs[j + 1] == arcs[j] else (s - arcs[j]) / (arcs[j + 1] - arcs[j])
        w = min(max(w, 0.0), 1.0)
        out.append(tuple((1 - w) * a + w * b for a, b in zip(curve[j], curve[j + 1])))
    return out


def build(regions, truncate_last_m=None):
    """Smooth whole path, cut at the region waypoints, resample each region."""
    waypoints, bounds = [], []
    for name, pts in regions:
        if waypoints:
            pts = pts[1:]
        bounds.append(len(waypoints) + (0 if not waypoints else -1))
        waypoints.extend(pts)
    per_span = 40
    curve = catmull_rom(waypoints, per_span)
    points, spans = [], []
    cut = [b * per_span for b in bounds] + [len(curve) - 1]
    for r, (name, _) in enumerate(regions):
        piece = curve[cut[r]:cut[r + 1] + 1]
        if truncate_last_m is not None and r == len(regions) - 1:
            acc, keep = 0.0, [piece[0]]
            for a, b in zip(piece, piece[1:]):
                acc += dist(a, b)
                keep.append(b)
                if acc >= truncate_last_m:
                    break
            piece = keep
        res = resample(piece, STEP_M)
        res = [tuple(round(c, 4) for c in p) for p in res]
        start = len(points) - 1 if points else 0
        points.extend(res if not points else res[1:])
        spans.append((name, start, len(points) - 1))
    arcs = [0.0]
    for a, b in zip(points, points[1:]):
        arcs.append(arcs[-1] + dist(a, b))
    return points, arcs, [(name, arcs[i], arcs[j]) for name, i, j in spans]


def radius_profile(spans):
    samples = [(0.0, ANAL_CANAL_RADIUS_M)]
    for name, s0, s1 in spans:
        r = RADIUS_M[name]
        a, b = s0 + 0.25 * (s1 - s0), s1 - 0.25 * (s1 - s0)
        if name == "rectum":
            a = max(a, 0.04)
        samples += [(a, r), (b, r)]
    last = spans[-1]
    samples.append((last[2], RADIUS_M[last[0]]))
    return samples


def radius_at(profile, s):
    if s <= profile[0][0]:
        return profile[0][1]
    for (a, ra), (b, rb) in zip(profile, profile[1:]):
        if s <= b:
            return ra + (rb - ra) * (s - a) / (b - a)
    return profile[-1][1]


def self_proximity(points, arcs, profile):
    """Same rule as ValidateCase: far apart in arc, closer than r_i + r_j."""
    samples = []
    for i in range(len(points) - 1):
        n = max(1, math.ceil((arcs[i + 1] - arcs[i]) / 0.005))
        for k in range(n):
            w = k / n
            p = tuple((1 - w) * a + w * b for a, b in zip(points[i], points[i + 1]))
            s = arcs[i] + w * (arcs[i + 1] - arcs[i])
            samples.append((p, s, radius_at(profile, s)))
    worst = (float("inf"), None)
    for i, (pi, si, ri) in enumerate(samples):
        for pj, sj, rj in samples[i + 1:]:
            if sj - si <= math.pi / 2 * (ri + rj):
                continue
            margin = dist(pi, pj) - (ri + rj)
            if margin < worst[0]:
                worst = (margin, (round(si, 3), round(sj, 3)))
    return worst


def tissue_text(name, mobility):
    """mobility: "fixed", "mobile" or "very" (the region's name decides whether it
    hangs on a mesentery), or "fixed!"/"mobile!" to say so explicitly."""
    explicit = mobility.endswith("!")
    mobility = mobility.rstrip("!")
    k = FIXED if mobility == "fixed" else (VERY_MOBILE if mobility == "very" else MOBILE)
    text = (f"    suspension_stiffness_N_per_m2: {k['K_c']:g}\n"
            f"    suspension_damping_N_s_per_m2: {k['D_c']:g}\n"
            "    wall_stiffness_N_per_m: 400\n"
            "    wall_damping_N_s_per_m: 4\n"
            "    deformation_threshold_m: 0.004\n"
            "    static_friction: 0.15\n"
            "    dynamic_friction: 0.10\n"
            "    neighbor_tension_N: 2\n")
    if explicit:
        text += f"    mobility: MOBILITY_{'FIXED' if mobility == 'fixed' else 'MOBILE'}\n"
    return text


def case_text(spec, points, arcs, spans, profile):
    lines = ["# proto-file: ves/v1/case.proto", "# proto-message: ves.v1.ColonCase",
             "# Synthetic case; units metres, patient frame W (docs/case-format.md).",
             "# Region lengths (m): " + ", ".join(f"{n} {e - s:.3f}" for n, s, e in spans)
             + f"; total {arcs[-1]:.3f}.", "",
             f'id: "{spec["id"]}"', f'title: "{spec["title"]}"',
             f"version: {spec.get('version', 1)}",
             f"difficulty: {spec['difficulty']}",
             f'description: "{spec["description"]}"',
             "provenance {", '  source: "synthetic"', "  year: 2026",
             '  institution: "VES project"',
             f'  notes: "{spec["notes"]}"', "}", ""]
    for i, p in enumerate(points):
        lines.append(f"centerline {{ x_m: {-p[0] + 0.0:.4f} y_m: {p[1]:.4f} z_m: {p[2]:.4f} }}"
                     f"  # {i}, s = {arcs[i]:.3f}")
    lines.append("")
    for s, r in profile:
        lines.append(f"radius_profile {{ arc_m: {s:.6f} radius_m: {r:.4f} }}")
    lines.append("")
    for name, s0, s1 in spans:
        mobility = spec["mobility"](name)
        lines += ["regions {", f"  region: {ENUM[name]}", f"  start_arc_m: {s0:.6f}",
                  f"  end_arc_m: {s1:.6f}", "  tissue {", tissue_text(name, mobility).rstrip("\n"),
                  "  }", "}"]
    return "\n".join(lines) + "\n"


def standard_mobility(name):
    return "mobile" if name in ("sigmoid", "transverse") else "fixed"


CASES = {
    "paper-sigmoid": dict(
        regions=[("rectum", RECTUM), ("sigmoid", SIGMOID), ("descending", DESCENDING)],
        truncate_last_m=0.08, id="paper-sigmoid", title="Mobile sigmoid (paper Fig. 10)",
        difficulty="DIFFICULTY_MEDIUM", mobility=standard_mobility,
        description="Rectum, mobile sigmoid and the start of the descending colon: the "
                    "hypothetical intestine of the paper's Fig. 10, where constant-force "
                    "insertion stretches the sigmoid upward (+y).",
        notes="Synthetic; the first 0.6 m of standard-adult."),
    "standard-adult": dict(
        regions=STANDARD, id="standard-adult", title="Standard adult colon",
        difficulty="DIFFICULTY_MEDIUM", mobility=standard_mobility,
        description="Rectum to cecum, about 1.5 m, published adult segment lengths; "
                    "mobile sigmoid and transverse colon, the rest fixed.",
        notes="Synthetic; dimensions from published adult series, see docs/case-format.md."),
    "redundant-sigmoid": dict(
        regions=[STANDARD[0], ("sigmoid", REDUNDANT_SIGMOID)] + STANDARD[2:],
        id="redundant-sigmoid", title="Redundant sigmoid colon",
        difficulty="DIFFICULTY_HARD",
        mobility=lambda n: "very" if n == "sigmoid" else standard_mobility(n),
        description="Standard adult colon with a long (about 0.65 m), very mobile sigmoid "
                    "that rises out of the pelvis and loops in front of its own start: "
                    "loop-prone, the hard case.",
        notes="Synthetic; redundant sigmoid as described in colonoscopy series, see "
              "docs/case-format.md."),
    "mobile-descending": dict(
        regions=[STANDARD[0], ("sigmoid", LONG_SIGMOID)] + STANDARD[2:4] +
                [("transverse", LONG_TRANSVERSE)] + STANDARD[5:],
        id="mobile-descending", title="Long colon with a mobile descending colon",
        version=2,
        difficulty="DIFFICULTY_HARD",
        mobility=lambda n: "mobile!" if n == "descending" else standard_mobility(n),
        description="A long sigmoid and a long, low transverse colon, and a descending colon "
                    "that keeps its mesentery (a persistent descending mesocolon): the "
                    "sigmoid loop can reach up the left side, and the scope has no fixed "
                    "colon to hook until the splenic flexure.",
        notes="Synthetic; persistent descending mesocolon in 15-36 % of adults, see "
              "docs/case-format.md."),
    "fixed-tube": dict(
        regions=STANDARD, id="fixed-tube", title="Fixed tube (older rigid model)",
        difficulty="DIFFICULTY_EASY", mobility=lambda n: "fixed!",
        description="The path of standard-adult with every suspension stiff: the older "
                    "fixed-tube model the paper compares against.",
        notes="Synthetic; same geometry as standard-adult."),
}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--print-lengths", action="store_true")
    parser.add_argument("--write", nargs="*", default=None)
    parser.add_argument("--force", action="store_true")
    args = parser.parse_args()
    for name, spec in CASES.items():
        points, arcs, spans = build(spec["regions"], spec.get("truncate_last_m"))
        profile = radius_profile(spans)
        if args.print_lengths:
            margin, where = self_proximity(points, arcs, profile)
            print(f"{name}: {len(points)} points, total {arcs[-1]:.3f} m, "
                  f"closest non-neighbour margin {margin * 1000:.1f} mm at {where}")
            for n, s0, s1 in spans:
                print(f"   {n:16s} {s1 - s0:.3f} m  [{s0:.3f}, {s1:.3f}]")
        if args.write is not None and (not args.write or name in args.write):
            path = os.path.join(HERE, name + ".textproto")
            if os.path.exists(path) and not args.force:
                print(f"{path} exists; not overwriting (use --force)", file=sys.stderr)
                continue
            with open(path, "w") as f:
                f.write(case_text(spec, points, arcs, spans, profile))
            print("wrote", path)


if __name__ == "__main__":
    main()
