#!/usr/bin/env bash
# Configures and builds VES into ${VES_BUILD_DIR:-build} with -j2.
# Usage: deploy/build.sh [extra cmake -D options]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${VES_BUILD_DIR:-$root/build}"
# ccache (cmake/VesOptions.cmake) keyed on paths relative to the checkout, so
# a fresh clone in another folder reuses the objects of an earlier build.
export CCACHE_BASEDIR="$root" CCACHE_NOHASHDIR=1
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@" >/dev/null
cmake --build "$build" -j "${VES_JOBS:-2}"
