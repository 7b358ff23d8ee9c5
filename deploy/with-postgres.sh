#!/usr/bin/env bash
# with-postgres.sh COMMAND [ARGS...]
# Runs COMMAND beside a throwaway PostgreSQL cluster: initdb in a temporary
# directory (as a non-root user: the `postgres` system user when run as root),
# listening on 127.0.0.1 only, on a free port, with synchronous_commit=on. The
# command sees
#   VES_TEST_POSTGRES_URL=postgresql://ves_test@127.0.0.1:PORT/ves_test
# and the server's bin directory first on PATH (pg_dump, pg_restore, pgbench).
# The cluster is stopped and its directory removed on exit, even on failure.
# Exit status: COMMAND's, or 3 when no cluster could be started.
set -euo pipefail

if [ $# -eq 0 ]; then
  echo "usage: with-postgres.sh COMMAND [ARGS...]" >&2
  exit 2
fi

bindir="$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -n 1 || true)"
if [ -z "$bindir" ] || [ ! -x "$bindir/initdb" ]; then
  echo "with-postgres: no PostgreSQL server binaries (/usr/lib/postgresql/*/bin/initdb)" >&2
  exit 3
fi

# PostgreSQL refuses to run as root: use a system user for the cluster.
run_as=()
owner="$(id -un)"
if [ "$(id -u)" -eq 0 ]; then
  owner=postgres
  id -u "$owner" >/dev/null 2>&1 || owner=nobody
  run_as=(runuser -u "$owner" --)
fi

dir="$(mktemp -d "${TMPDIR:-/tmp}/ves-pg.XXXXXX")"
chmod 755 "$dir"
[ "$(id -u)" -eq 0 ] && chown "$owner" "$dir"
data="$dir/data"

cleanup() {
  local status=$?
  if [ -f "$data/postmaster.pid" ]; then
    "${run_as[@]}" "$bindir/pg_ctl" -D "$data" -m immediate -w stop >/dev/null 2>&1 || true
  fi
  rm -rf "$dir"
  exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

"${run_as[@]}" "$bindir/initdb" -D "$data" -U ves_test --auth=trust --locale=C -E UTF8 \
  --no-sync >"$dir/initdb.log" 2>&1 || {
  echo "with-postgres: initdb failed:" >&2
  cat "$dir/initdb.log" >&2
  exit 3
}

# A free port: try a few random ones; pg_ctl -w fails when the port is taken.
port=""
for _ in $(seq 1 20); do
  candidate=$((20000 + RANDOM % 40000))
  if "${run_as[@]}" "$bindir/pg_ctl" -D "$data" -l "$dir/server.log" -w -t 30 \
      -o "-c listen_addresses=127.0.0.1 -c port=$candidate -c unix_socket_directories=$dir \
          -c synchronous_commit=on -c fsync=on -c max_connections=300" \
      start >/dev/null 2>&1; then
    port=$candidate
    break
  fi
done
if [ -z "$port" ]; then
  echo "with-postgres: could not start PostgreSQL; server log:" >&2
  tail -n 20 "$dir/server.log" >&2 || true
  exit 3
fi

"$bindir/createdb" -h 127.0.0.1 -p "$port" -U ves_test ves_test
export VES_TEST_POSTGRES_URL="postgresql://ves_test@127.0.0.1:$port/ves_test"
export PATH="$bindir:$PATH"
echo "with-postgres: PostgreSQL $("$bindir/postgres" --version | awk '{print $3}') on" \
  "127.0.0.1:$port (cluster $data)" >&2
set +e
"$@"
status=$?
set -e
exit "$status"
