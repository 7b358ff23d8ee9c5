#!/usr/bin/env bash
# Runs the libFuzzer targets (docs/fuzzing.md).
# Usage: deploy/fuzz.sh [--seconds S] [--build-dir DIR] [--corpus-dir DIR] [TARGET...]
#   Builds the targets with clang-14 (-DVES_FUZZ=ON: ASan + UBSan) into DIR
#   (default build-fuzz), seeds each corpus from the project's data
#   (ves_fuzz_seeds) and from tests/fuzz/regressions/<target>, and runs each
#   target for S seconds (default 60), VES_JOBS of them at a time (default 1).
#   A crash leaves its input in DIR/crashes/<target>/ and makes the script
#   exit 1; copy it into tests/fuzz/regressions/<target>/ once fixed.
#   Targets: csv markups textproto bundle session_file input_log can_frame
#   journal
#   (default: all).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
seconds=60
build="$root/build-fuzz"
corpus_root=""
targets=()
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds) seconds="$2"; shift 2 ;;
    --build-dir) build="$2"; shift 2 ;;
    --corpus-dir) corpus_root="$2"; shift 2 ;;
    -h|--help) sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "fuzz.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) targets+=("$1"); shift ;;
  esac
done
all=(csv markups textproto bundle session_file input_log can_frame journal)
[ ${#targets[@]} -eq 0 ] && targets=("${all[@]}")
for t in "${targets[@]}"; do
  [[ " ${all[*]} " == *" $t "* ]] || { echo "fuzz.sh: unknown target '$t' (${all[*]})" >&2; exit 2; }
done
[[ "$seconds" =~ ^[0-9]+$ ]] && [ "$seconds" -ge 1 ] || {
  echo "fuzz.sh: --seconds '$seconds' must be a whole number >= 1" >&2; exit 2; }
corpus_root="${corpus_root:-$build/corpus}"

export CCACHE_BASEDIR="$root" CCACHE_NOHASHDIR=1
if [ ! -f "$build/CMakeCache.txt" ]; then
  CC=clang-14 CXX=clang++-14 cmake -S "$root" -B "$build" -G Ninja \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVES_FUZZ=ON -DVES_BUILD_BENCH=OFF >/dev/null
fi
cmake --build "$build" -j "${VES_JOBS:-2}" --target ves_fuzz_seeds \
  $(printf 'fuzz_%s ' "${targets[@]}") >/dev/null

# One target's run; its report goes to $build/fuzz-$t.result (read back in
# the targets' order below, so reports do not interleave).
run_target() {
  local t="$1" corpus="$corpus_root/$1" crashes="$build/crashes/$1"
  local result="$build/fuzz-$1.result"
  mkdir -p "$corpus" "$crashes"
  "$build/tests/fuzz/ves_fuzz_seeds" "$t" "$corpus"
  local seed_dirs=("$corpus")
  [ -d "$root/tests/fuzz/regressions/$t" ] && seed_dirs+=("$root/tests/fuzz/regressions/$t")
  echo "fuzz.sh: $t for ${seconds}s (corpus $corpus)"
  # -max_len bounds one input (and so what a decoder may allocate for it);
  # -rss_limit_mb makes a memory blow-up a finding, not an OOM kill.
  if ! "$build/tests/fuzz/fuzz_$t" -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=2048 \
       -timeout=10 -print_final_stats=1 -artifact_prefix="$crashes/" "${seed_dirs[@]}" \
       >"$build/fuzz-$t.log" 2>&1; then
    { echo "FAILED"
      echo "fuzz.sh: $t FAILED: $(grep -m1 -E 'ERROR|Sanitizer|deadly|property broken' \
        "$build/fuzz-$t.log" || tail -n 1 "$build/fuzz-$t.log")"
      echo "fuzz.sh:   input: $(ls -t "$crashes" | head -n 1), log: $build/fuzz-$t.log"
    } >"$result"
  else
    { echo "ok"
      echo "fuzz.sh: $t ok: $(grep -E '^stat::number_of_executed_units' "$build/fuzz-$t.log" \
        | awk '{print $2}') runs, corpus $(ls "$corpus" | wc -l) inputs"
    } >"$result"
  fi
}

# VES_JOBS targets at a time (each libFuzzer run is one process on one core):
# on CI's two cores the eight targets take four rounds of S seconds, not eight.
at_once="${VES_JOBS:-1}"
[[ "$at_once" =~ ^[0-9]+$ ]] && [ "$at_once" -ge 1 ] || at_once=1
running=0
for t in "${targets[@]}"; do
  rm -f "$build/fuzz-$t.result"
  if [ "$running" -ge "$at_once" ]; then
    wait -n || true
    running=$((running - 1))
  fi
  run_target "$t" &
  running=$((running + 1))
done
wait || true

failed=0
for t in "${targets[@]}"; do
  result="$build/fuzz-$t.result"
  if [ ! -f "$result" ]; then
    echo "fuzz.sh: $t FAILED: the run left no report (log: $build/fuzz-$t.log)" >&2
    failed=1
  elif [ "$(head -n 1 "$result")" = ok ]; then
    tail -n +2 "$result"
  else
    tail -n +2 "$result" >&2
    failed=1
  fi
done
exit $failed
