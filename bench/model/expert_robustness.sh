#!/bin/bash
# The scripted expert with each of its main settings moved by -20 % and +20 %,
# one at a time, on the full colons it reaches (issue #17: "no single tuned
# point"). One row per run: did it reach the cecum, when, with how much scope
# in, the peak force at the hand, and what it cost the patient.
#   bench/model/expert_robustness.sh [BUILD_DIR] [SECONDS] [key=value ...]
# Further key=value pairs (expert_sweep's keys) go to every run.
# VES_JOBS runs that many at once (default 1). About 15-40 s of CPU per run.
# VES_CASES names the shipped cases (default: standard-adult mobile-descending).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:-$root/build}"
seconds="${2:-600}"
shift $(( $# < 2 ? $# : 2 ))
extra="$*"
sweep="${EXPERT_SWEEP:-$build/bench/model/expert_sweep}"
[[ -x "$sweep" ]] || { echo "expert_sweep not built: cmake --build $build --target expert_sweep" >&2; exit 2; }
# The expert's defaults, from ExpertOperator::Settings as built (settle_s is
# 0, so it has no ±20 % and is not among them).
declare -A base=()
for kv in $("$sweep" --expert-defaults); do base[${kv%%=*}]=${kv#*=}; done
for k in advance withdraw push pull loop_limit roll_rate; do
  [[ -n "${base[$k]:-}" ]] || { echo "expert_sweep --expert-defaults gave no $k" >&2; exit 2; }
done
runs=()
for c in ${VES_CASES:-standard-adult mobile-descending}; do
  runs+=("$root/patient_db/cases/$c.textproto defaults=1 $seconds")
  for k in advance withdraw push pull loop_limit roll_rate; do
    for f in 0.8 1.2; do
      runs+=("$root/patient_db/cases/$c.textproto $k=$(awk -v b="${base[$k]}" -v f="$f" 'BEGIN{printf "%.4g", b*f}') $seconds")
    done
  done
done
printf '%s\n' "${runs[@]}" |
  xargs -P "${VES_JOBS:-1}" -L 1 bash -c \
    '"$0" "$1" expert "$3" "$2" '"$extra"'' \
    "$sweep" 2>&1 |
  sed -n 's/^RESULT //p' | sort |
  awk '{ delete v; setting = ""
         for (i = 1; i <= NF; ++i) {
           split($i, a, "="); v[a[1]] = a[2]
           if (a[1] == "op_turn_from") setting = $(i + 1)  # the first key=value given
         }
         if (setting == "defaults=1") setting = "(defaults)"
         if (!("peak_roll_10ms" in v)) v["peak_roll_10ms"] = "-"
         sub(/\.textproto$/, "", v["case"]); runs++
         if (v["cecum_s"] + 0 >= 0) { reached++; if (v["inserted_at_cecum"] + 0 <= 1.30) short++ }
         if (v["damage"] + 0 == 0) clean++
         printf "%-18s %-18s cecum_s %6s  in_at_cecum %6s  damage %2s  base>10N %6s  peak_N %5s  roll %5s (10 ms %4s)  fixed_mm %4s  pain_s %4s  ring_hold_s %4s\n",
                v["case"], setting, v["cecum_s"], v["inserted_at_cecum"], v["damage"], v["over10"],
                v["peak_force"], v["peak_roll"], v["peak_roll_10ms"], v["fixed_mm"], v["pain"], v["ring_hold_s"] }
       END { printf "the cecum reached in %d of %d runs (%s s each), %d of them with <= 1.30 m in; %d runs without damage\n",
                   reached, runs, '"$seconds"', short, clean }'
