#!/usr/bin/env bash
# The test command: installs dependencies, configures, builds (-j2) and runs
# every test with CTest. Exits non-zero on any failure.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${VES_BUILD_DIR:-$root/build}"
"$root/deploy/install-deps.sh"
VES_BUILD_DIR="$build" "$root/deploy/build.sh" "$@"
cd "$build"
# With PostgreSQL's server installed, the tests also run against a throwaway
# cluster (deploy/with-postgres.sh sets VES_TEST_POSTGRES_URL).
with_pg=()
if compgen -G "/usr/lib/postgresql/*/bin/initdb" >/dev/null; then
  with_pg=("$root/deploy/with-postgres.sh")
fi
"${with_pg[@]}" ctest --output-on-failure -j "${VES_JOBS:-2}" --timeout 600
