#!/usr/bin/env bash
# The hardening stage of CI (.ci/run, after deploy/test.sh; docs/fuzzing.md):
# one clang-14 build with ASan + UBSan (-DVES_FUZZ=ON, build-fuzz/ unless
# VES_FUZZ_BUILD_DIR says otherwise) of the parser, model, haptics and
# training test suites, the fuzz regression test and the fuzz targets; runs
# those suites under the sanitizers, then every fuzz target for
# ${VES_FUZZ_SECONDS:-60} s. Exits non-zero on any failure. Timed at the end.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${VES_FUZZ_BUILD_DIR:-$root/build-fuzz}"
seconds="${VES_FUZZ_SECONDS:-60}"
start=$(date +%s)
"$root/deploy/install-deps.sh"
export CCACHE_BASEDIR="$root" CCACHE_NOHASHDIR=1
if [ ! -f "$build/CMakeCache.txt" ]; then
  CC=clang-14 CXX=clang++-14 cmake -S "$root" -B "$build" -G Ninja \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVES_FUZZ=ON -DVES_BUILD_BENCH=OFF >/dev/null
fi
suites=(case_format_test model_test model_limits_test model_cases_test haptics_test
        training_test lesson_gate_test fuzz_regression_test)
cmake --build "$build" -j "${VES_JOBS:-2}" --target "${suites[@]}"
echo "ci-hardening: sanitized suites built after $(( $(date +%s) - start )) s"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=1"
export LSAN_OPTIONS="suppressions=$root/deploy/sanitizers/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# Only the suites built above carry these labels (the rest are NOT_BUILT
# placeholders without labels); the slow scripted-skill suite stays out.
(cd "$build" && ctest --output-on-failure -j "${VES_JOBS:-2}" \
  -L 'patient_db|model|haptics|training|fuzz' -LE 'slow|postgres')
echo "ci-hardening: sanitized suites passed after $(( $(date +%s) - start )) s"
VES_JOBS="${VES_JOBS:-2}" "$root/deploy/fuzz.sh" --build-dir "$build" --seconds "$seconds" \
  --corpus-dir "$build/ci-corpus"
echo "ci-hardening: done in $(( $(date +%s) - start )) s"
