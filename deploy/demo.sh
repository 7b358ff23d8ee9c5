#!/usr/bin/env bash
# The main job: VES end to end on one machine.
#   deploy/demo.sh [OUTPUT_DIR]
# Installs the dependencies (needs root unless they are present), builds,
# starts ves-server on 127.0.0.1 (a free port) with SQLite in a temporary
# folder, creates an institution, a station and a supervisor token, a trainee
# and the four shipped cases, runs two headless sessions (novice, expert) on
# standard-adult that upload to the server, and prints what a supervisor sees
# (ves-admin scores). Frames, fluoroscopy.png and summary.txt of each session
# stay in OUTPUT_DIR (default: a new folder under /tmp, named at the end).
# Everything it started is stopped on exit, also on failure or Ctrl-C.
# Environment: VES_BUILD_DIR (default build/), VES_DEMO_SECONDS (session time
# limit, default 240), VES_DEMO_SKIP_BUILD=1 (use the binaries already built).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${VES_BUILD_DIR:-$root/build}"
seconds="${VES_DEMO_SECONDS:-240}"
out="${1:-$(mktemp -d /tmp/ves-demo-output.XXXXXX)}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
work="$(mktemp -d /tmp/ves-demo-work.XXXXXX)"
server_pid=""

cleanup() {
  local status=$?
  if [ -n "$server_pid" ] && kill -0 "$server_pid" 2>/dev/null; then
    kill -TERM "$server_pid" 2>/dev/null || true
    wait "$server_pid" 2>/dev/null || true
  fi
  rm -rf "$work"
  if [ $status -ne 0 ]; then echo "demo: FAILED (status $status); output so far in $out" >&2; fi
  exit $status
}
trap cleanup EXIT
trap 'exit 130' INT TERM

step() { printf '\n== %s\n' "$*"; }

step "dependencies"
"$root/deploy/install-deps.sh"

if [ "${VES_DEMO_SKIP_BUILD:-0}" != 1 ]; then
  step "build (into $build)"
  VES_BUILD_DIR="$build" "$root/deploy/build.sh"
fi
station="$build/station/app/ves-station"
server="$build/server/ves-server"
admin="$build/server/ves-admin"
for program in "$station" "$server" "$admin"; do
  [ -x "$program" ] || { echo "demo: $program is missing (build first)" >&2; exit 1; }
done

step "server on 127.0.0.1 (SQLite in $work)"
db="sqlite:$work/ves.db"
admin_token="$("$admin" init --db "$db" --institution demo-hospital --label "demo admin")"
"$server" --listen 127.0.0.1:0 --db "$db" --insecure-loopback --port-file "$work/port" \
  --drain-s 5 --quiet >"$work/server.log" 2>&1 &
server_pid=$!
for _ in $(seq 1 100); do
  [ -s "$work/port" ] && break
  kill -0 "$server_pid" 2>/dev/null || { cat "$work/server.log" >&2; exit 1; }
  sleep 0.1
done
[ -s "$work/port" ] || { echo "demo: ves-server did not start" >&2; exit 1; }
address="127.0.0.1:$(cat "$work/port")"
echo "ves-server listening on $address (pid $server_pid)"

remote() { "$admin" "$@" --server "$address" --token "$admin_token"; }
station_token="$(remote token create --role station --label "demo station" 2>/dev/null)"
supervisor_token="$(remote token create --role supervisor --label "demo supervisor" 2>/dev/null)"
trainee="demo-trainee"
remote trainee add --id "$trainee" --name "Demo Trainee"
for case_file in "$root"/patient_db/cases/*.textproto; do
  remote case upload "$case_file"
done

run_session() {
  local operator=$1 status=0
  step "headless session: $operator operator on standard-adult (simulated device)"
  "$station" run --server "$address" --token "$station_token" --trainee "$trainee" \
    --case standard-adult --device sim --headless --operator "$operator" \
    --out "$out/$operator" --data-dir "$work/station" --station-id demo-station \
    --seconds "$seconds" || status=$?
  # 0: the session ran to its end, whatever its outcome.
  if [ $status -ne 0 ]; then
    echo "demo: ves-station run ($operator) failed with status $status" >&2
    exit 1
  fi
}
run_session novice
run_session expert

step "station outbox"
"$station" status --data-dir "$work/station"

step "what the supervisor sees: ves-admin scores --trainee $trainee"
"$admin" scores --trainee "$trainee" --server "$address" --token "$supervisor_token"

step "output"
echo "frames, fluoroscopy.png and summary.txt of each session are in: $out"
ls "$out"/novice "$out"/expert | sed 's/^/  /'
