#!/usr/bin/env bash
# Installs every build and runtime dependency of VES from Debian's packages.
# Run as root on Debian 12. Idempotent; quiet when everything is present.
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build ccache pkg-config git
  # contracts and RPC
  protobuf-compiler libprotobuf-dev protobuf-compiler-grpc libgrpc++-dev
  # model, I/O, storage
  libeigen3-dev libboost-dev libboost-program-options-dev libsqlite3-dev sqlite3
  libssl-dev openssl zlib1g-dev libspdlog-dev nlohmann-json3-dev
  # PostgreSQL store and its test cluster (deploy/with-postgres.sh)
  libpqxx-dev postgresql postgresql-client
  # views: OpenCV (highgui with Qt), EGL/GLES offscreen through Mesa
  libopencv-dev libx11-dev libegl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri xvfb xauth
  # the station's UI test drives the windows under Xvfb: keys/mouse and screenshots
  xdotool x11-apps
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # the web front end (ves-server --http): Chart.js embedded at build time; browser tests
  libjs-chart.js chromium chromium-driver python3-selenium
  # the test OpenID Connect provider of tests/server/oidc_test_idp.py (RS256 signing)
  python3-cryptography
  # fuzzing (libFuzzer) and the sanitized CI stage: deploy/fuzz.sh, deploy/ci-hardening.sh
  clang-14 libclang-rt-14-dev
)

missing=()
for pkg in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done
[ ${#missing[@]} -eq 0 ] && exit 0

if [ "$(id -u)" -ne 0 ]; then
  echo "install-deps: missing packages (${missing[*]}); run this script as root" >&2
  exit 1
fi
echo "install-deps: installing ${#missing[@]} package(s): ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
