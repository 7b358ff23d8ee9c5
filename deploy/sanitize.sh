#!/usr/bin/env bash
# deploy/sanitize.sh address|undefined|thread [ctest args...]
# Builds VES with GCC and that sanitizer into build-<sanitizer>/
# (-DVES_SANITIZE=..., docs/fuzzing.md) and runs the tests under it:
#   address    ASan + LeakSanitizer, the whole suite
#   undefined  UBSan, every finding fatal, the whole suite
#   thread     TSan: the haptic loop, render, sync, server, integration and
#              station suites (the threaded parts)
# Suppressions (deploy/sanitizers/*.supp) name third-party libraries only.
# Extra arguments go to ctest (e.g. -R Outbox). Exit status: ctest's.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
sanitizer="${1:-}"
case "$sanitizer" in
  address|undefined|thread) shift ;;
  *) echo "usage: deploy/sanitize.sh address|undefined|thread [ctest args...]" >&2; exit 2 ;;
esac
build="${VES_BUILD_DIR:-$root/build-$sanitizer}"
supp="$root/deploy/sanitizers"
VES_BUILD_DIR="$build" "$root/deploy/build.sh" -DVES_SANITIZE="$sanitizer" -DVES_BUILD_BENCH=OFF

export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=1:strict_string_checks=1:suppressions=$supp/asan.supp"
export LSAN_OPTIONS="suppressions=$supp/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export TSAN_OPTIONS="suppressions=$supp/tsan.supp:halt_on_error=1:second_deadlock_stack=1"
filter=()
[ "$sanitizer" = thread ] && filter=(-L 'haptics|render|sync|server|integration|station')
with_pg=()
if compgen -G "/usr/lib/postgresql/*/bin/initdb" >/dev/null; then
  with_pg=("$root/deploy/with-postgres.sh")
fi
cd "$build"
# (Sanitized builds give every test three times its usual timeout: VesTesting.cmake.)
"${with_pg[@]}" ctest --output-on-failure -j "${VES_JOBS:-2}" "${filter[@]}" "$@"
